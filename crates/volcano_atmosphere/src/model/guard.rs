//! The atmosphere's guard ([`volcano_core::fault`]): every cell of a layer or of the ground
//! whose state is no longer finite (or whose temperature is not positive, or whose amount of
//! water or ash is negative) is reset, and the water and ash it held are counted as lost. One
//! pass over the fields; [`step`](super::step::step) runs it before and after each step, in
//! every build.

use serde::Serialize;
use volcano_core::fault::finite_and_at_least;

use super::fields::{AtmosphereState, LayerFields};

/// What one [`repair`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct AtmosphereRepair {
    /// Layer and ground cells reset (and layers whose prevailing wind was reset).
    pub cells: u64,
    /// Water (vapour, condensed, on the ground) removed with them (g); an amount that was
    /// itself not finite counts as zero, a negative one with its sign.
    pub lost_water_g: f64,
    /// Ash (in the air, on the ground) removed with them (g), counted alike.
    pub lost_ash_g: f64,
}

impl std::ops::AddAssign for AtmosphereRepair {
    fn add_assign(&mut self, o: Self) {
        self.cells += o.cells;
        self.lost_water_g += o.lost_water_g;
        self.lost_ash_g += o.lost_ash_g;
    }
}

impl AtmosphereRepair {
    /// Whether anything was repaired.
    pub fn any(&self) -> bool {
        self.cells > 0
    }
}

/// An amount that can be booked: finite (of either sign), else 0.
fn known(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}

/// Finds and repairs non-finite state (see the module docs). A reset layer cell is at rest
/// (no wind, vertical velocity or pressure potential) at the layer's reference temperature,
/// dry and free of ash; a reset ground cell is at the lowest layer's reference temperature,
/// dry and free of ash. A valid state is left bit for bit as it was.
pub fn repair(state: &mut AtmosphereState) -> AtmosphereRepair {
    let mut out = AtmosphereRepair::default();
    let dx2 = state.grid.dx * state.grid.dx;
    for layer in &mut state.layers {
        out += repair_layer(layer, dx2);
    }
    let t_ground = state.layers.first().map_or(288.0, |l| l.t_ref);
    let g = &mut state.ground;
    if finite_and_at_least(g.t.data(), f64::MIN_POSITIVE)
        && finite_and_at_least(g.water.data(), 0.0)
        && finite_and_at_least(g.ash.data(), 0.0)
    {
        return out;
    }
    let n = g.t.data().len().min(g.water.data().len()).min(g.ash.data().len());
    for k in 0..n {
        let (t, water, ash) = (g.t.data()[k], g.water.data()[k], g.ash.data()[k]);
        let ok =
            t.is_finite() && t > 0.0 && water.is_finite() && water >= 0.0 && ash.is_finite() && ash >= 0.0;
        if !ok {
            out.cells += 1;
            out.lost_water_g += known(water) * dx2;
            out.lost_ash_g += known(ash) * dx2;
            g.t.data_mut()[k] = t_ground;
            g.water.data_mut()[k] = 0.0;
            g.ash.data_mut()[k] = 0.0;
        }
    }
    out
}

/// The fast path for one layer (see [`finite_and_at_least`]).
fn layer_healthy(l: &LayerFields) -> bool {
    let any = f64::NEG_INFINITY;
    finite_and_at_least(l.t.data(), f64::MIN_POSITIVE)
        && [l.u.data(), l.v.data(), l.c.data(), l.up.data(), l.d.data()]
            .iter()
            .all(|g| finite_and_at_least(g, any))
        && finite_and_at_least(l.p.data(), any)
        && [l.h.data(), l.w.data(), l.ash.data()].iter().all(|g| finite_and_at_least(g, 0.0))
}

fn repair_layer(l: &mut LayerFields, dx2: f64) -> AtmosphereRepair {
    let mut out = AtmosphereRepair::default();
    // The layer's prevailing wind (the relaxation's target) is state too.
    if !l.wind.is_finite() {
        l.wind = bevy::math::Vec2::ZERO;
        out.cells += 1;
    }
    if l.wind_relaxation_s.is_some_and(|t| !(t.is_finite() && t > 0.0)) {
        l.wind_relaxation_s = None;
        out.cells += 1;
    }
    if layer_healthy(l) {
        return out;
    }
    let n = l.t.data().len();
    let amount = |x: f64| x.is_finite() && x >= 0.0;
    for k in 0..n {
        let t = l.t.data()[k];
        let ok = t.is_finite()
            && t > 0.0
            && [&l.u, &l.v, &l.c, &l.up, &l.d].iter().all(|g| g.data()[k].is_finite())
            && l.p.data()[k].is_finite()
            && [&l.h, &l.w, &l.ash].iter().all(|g| amount(g.data()[k]));
        if ok {
            continue;
        }
        out.cells += 1;
        // Concentrations (g/m³) × the cell's free volume.
        let sigma = l.sigma.data().get(k).copied().filter(|s| s.is_finite()).unwrap_or(1.0) as f64;
        let volume = dx2 * l.thickness * sigma;
        out.lost_water_g += (known(l.h.data()[k]) + known(l.w.data()[k])) * volume;
        out.lost_ash_g += known(l.ash.data()[k]) * volume;
        l.t.data_mut()[k] = l.t_ref;
        for g in [&mut l.u, &mut l.v, &mut l.c, &mut l.up, &mut l.d] {
            g.data_mut()[k] = 0.0;
        }
        for g in [&mut l.p, &mut l.h, &mut l.w, &mut l.ash] {
            g.data_mut()[k] = 0.0;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::scenario::WeatherScenario;
    use crate::model::step::{Workspace, step};

    #[test]
    fn bad_cells_are_reset_and_the_water_they_held_is_booked() {
        let s = WeatherScenario::builtin("convection").unwrap();
        let mut st = s.build(Some(32)).unwrap();
        let mut work = Workspace::new(&st).unwrap();
        for _ in 0..3 {
            let r = step(&mut st, &s.params, &mut work, s.dt).unwrap();
            assert!(!r.repaired.any(), "a healthy atmosphere needs no repair");
        }
        let dx2 = st.grid.dx * st.grid.dx;
        let (a, b, c) = (100, 300, 500);
        let l = &mut st.layers[0];
        let vol = |l: &LayerFields, k: usize| dx2 * l.thickness * l.sigma.data()[k] as f64;
        let mut lost =
            (l.h.data()[a] + l.w.data()[a]) * vol(l, a) + (l.h.data()[b] + l.w.data()[b]) * vol(l, b);
        l.t.data_mut()[a] = f32::NAN;
        l.u.data_mut()[b] = f32::INFINITY;
        st.ground.water.data_mut()[c] = -5.0;
        lost += -5.0 * dx2;
        let ash = 2.0;
        st.layers[1].ash.data_mut()[a] = ash;
        st.layers[1].d.data_mut()[a] = f32::NAN;
        lost += (st.layers[1].h.data()[a] + st.layers[1].w.data()[a]) * vol(&st.layers[1], a);
        let water = st.water_total();
        let r = step(&mut st, &s.params, &mut work, s.dt).unwrap().repaired;
        assert_eq!(r.cells, 4, "{r:?}");
        assert!((r.lost_water_g - lost).abs() <= 1e-9 * lost.abs(), "{} g vs {lost} g", r.lost_water_g);
        assert!((r.lost_ash_g - ash * vol(&st.layers[1], a)).abs() < 1e-6, "{r:?}");
        assert!(st.is_valid());
        // The step itself conserves water: what is left is what was there less what the
        // guard removed.
        let after = st.water_total();
        assert!(
            ((after - (water - r.lost_water_g)) / water).abs() < 1e-9,
            "{after} g vs {water} − {} g",
            r.lost_water_g
        );
    }

    #[test]
    fn a_valid_state_is_left_as_it_was() {
        let s = WeatherScenario::builtin("convection").unwrap();
        let mut st = s.build(Some(16)).unwrap();
        let mut work = Workspace::new(&st).unwrap();
        step(&mut st, &s.params, &mut work, s.dt).unwrap();
        let before = st.clone();
        assert!(!repair(&mut st).any());
        assert_eq!(st, before);
    }
}
