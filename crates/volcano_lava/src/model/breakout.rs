//! Beyond the thesis (its future work, §5.1 and Fig 5.2-right): crust drag and breakouts.
//! A rigid crust slows the lava under it (no-slip top); lava that keeps arriving inflates
//! the sheet under the crust, and past a threshold the crust tears: the crust is removed
//! around the tear, the free-surface flux returns there, and a new lobe flows out.

use bevy::math::Vec2;

use super::field::FlowField;
use super::params::LavaParams;
use super::surface::SurfaceState;

/// Mobility multiplier under a crust of thickness `crust`: `1 − ¾ min(1, crust/rigid)`.
/// With a rigid crust the flux of a film sheared between a fixed base and a fixed top is
/// `ρ g h³/(12η)`, a quarter of the free-surface Jeffreys flux `ρ g h³/(3η)`.
pub fn crust_drag_factor(crust: f64, rigid: f64) -> f64 {
    1.0 - 0.75 * (crust / rigid).clamp(0.0, 1.0)
}

/// A crust tear.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Breakout {
    /// Cell index of the tear.
    pub cell: usize,
    /// World (x, z) of the tear.
    pub position: Vec2,
    /// Inflation under the crust when it tore (m).
    pub inflation: f64,
}

/// Per-cell memory of the lava thickness when the crust became rigid.
#[derive(Debug, Clone, PartialEq)]
pub struct BreakoutState {
    /// Thickness (m) when the crust over the cell became rigid; negative = not rigid.
    pub h_rigid: Vec<f64>,
    /// Breakouts so far.
    pub count: u64,
}

impl BreakoutState {
    /// For a field of `n` cells.
    pub fn new(n: usize) -> Self {
        Self { h_rigid: vec![-1.0; n], count: 0 }
    }
}

/// Tracks inflation under rigid crust and tears the crust where it exceeds
/// `breakout_inflation` (cells in row order, at most one tear per `breakout_radius` disc per
/// call); then writes the crust drag into the field's mobility factor (if `crust_drag`).
/// Returns the tears of this call.
pub fn update_breakouts(
    state: &mut BreakoutState,
    field: &mut FlowField,
    surface: &mut SurfaceState,
    params: &LavaParams,
) -> Vec<Breakout> {
    let mut tears = Vec::new();
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    if state.h_rigid.len() != nx * ny || surface.size() != (nx, ny) {
        return tears;
    }
    let h = field.h.data();
    #[allow(clippy::needless_range_loop)] // k indexes h, the crust and h_rigid, and tears mutate them
    for k in 0..nx * ny {
        if h[k] < params.min_thickness || surface.crust[k] < params.rigid_crust {
            state.h_rigid[k] = -1.0;
            continue;
        }
        if state.h_rigid[k] < 0.0 {
            state.h_rigid[k] = h[k];
            continue;
        }
        let inflation = h[k] - state.h_rigid[k];
        if inflation > params.breakout_inflation && params.crust_drag {
            let (i, j) = (k % nx, k / nx);
            tears.push(Breakout { cell: k, position: field.h.position(i, j), inflation });
            // Tear the crust over the disc.
            let r = (params.breakout_radius / dx).ceil() as i64;
            for dj in -r..=r {
                for di in -r..=r {
                    let (a, b) = (i as i64 + di, j as i64 + dj);
                    if a < 0 || b < 0 || a >= nx as i64 || b >= ny as i64 {
                        continue;
                    }
                    if ((di * di + dj * dj) as f64).sqrt() * dx > params.breakout_radius {
                        continue;
                    }
                    let q = b as usize * nx + a as usize;
                    surface.crust[q] = 0.0;
                    surface.contact[q] = 0.0;
                    state.h_rigid[q] = -1.0;
                }
            }
        }
    }
    state.count += tears.len() as u64;
    if params.crust_drag {
        for (f, &c) in field.mob_factor.iter_mut().zip(&surface.crust) {
            *f = crust_drag_factor(c, params.rigid_crust);
        }
    } else {
        field.mob_factor.iter_mut().for_each(|f| *f = 1.0);
    }
    tears
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drag_factor_is_a_quarter_under_rigid_crust() {
        assert_eq!(crust_drag_factor(0.0, 0.03), 1.0);
        assert_eq!(crust_drag_factor(0.03, 0.03), 0.25);
        assert_eq!(crust_drag_factor(0.5, 0.03), 0.25);
        assert!((crust_drag_factor(0.015, 0.03) - 0.625).abs() < 1e-12);
    }

    #[test]
    fn inflation_under_rigid_crust_tears_it_and_frees_the_flow() {
        let p = LavaParams::default();
        let n = 16;
        let mut f = FlowField::flat(n, n, 0.5).unwrap();
        f.h.data_mut().fill(0.5);
        let mut s = SurfaceState::new(n, n);
        s.crust.fill(0.04);
        let mut b = BreakoutState::new(n * n);
        assert!(update_breakouts(&mut b, &mut f, &mut s, &p).is_empty());
        assert!(f.mobility_factor().iter().all(|&x| x == 0.25), "rigid crust drags");
        // Lava keeps arriving under the crust at the centre: +0.2 m, then +0.4 m.
        let k = 8 * n + 8;
        f.h.data_mut()[k] = 0.7;
        assert!(update_breakouts(&mut b, &mut f, &mut s, &p).is_empty(), "0.2 m < 0.3 m");
        f.h.data_mut()[k] = 0.9;
        let tears = update_breakouts(&mut b, &mut f, &mut s, &p);
        assert_eq!(tears.len(), 1);
        assert_eq!(tears[0].cell, k);
        assert!((tears[0].inflation - 0.4).abs() < 1e-12);
        assert_eq!(s.crust[k], 0.0);
        assert_eq!(s.crust[k + 2], 0.0, "1 m radius = 2 cells");
        assert_eq!(s.crust[k + 3], 0.04);
        assert_eq!(f.mobility_factor()[k], 1.0, "free-surface flux back at the tear");
        assert_eq!(b.count, 1);
        // No drag, no breakouts (isothermal runs).
        let iso = LavaParams::isothermal(1000.0).unwrap();
        let mut s2 = SurfaceState::new(n, n);
        s2.crust.fill(0.04);
        let mut b2 = BreakoutState::new(n * n);
        update_breakouts(&mut b2, &mut f, &mut s2, &iso);
        f.h.data_mut()[k] = 2.0;
        assert!(update_breakouts(&mut b2, &mut f, &mut s2, &iso).is_empty());
        assert!(f.mobility_factor().iter().all(|&x| x == 1.0));
    }
}
