//! The state of the layered atmosphere: per-layer fields (thesis Table 4.2), the ground under
//! them, and the layer geometry (irregular altitudes, thicknesses, terrain cut-through).
//!
//! Grids are `n × n` cells on a torus with square cells of size `dx`. Scalars sit at cell
//! centres; the wind is staggered (MAC): `u[i, j]` on the west face of cell `(i, j)`, `v[i, j]`
//! on its south face, so the discrete divergence and gradient compose exactly to the 5-point
//! Laplacian of the multigrid solver.

use bevy::math::Vec2;
use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::{ConfigError, Grid2, LandCover};

use super::multigrid::check_grid_size;
use super::thermo::layer_pressure;

/// Grid shape shared by every layer and the ground.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
pub struct GridSpec {
    /// Cells per side (power of two, 16–4096).
    pub n: usize,
    /// Cell size (m).
    pub dx: f64,
}

impl GridSpec {
    /// Validated grid: `n` a power of two in [16, 4096], `dx` in (0, 100 km].
    pub fn new(n: usize, dx: f64) -> Result<Self, ConfigError> {
        check_grid_size(n)?;
        volcano_core::error::in_range("cell size", dx, 1e-3, 1e5)?;
        Ok(Self { n, dx })
    }
    /// Side length of the domain (m).
    pub fn extent(&self) -> f64 {
        self.n as f64 * self.dx
    }
    /// Cell count.
    pub fn cells(&self) -> usize {
        self.n * self.n
    }
    /// World position (grid x, grid y) of the first cell centre; the domain is centred on 0.
    pub fn origin(&self) -> Vec2 {
        Vec2::splat((-0.5 * self.extent() + 0.5 * self.dx) as f32)
    }
    /// A grid of this shape filled with `value`.
    pub fn grid<T: Copy>(&self, value: T) -> Grid2<T> {
        Grid2::new(self.n, self.n, self.dx, self.origin(), value).expect("GridSpec is validated")
    }
    /// World position (grid x, grid y) of cell `k`'s centre.
    pub fn centre(&self, k: usize) -> (f64, f64) {
        let o = self.origin();
        (o.x as f64 + (k % self.n) as f64 * self.dx, o.y as f64 + (k / self.n) as f64 * self.dx)
    }
}

/// Vertical extent of each layer from the user's altitudes: boundaries at the midpoints
/// between neighbours; the lowest layer reaches down symmetrically and the top one up by the
/// same half-gap. Returns `(bottom, thickness)` per layer. Altitudes must be finite and
/// strictly increasing (at least 1 m apart); at least two layers.
pub fn layer_geometry(altitudes: &[f64]) -> Result<Vec<(f64, f64)>, ConfigError> {
    if altitudes.len() < 2 {
        return Err(ConfigError::InvalidParameter {
            name: "layers",
            value: altitudes.len() as f64,
            reason: "need at least two layers (vertical exchange works between pairs)".into(),
        });
    }
    for (k, &a) in altitudes.iter().enumerate() {
        volcano_core::error::in_range("layer altitude", a, -500.0, 30_000.0)?;
        if k > 0 && a < altitudes[k - 1] + 1.0 {
            return Err(ConfigError::InvalidParameter {
                name: "layer altitude",
                value: a,
                reason: format!(
                    "layers must be in increasing order of altitude, at least 1 m apart \
                     (layer {k} at {a} m is not above layer {} at {} m)",
                    k - 1,
                    altitudes[k - 1]
                ),
            });
        }
    }
    let n = altitudes.len();
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let lo = if k == 0 {
            altitudes[0] - 0.5 * (altitudes[1] - altitudes[0])
        } else {
            0.5 * (altitudes[k - 1] + altitudes[k])
        };
        let hi = if k + 1 == n {
            altitudes[k] + 0.5 * (altitudes[k] - altitudes[k - 1])
        } else {
            0.5 * (altitudes[k] + altitudes[k + 1])
        };
        out.push((lo, hi - lo));
    }
    Ok(out)
}

/// All fields of one air layer (thesis Table 4.2), one grid per quantity.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerFields {
    /// Θ_i, the layer's altitude (m).
    pub altitude: f64,
    /// Altitude of the layer's lower boundary (m).
    pub bottom: f64,
    /// h_i, thickness (m).
    pub thickness: f64,
    /// Π_i, mean atmospheric pressure of the layer (Pa), eq. (4.2) with the erratum.
    pub pi: f64,
    /// T_i, temperature (K).
    pub t: Grid2<f32>,
    /// Reference temperature (K) the layer relaxes toward (its initial profile value).
    pub t_ref: f32,
    /// H_i, absolute humidity (g/m³).
    pub h: Grid2<f64>,
    /// W_i, condensed water content (g/m³).
    pub w: Grid2<f64>,
    /// Volcanic ash concentration (g/m³), a passive conservative tracer for coupling.
    pub ash: Grid2<f64>,
    /// V_i, x component on west faces (m/s).
    pub u: Grid2<f32>,
    /// V_i, y component on south faces (m/s).
    pub v: Grid2<f32>,
    /// P_i, dynamic pressure potential (m²/s): the projection subtracts ∇P from V.
    pub p: Grid2<f64>,
    /// C_i, convective velocity at the top of the layer (m/s).
    pub c: Grid2<f32>,
    /// U_i, non-convective uplift at the top of the layer (m/s).
    pub up: Grid2<f32>,
    /// D_i = C_i + U_i, vertical velocity through the top of the layer (m/s).
    pub d: Grid2<f32>,
    /// σ_i, free (not terrain) fraction of the layer's slab, eq. (4.8).
    pub sigma: Grid2<f32>,
    /// Prevailing wind (m/s) the layer relaxes toward when `wind_relaxation_s` is set.
    pub wind: Vec2,
    /// Relaxation time (s) toward the prevailing wind (synoptic forcing); `None` = free.
    pub wind_relaxation_s: Option<f64>,
    /// Cells inside an entraining column, set by the plume → air coupling before a step:
    /// `(cell, temperature seen from outside)`. The horizontal advection of T reads the given
    /// temperature there instead of the cell's and leaves the cell's own T as it was, and air
    /// sinking from such a cell into the layer below carries the given temperature: the column
    /// draws the air around it in and carries its heat up, so its air neither leaves sideways
    /// nor sinks (docs/ARCHITECTURE.md §1.4). Empty for a free atmosphere.
    pub entraining: Vec<(u32, f32)>,
}

impl LayerFields {
    /// A layer at rest, temperature `t`, dry, no terrain.
    pub fn new(grid: GridSpec, altitude: f64, bottom: f64, thickness: f64, t: f32) -> Self {
        Self {
            altitude,
            bottom,
            thickness,
            pi: layer_pressure(altitude),
            t: grid.grid(t),
            t_ref: t,
            h: grid.grid(0.0),
            w: grid.grid(0.0),
            ash: grid.grid(0.0),
            u: grid.grid(0.0),
            v: grid.grid(0.0),
            p: grid.grid(0.0),
            c: grid.grid(0.0),
            up: grid.grid(0.0),
            d: grid.grid(0.0),
            sigma: grid.grid(1.0),
            wind: Vec2::ZERO,
            wind_relaxation_s: None,
            entraining: Vec::new(),
        }
    }

    /// Water (vapour + condensed) in the layer (g), amounts = concentration × free volume.
    pub fn water_grams(&self, dx: f64) -> f64 {
        let vol = self.thickness * dx * dx;
        let s = self.sigma.data();
        self.h.data().iter().zip(self.w.data()).zip(s).map(|((h, w), &s)| (h + w) * s as f64).sum::<f64>()
            * vol
    }

    /// Whether every field is finite and the amounts non-negative.
    pub fn is_valid(&self) -> bool {
        let f32ok = |g: &Grid2<f32>| g.data().iter().all(|x| x.is_finite());
        let amount = |g: &Grid2<f64>| g.data().iter().all(|x| x.is_finite() && *x >= 0.0);
        f32ok(&self.t)
            && f32ok(&self.u)
            && f32ok(&self.v)
            && f32ok(&self.c)
            && f32ok(&self.up)
            && f32ok(&self.d)
            && self.p.data().iter().all(|x| x.is_finite())
            && amount(&self.h)
            && amount(&self.w)
            && amount(&self.ash)
            && self.t.data().iter().all(|&t| t > 0.0)
    }
}

impl Default for LayerFields {
    /// An empty 1 × 1 layer (a placeholder while fields are moved in and out of components).
    fn default() -> Self {
        let g = |v| Grid2::new(1, 1, 1.0, Vec2::ZERO, v).expect("1×1 grid is valid");
        let g64 = |v| Grid2::new(1, 1, 1.0, Vec2::ZERO, v).expect("1×1 grid is valid");
        Self {
            altitude: 0.0,
            bottom: 0.0,
            thickness: 1.0,
            pi: layer_pressure(0.0),
            t: g(288.0),
            t_ref: 288.0,
            h: g64(0.0),
            w: g64(0.0),
            ash: g64(0.0),
            u: g(0.0),
            v: g(0.0),
            p: g64(0.0),
            c: g(0.0),
            up: g(0.0),
            d: g(0.0),
            sigma: g(1.0),
            wind: Vec2::ZERO,
            wind_relaxation_s: None,
            entraining: Vec::new(),
        }
    }
}

/// Surface properties of a land cover (docs/physics/atmosphere.md §5.5 numbers; snow and vegetation
/// heat capacity are estimates: ice 2100, wet soil ≈ soil).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoverProps {
    /// B, albedo.
    pub albedo: f32,
    /// ε, long-wave emissivity.
    pub emissivity: f32,
    /// Specific heat capacity (J/(kg·K)).
    pub heat_capacity: f32,
    /// Bulk density (kg/m³) of the active layer.
    pub density: f32,
}

/// Properties of each land cover: water 0.1/0.952/4000, soil 0.2/0.91/800, vegetation
/// 0.2/0.94/800 (docs/physics/atmosphere.md §5.5), snow 0.8/0.98/2100 (fresh snow albedo, ice heat
/// capacity).
pub fn cover_props(cover: LandCover) -> CoverProps {
    match cover {
        LandCover::Water => {
            CoverProps { albedo: 0.1, emissivity: 0.952, heat_capacity: 4000.0, density: 1000.0 }
        }
        LandCover::Ground => {
            CoverProps { albedo: 0.2, emissivity: 0.91, heat_capacity: 800.0, density: 1600.0 }
        }
        LandCover::Vegetation => {
            CoverProps { albedo: 0.2, emissivity: 0.94, heat_capacity: 800.0, density: 1600.0 }
        }
        LandCover::Snow => {
            CoverProps { albedo: 0.8, emissivity: 0.98, heat_capacity: 2100.0, density: 400.0 }
        }
    }
}

/// The ground under the atmosphere (thesis §4.2.5).
#[derive(Debug, Clone, PartialEq)]
pub struct Ground {
    /// Θ_T, terrain altitude (m), sampled at the atmosphere's cell centres.
    pub height: Grid2<f32>,
    /// Land cover.
    pub cover: Grid2<LandCover>,
    /// T_T, ground temperature (K).
    pub t: Grid2<f32>,
    /// M_T, water on or in the ground (g/m²), including water bodies' active layer.
    pub water: Grid2<f64>,
    /// Fraction of direct sunlight reaching each cell (0 = shadowed), cached per sun position.
    pub sunlit: Grid2<f32>,
    /// Sun direction the `sunlit` map was computed for.
    pub sunlit_for: Option<[f32; 3]>,
    /// ℓ(p): index of the lowest layer with air at each cell (`u8::MAX` if none).
    pub lowest: Vec<u8>,
    /// Ash fallen on the ground (g/m²) since it was last collected (the coupling moves it to
    /// the terrain's deposit after each step; without coupling it accumulates here).
    pub ash: Grid2<f64>,
}

impl Default for Ground {
    /// An empty 1 × 1 ground (a placeholder while moved in and out of components).
    fn default() -> Self {
        Self {
            height: Grid2::new(1, 1, 1.0, Vec2::ZERO, 0.0).expect("1×1 grid is valid"),
            cover: Grid2::new(1, 1, 1.0, Vec2::ZERO, LandCover::Ground).expect("1×1 grid is valid"),
            t: Grid2::new(1, 1, 1.0, Vec2::ZERO, 288.0).expect("1×1 grid is valid"),
            water: Grid2::new(1, 1, 1.0, Vec2::ZERO, 0.0).expect("1×1 grid is valid"),
            sunlit: Grid2::new(1, 1, 1.0, Vec2::ZERO, 1.0).expect("1×1 grid is valid"),
            sunlit_for: None,
            lowest: vec![0],
            ash: Grid2::new(1, 1, 1.0, Vec2::ZERO, 0.0).expect("1×1 grid is valid"),
        }
    }
}

/// The whole simulated atmosphere: layers bottom to top, ground, clock and budgets.
#[derive(Debug, Clone, PartialEq)]
pub struct AtmosphereState {
    /// Grid shape.
    pub grid: GridSpec,
    /// Layers, lowest first.
    pub layers: Vec<LayerFields>,
    /// Ground under them.
    pub ground: Ground,
    /// Simulated time since the start (s).
    pub time_s: f64,
    /// Local solar time at `time_s = 0` (hours).
    pub start_hour: f64,
    /// Day of the year (1–365) at the start.
    pub day_of_year: f64,
    /// Latitude (degrees, north positive).
    pub latitude_deg: f64,
    /// Water precipitated to the ground since the start (g).
    pub precipitated: f64,
}

impl AtmosphereState {
    /// Total water: vapour + condensed in every layer + ground water (g). Precipitation is
    /// already part of the ground water; [`AtmosphereState::precipitated`] is its tally.
    pub fn water_total(&self) -> f64 {
        let air: f64 = self.layers.iter().map(|l| l.water_grams(self.grid.dx)).sum();
        let a = self.grid.dx * self.grid.dx;
        air + self.ground.water.data().iter().sum::<f64>() * a
    }

    /// Water in the air only (g).
    pub fn air_water(&self) -> f64 {
        self.layers.iter().map(|l| l.water_grams(self.grid.dx)).sum()
    }

    /// Local solar time (hours, 0–24) now.
    pub fn local_hour(&self) -> f64 {
        (self.start_hour + self.time_s / 3600.0).rem_euclid(24.0)
    }

    /// Day of year now (fractional days carried over midnight).
    pub fn day_now(&self) -> f64 {
        self.day_of_year + ((self.start_hour + self.time_s / 3600.0) / 24.0).floor()
    }

    /// Checks the clock and books: the time since the start and the water precipitated finite
    /// and non-negative, the start hour in [0, 24], the day of the year in [1, 366], the
    /// latitude in [−90, 90] (the sun's position, hence every cell's heating, comes from them).
    pub fn check_clock(&self) -> Result<(), ConfigError> {
        use volcano_core::error::in_range;
        in_range("time_s", self.time_s, 0.0, f64::MAX)?;
        in_range("start_hour", self.start_hour, 0.0, 24.0)?;
        in_range("day_of_year", self.day_of_year, 1.0, 366.0)?;
        in_range("latitude_deg", self.latitude_deg, -90.0, 90.0)?;
        in_range("precipitated", self.precipitated, 0.0, f64::MAX)?;
        Ok(())
    }

    /// Checks that every layer and ground grid has the state's `n × n` shape and that there
    /// are 2–255 layers (a state assembled by hand could otherwise make a step index out of
    /// range).
    pub fn check_shape(&self) -> Result<(), ConfigError> {
        let n = self.grid.n;
        let bad = |what: &'static str, got: usize| ConfigError::InvalidParameter {
            name: what,
            value: got as f64,
            reason: format!("must have the state's {n}×{n} cells"),
        };
        if !(2..=255).contains(&self.layers.len()) {
            return Err(ConfigError::InvalidParameter {
                name: "layers",
                value: self.layers.len() as f64,
                reason: "need 2 to 255 layers".into(),
            });
        }
        for l in &self.layers {
            let sizes = [
                l.t.data().len(),
                l.h.data().len(),
                l.w.data().len(),
                l.ash.data().len(),
                l.u.data().len(),
                l.v.data().len(),
                l.p.data().len(),
                l.c.data().len(),
                l.up.data().len(),
                l.d.data().len(),
                l.sigma.data().len(),
            ];
            if let Some(&s) = sizes.iter().find(|&&s| s != n * n) {
                return Err(bad("layer field size", s));
            }
            if let Some(&(k, t)) =
                l.entraining.iter().find(|&&(k, t)| k as usize >= n * n || !(t > 0.0 && t.is_finite()))
            {
                return Err(ConfigError::InvalidParameter {
                    name: "entraining cell",
                    value: if k as usize >= n * n { k as f64 } else { t as f64 },
                    reason: format!(
                        "cells must be < {} and their outside temperature finite and > 0 K",
                        n * n
                    ),
                });
            }
            if l.t.nx() != n {
                return Err(bad("layer grid width", l.t.nx()));
            }
            if !(l.thickness.is_finite() && l.thickness > 0.0 && l.pi.is_finite() && l.pi > 0.0) {
                return Err(bad("layer geometry", 0));
            }
        }
        let g = &self.ground;
        for s in [g.height.data().len(), g.cover.data().len(), g.t.data().len(), g.water.data().len()] {
            if s != n * n {
                return Err(bad("ground field size", s));
            }
        }
        if g.sunlit.data().len() != n * n || g.lowest.len() != n * n || g.ash.data().len() != n * n {
            return Err(bad("ground field size", g.lowest.len()));
        }
        Ok(())
    }

    /// Whether every field is finite and every amount non-negative.
    pub fn is_valid(&self) -> bool {
        self.layers.iter().all(|l| l.is_valid())
            && self.ground.t.data().iter().all(|t| t.is_finite() && *t > 0.0)
            && self.ground.water.data().iter().all(|w| w.is_finite() && *w >= 0.0)
            && self.ground.ash.data().iter().all(|a| a.is_finite() && *a >= 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn irregular_layers_get_midpoint_thicknesses() {
        let g = layer_geometry(&[500.0, 1500.0, 4000.0]).unwrap();
        assert_eq!(g[0], (0.0, 1000.0));
        assert_eq!(g[1], (1000.0, 1750.0));
        assert_eq!(g[2], (2750.0, 2500.0));
        assert!(layer_geometry(&[1000.0, 500.0]).unwrap_err().to_string().contains("increasing order"));
        assert!(layer_geometry(&[1000.0]).is_err());
        assert!(layer_geometry(&[0.0, f64::NAN]).is_err());
    }

    #[test]
    fn grid_spec_validation() {
        assert!(GridSpec::new(64, 100.0).is_ok());
        assert!(GridSpec::new(60, 100.0).is_err());
        assert!(GridSpec::new(64, 0.0).is_err());
        assert!(GridSpec::new(64, f64::INFINITY).is_err());
        let g = GridSpec::new(16, 10.0).unwrap();
        assert_eq!(g.centre(0), (-75.0, -75.0));
        // A hand-assembled state with a mismatched layer is rejected, not indexed out of range.
        let mut st =
            crate::model::scenario::WeatherScenario::builtin("convection").unwrap().build(Some(16)).unwrap();
        st.check_shape().unwrap();
        st.layers[1] = LayerFields::default();
        assert!(st.check_shape().is_err());
        assert_eq!(g.centre(17), (-65.0, -65.0));
    }
}
