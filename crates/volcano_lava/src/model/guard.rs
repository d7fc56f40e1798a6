//! The lava domain's guard ([`volcano_core::fault`]): every cell whose state is no longer
//! finite (or whose thickness is negative) is reset to an empty cell, its liquid lava booked as
//! [`VolumeBudget::faulted`](super::budget::VolumeBudget::faulted), and fold particles and
//! surface samples that are no longer finite are removed. A healthy field costs one
//! vectorised, parallel pass over its carried grids; run on every step in every build.

use volcano_core::fault::{finite_and_at_least, finite_by};
use volcano_core::parallel::Bands;

use super::LayersMut;
use super::breakout::BreakoutState;
use super::field::FlowField;
use super::folds::{FoldSystem, bury};
use super::surface::SurfaceState;

/// What one [`repair`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LavaRepair {
    /// Cells reset.
    pub cells: u64,
    /// Fold particles and surface samples removed.
    pub particles: u64,
    /// Liquid lava removed with the cells (m³), booked as `faulted`.
    pub lost_m3: f64,
}

impl std::ops::AddAssign for LavaRepair {
    fn add_assign(&mut self, o: Self) {
        self.cells += o.cells;
        self.particles += o.particles;
        self.lost_m3 += o.lost_m3;
    }
}

impl LavaRepair {
    /// Whether anything was repaired.
    pub fn any(&self) -> bool {
        self.cells > 0 || self.particles > 0
    }
}

/// The fast path: every carried value finite, every thickness and crust non-negative, every
/// temperature positive ([`finite_and_at_least`], bands of rows in parallel: ≈ 3 % of a step
/// of a 256² field). The velocities, surface velocities and divergence are left out: each step
/// writes them before it reads them, and a bad value there shows in the carried state a step
/// later.
fn healthy(flow: &FlowField, surface: &SurfaceState, folds: &FoldSystem, breakouts: &BreakoutState) -> bool {
    let (nx, ny) = (flow.nx(), flow.ny());
    let sized = |v: &[f64]| v.len() == nx * ny;
    if ![&flow.mob_factor, &surface.crust, &surface.contact, &breakouts.h_rigid].iter().all(|v| sized(v)) {
        return false;
    }
    let any = f64::NEG_INFINITY;
    let grids: [(&[f64], f64); 8] = [
        (flow.h.data(), 0.0),
        (flow.temp.data(), f64::MIN_POSITIVE),
        (flow.ground.data(), any),
        (flow.solid.data(), any),
        (&flow.mob_factor, any),
        (&surface.crust, 0.0),
        (&surface.contact, any),
        (&breakouts.h_rigid, any),
    ];
    let bands = Bands::of(64).map_ranges(ny, |rows| {
        let cells = rows.start * nx..rows.end * nx;
        grids.iter().all(|&(g, lo)| finite_and_at_least(&g[cells.clone()], lo))
    });
    let sample = |s: &super::samples::SurfaceSample| s.pos.x + s.pos.y + s.contact + s.crust;
    let fold = |q: &super::folds::FoldParticle| {
        q.pos.x
            + q.pos.y
            + q.spring_vel.x
            + q.spring_vel.y
            + q.vel.x
            + q.vel.y
            + q.tangent.x
            + q.tangent.y
            + q.thickness
            + q.age
            + q.offset
            + q.roll_height
            + q.roll_angle
    };
    bands.iter().all(|&ok| ok)
        && finite_by(&surface.samples.samples, sample)
        && finite_by(&folds.particles, fold)
}

/// Finds and repairs non-finite state in a lava field's layers (see the module docs). A reset
/// cell holds no lava, is at `air_temperature`, has no velocity, crust or rigid crust; a ground
/// height that is not finite becomes the mean of its finite neighbours (0 without any), and
/// its frozen lava (unknown) is forgotten. A valid state is left bit for bit as it was.
pub fn repair(layers: LayersMut<'_>, air_temperature: f64) -> LavaRepair {
    let LayersMut { flow, surface, folds, breakouts } = layers;
    let mut out = LavaRepair::default();
    if healthy(flow, surface, folds, breakouts) {
        return out;
    }
    let (nx, ny) = (flow.nx(), flow.ny());
    let area = flow.cell() * flow.cell();
    let crust_ok = surface.crust.len() == nx * ny;
    let rigid_ok = breakouts.h_rigid.len() == nx * ny;
    let bad_f = |x: f64| !x.is_finite();
    for k in 0..nx * ny {
        let h = flow.h.data()[k];
        let mut bad = bad_f(h)
            || h < 0.0
            || bad_f(flow.temp.data()[k])
            || flow.temp.data()[k] <= 0.0
            || bad_f(flow.ground.data()[k])
            || bad_f(flow.solid.data()[k])
            || bad_f(flow.vel[0].data()[k])
            || bad_f(flow.vel[1].data()[k])
            || flow.mob_factor.get(k).is_some_and(|&m| bad_f(m));
        if crust_ok {
            bad |= bad_f(surface.crust[k])
                || surface.crust[k] < 0.0
                || bad_f(surface.contact[k])
                || bad_f(surface.vsurf[0][k])
                || bad_f(surface.vsurf[1][k])
                || bad_f(surface.divergence[k]);
        }
        if rigid_ok {
            bad |= bad_f(breakouts.h_rigid[k]);
        }
        if !bad {
            continue;
        }
        out.cells += 1;
        if h.is_finite() {
            // A negative thickness is lava owed to the cell: booked with its sign, the
            // accounts still close.
            out.lost_m3 += h * area;
        }
        flow.h.data_mut()[k] = 0.0;
        flow.temp.data_mut()[k] = air_temperature;
        flow.vel[0].data_mut()[k] = 0.0;
        flow.vel[1].data_mut()[k] = 0.0;
        if let Some(m) = flow.mob_factor.get_mut(k) {
            *m = 1.0;
        }
        if !flow.solid.data()[k].is_finite() {
            flow.solid.data_mut()[k] = 0.0;
        }
        if !flow.ground.data()[k].is_finite() {
            let (i, j) = (k % nx, k / nx);
            let near = [(i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)];
            let finite: Vec<f64> = near
                .iter()
                .filter(|&&(a, b)| a < nx && b < ny)
                .map(|&(a, b)| flow.ground.data()[b * nx + a])
                .filter(|g| g.is_finite())
                .collect();
            let mean = if finite.is_empty() { 0.0 } else { finite.iter().sum::<f64>() / finite.len() as f64 };
            flow.ground.data_mut()[k] = mean;
            flow.solid.data_mut()[k] = 0.0;
        }
        if crust_ok {
            surface.crust[k] = 0.0;
            surface.contact[k] = 0.0;
            surface.vsurf[0][k] = 0.0;
            surface.vsurf[1][k] = 0.0;
            surface.divergence[k] = 0.0;
        }
        if rigid_ok {
            breakouts.h_rigid[k] = -1.0;
        }
    }
    flow.budget.faulted += out.lost_m3;
    let finite_sample =
        |s: &super::samples::SurfaceSample| s.pos.is_finite() && s.contact.is_finite() && s.crust.is_finite();
    let before = surface.samples.samples.len();
    surface.samples.samples.retain(finite_sample);
    out.particles += (before - surface.samples.samples.len()) as u64;
    let dead: Vec<bool> = folds
        .particles
        .iter()
        .map(|q| {
            !(q.pos.is_finite()
                && q.spring_vel.is_finite()
                && q.vel.is_finite()
                && q.tangent.is_finite()
                && q.thickness.is_finite()
                && q.age.is_finite()
                && q.offset.is_finite()
                && q.roll_height.is_finite()
                && q.roll_angle.is_finite())
        })
        .collect();
    if dead.contains(&true) {
        out.particles += u64::from(bury::remove(folds, &dead));
    }
    out
}

#[cfg(test)]
mod tests {
    use bevy::math::Vec2;

    use super::*;
    use crate::model::folds::FoldParams;
    use crate::model::params::LavaParams;
    use crate::model::step_layers;

    struct Layers(FlowField, SurfaceState, FoldSystem, BreakoutState);

    impl Layers {
        fn new() -> Self {
            let mut flow = FlowField::flat(24, 24, 0.5).unwrap();
            flow.place_volume(Vec2::new(6.0, 6.0), 2.0, 3.0, 1400.0).unwrap();
            let n = 24 * 24;
            Self(flow, SurfaceState::new(24, 24), FoldSystem::new(7), BreakoutState::new(n))
        }
        fn step(&mut self, p: &LavaParams) -> LavaRepair {
            let Layers(flow, surface, folds, breakouts) = self;
            let layers = LayersMut { flow, surface, folds, breakouts };
            step_layers(layers, p, &FoldParams::default(), &[], 0.02).repaired
        }
    }

    #[test]
    fn non_finite_cells_are_reset_and_their_lava_booked() {
        let p = LavaParams::default();
        let mut l = Layers::new();
        for _ in 0..20 {
            assert!(!l.step(&p).any(), "a healthy field needs no repair");
        }
        let f = &mut l.0;
        let wet: Vec<usize> = (0..24 * 24).filter(|&k| f.h.data()[k] > 1e-3).collect();
        assert!(wet.len() > 10);
        let area = 0.25;
        // NaN lava (unknown volume), lava at an infinite temperature (its volume is known),
        // a NaN ground under lava, and a negative thickness.
        let (a, b, c, d) = (wet[0], wet[3], wet[6], wet[9]);
        let known = (f.h.data()[b] + f.h.data()[c] - 0.01) * area;
        // What the edits themselves took away: the NaN cell's lava and the lava the negative
        // thickness replaced (the accounts cannot know either).
        let unknown = (f.h.data()[a] + f.h.data()[d] + 0.01) * area;
        f.h.data_mut()[a] = f64::NAN;
        f.temp.data_mut()[b] = f64::INFINITY;
        f.ground.data_mut()[c] = f64::NAN;
        f.h.data_mut()[d] = -0.01;
        let expected_ground = {
            let g = f.ground.data();
            (g[c - 1] + g[c + 1] + g[c - 24] + g[c + 24]) / 4.0
        };
        let r = l.step(&p);
        let f = &l.0;
        assert_eq!(r.cells, 4, "{r:?}");
        assert!((r.lost_m3 - known).abs() < 1e-12, "{} vs {known}", r.lost_m3);
        assert!(f.is_valid(), "the field is finite again");
        assert_eq!(f.ground.data()[c], expected_ground);
        for _ in 0..50 {
            assert!(!l.step(&p).any());
        }
        // The accounts close but for what the edits took away.
        let f = &l.0;
        assert_eq!(f.budget.faulted, r.lost_m3);
        let missing = f.budget.expected() - f.lava_volume();
        assert!(
            (missing - unknown).abs() < 1e-12 * 3.0,
            "{missing} m³ unaccounted, {unknown} m³ taken by the edits"
        );
    }

    #[test]
    fn a_valid_state_is_left_as_it_was() {
        let p = LavaParams::default();
        let mut l = Layers::new();
        for _ in 0..30 {
            l.step(&p);
        }
        let before = (l.0.clone(), l.1.crust.clone(), l.2.particles.clone());
        let r = repair(
            LayersMut { flow: &mut l.0, surface: &mut l.1, folds: &mut l.2, breakouts: &mut l.3 },
            300.0,
        );
        assert!(!r.any());
        assert_eq!((l.0, l.1.crust, l.2.particles), before);
    }
}
