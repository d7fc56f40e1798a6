//! Painting into a layer's fields (authoring, thesis §4.2: "the user paints hot spots,
//! humidity, wind…"): a round brush that sets or adds a value in the state fields T, H, W,
//! ash and the two wind components. The derived fields (P, C, U, D, σ) are recomputed by
//! every step, so they are shown but not painted.
//!
//! Values are validated, not silently accepted: a non-finite value, a `Set` outside the
//! field's limits or a brush outside the domain is an error; an `Add` is clamped to the
//! limits. Amounts (H, W, ash) are never negative and stay zero inside terrain (σ = 0).

use serde::{Deserialize, Serialize};
use volcano_core::ConfigError;
use volcano_core::error::{finite, in_range, positive};

use super::fields::{GridSpec, LayerFields};

/// A paintable field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum PaintField {
    /// T (K).
    Temperature,
    /// H (g/m³).
    Humidity,
    /// W (g/m³).
    Water,
    /// Ash (g/m³).
    Ash,
    /// Wind x component (m/s), on the west faces.
    WindX,
    /// Wind y component (m/s), on the south faces.
    WindY,
}

impl PaintField {
    /// Every paintable field.
    pub const ALL: [PaintField; 6] = [
        PaintField::Temperature,
        PaintField::Humidity,
        PaintField::Water,
        PaintField::Ash,
        PaintField::WindX,
        PaintField::WindY,
    ];

    /// Accepted values (inclusive).
    pub fn limits(self) -> (f64, f64) {
        match self {
            PaintField::Temperature => (150.0, 350.0),
            // Saturation at 50 °C is ≈ 83 g/m³.
            PaintField::Humidity => (0.0, 100.0),
            PaintField::Water => (0.0, 50.0),
            PaintField::Ash => (0.0, 1.0e4),
            PaintField::WindX | PaintField::WindY => (-100.0, 100.0),
        }
    }

    /// Whether the field is an amount that cannot exist inside terrain.
    pub fn is_amount(self) -> bool {
        matches!(self, PaintField::Humidity | PaintField::Water | PaintField::Ash)
    }

    /// Short name with unit.
    pub fn label(self) -> &'static str {
        match self {
            PaintField::Temperature => "T (K)",
            PaintField::Humidity => "H (g/m³)",
            PaintField::Water => "W (g/m³)",
            PaintField::Ash => "ash (g/m³)",
            PaintField::WindX => "wind x (m/s)",
            PaintField::WindY => "wind y (m/s)",
        }
    }
}

/// What a stroke does to the cells under the brush.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum PaintMode {
    /// Replace the value.
    Set,
    /// Add the value, weighted by a smooth falloff `1 − (r/R)²`, then clamp to the limits.
    Add,
}

/// One brush stroke.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Brush {
    /// Field painted.
    pub field: PaintField,
    /// Set or add.
    pub mode: PaintMode,
    /// The value (or increment).
    pub value: f64,
    /// Brush centre, grid x (m; the domain is centred on 0).
    pub x_m: f64,
    /// Brush centre, grid y (m).
    pub y_m: f64,
    /// Brush radius (m).
    pub radius_m: f64,
}

impl Brush {
    /// Checks the brush against a grid; the error names the offending value.
    pub fn validate(&self, grid: GridSpec) -> Result<(), ConfigError> {
        let (lo, hi) = self.field.limits();
        finite("brush value", self.value)?;
        match self.mode {
            PaintMode::Set => {
                in_range("brush value", self.value, lo, hi)?;
            }
            PaintMode::Add => {
                in_range("brush increment", self.value, -(hi - lo), hi - lo)?;
            }
        }
        let half = 0.5 * grid.extent();
        in_range("brush x", self.x_m, -half, half)?;
        in_range("brush y", self.y_m, -half, half)?;
        positive("brush radius", self.radius_m)?;
        in_range("brush radius", self.radius_m, 0.0, grid.extent())?;
        Ok(())
    }
}

/// Paints one stroke into `layer` (periodic domain). Returns the number of cells changed.
pub fn paint(layer: &mut LayerFields, grid: GridSpec, brush: &Brush) -> Result<usize, ConfigError> {
    brush.validate(grid)?;
    if layer.t.nx() != grid.n {
        return Err(ConfigError::InvalidParameter {
            name: "layer size",
            value: layer.t.nx() as f64,
            reason: format!("the grid has {} cells per side", grid.n),
        });
    }
    let (lo, hi) = brush.field.limits();
    let l = grid.extent();
    let wrap = |d: f64| d - l * (d / l).round();
    // Face-centred wind components sit half a cell west / south of the cell centre.
    let (ox, oy) = match brush.field {
        PaintField::WindX => (-0.5 * grid.dx, 0.0),
        PaintField::WindY => (0.0, -0.5 * grid.dx),
        _ => (0.0, 0.0),
    };
    let sigma = layer.sigma.data().to_vec();
    let mut changed = 0;
    for (k, &free) in sigma.iter().enumerate() {
        let (x, y) = grid.centre(k);
        let (dx, dy) = (wrap(x + ox - brush.x_m), wrap(y + oy - brush.y_m));
        let r2 = (dx * dx + dy * dy) / (brush.radius_m * brush.radius_m);
        if r2 > 1.0 {
            continue;
        }
        if brush.field.is_amount() && free <= 0.0 {
            continue;
        }
        let new = |old: f64| -> f64 {
            let v = match brush.mode {
                PaintMode::Set => brush.value,
                PaintMode::Add => old + brush.value * (1.0 - r2),
            };
            v.clamp(lo, hi)
        };
        match brush.field {
            PaintField::Temperature => set32(&mut layer.t.data_mut()[k], new),
            PaintField::Humidity => layer.h.data_mut()[k] = new(layer.h.data()[k]),
            PaintField::Water => layer.w.data_mut()[k] = new(layer.w.data()[k]),
            PaintField::Ash => layer.ash.data_mut()[k] = new(layer.ash.data()[k]),
            PaintField::WindX => set32(&mut layer.u.data_mut()[k], new),
            PaintField::WindY => set32(&mut layer.v.data_mut()[k], new),
        }
        changed += 1;
    }
    Ok(changed)
}

fn set32(x: &mut f32, f: impl Fn(f64) -> f64) {
    *x = f(*x as f64) as f32;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::scenario::WeatherScenario;

    fn state() -> crate::AtmosphereState {
        WeatherScenario::builtin("orographic").unwrap().build(Some(32)).unwrap()
    }

    fn brush(field: PaintField, mode: PaintMode, value: f64) -> Brush {
        Brush { field, mode, value, x_m: 0.0, y_m: 0.0, radius_m: 3000.0 }
    }

    #[test]
    fn set_paints_a_disc_and_nothing_else() {
        let mut st = state();
        let g = st.grid;
        let layer = &mut st.layers[2];
        let before = layer.t.data().to_vec();
        let n = paint(layer, g, &brush(PaintField::Temperature, PaintMode::Set, 300.0)).unwrap();
        assert!(n > 0);
        for (k, old) in before.iter().enumerate() {
            let (x, y) = g.centre(k);
            let inside = x * x + y * y <= 3000.0 * 3000.0;
            assert_eq!(layer.t.data()[k] == 300.0, inside || *old == 300.0, "cell {k}");
        }
    }

    #[test]
    fn bad_values_are_errors_and_adds_are_clamped() {
        let mut st = state();
        let g = st.grid;
        let layer = &mut st.layers[1];
        let snapshot = layer.clone();
        for (f, m, v) in [
            (PaintField::Humidity, PaintMode::Set, -1.0),
            (PaintField::Temperature, PaintMode::Set, 1000.0),
            (PaintField::Water, PaintMode::Add, f64::NAN),
            (PaintField::WindX, PaintMode::Set, f64::INFINITY),
        ] {
            assert!(paint(layer, g, &brush(f, m, v)).is_err(), "{f:?} {m:?} {v}");
        }
        let mut off = brush(PaintField::Water, PaintMode::Set, 1.0);
        off.x_m = 1e9;
        assert!(paint(layer, g, &off).is_err());
        off = brush(PaintField::Water, PaintMode::Set, 1.0);
        off.radius_m = 0.0;
        assert!(paint(layer, g, &off).is_err());
        assert_eq!(*layer, snapshot, "a rejected stroke changes nothing");
        // A large negative add clamps amounts at 0.
        paint(layer, g, &brush(PaintField::Humidity, PaintMode::Add, -100.0)).unwrap();
        assert!(layer.h.data().iter().all(|h| *h >= 0.0 && h.is_finite()));
        assert!(layer.h.data().contains(&0.0));
    }

    #[test]
    fn amounts_stay_out_of_terrain() {
        let mut st = state();
        let g = st.grid;
        // The orographic ridge (1.5 km) cuts the lowest layer (slab 0–800 m) along x = 0,
        // wherever the ground is above 800 m (|x| ≲ 3.3 km): the brush reaches beyond.
        let layer = &mut st.layers[0];
        assert!(layer.sigma.data().iter().any(|s| *s <= 0.0), "the ridge should cut layer 0");
        let wide = Brush { radius_m: 5000.0, ..brush(PaintField::Water, PaintMode::Set, 2.0) };
        paint(layer, g, &wide).unwrap();
        for (w, s) in layer.w.data().iter().zip(layer.sigma.data()) {
            if *s <= 0.0 {
                assert_eq!(*w, 0.0);
            }
        }
        assert!(layer.w.data().contains(&2.0));
        assert!(layer.is_valid());
    }
}
