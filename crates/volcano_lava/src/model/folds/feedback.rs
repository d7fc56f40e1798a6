//! Folds feed back on the surface (thesis §5.1: folds thicken the crust where they lie).
//!
//! A fold is crust buckled over itself: under it the crust is (at least) two layers of the
//! crust its contact time grew, `2 · 2√(κt)` (eq 5.1), and never less than rigid, so the
//! surface there moves with the smoothed (rigid) velocity and the flow under it feels the full
//! crust drag ([`crate::model::breakout::crust_drag_factor`]); the thicker crust also
//! insulates the lava under it ([`crate::model::thermal`]). The thickened crust is capped at
//! half the lava thickness, so a fold alone never crusts a cell through (which would freeze
//! it).

use bevy::math::DVec2;

use super::sample::cell;
use super::{FoldParams, FoldSystem};
use crate::model::field::FlowField;
use crate::model::params::LavaParams;
use crate::model::surface::{SurfaceState, crust_from_contact};

/// Crust (m) under a fold over lava `h` m thick whose contact time is `contact` s:
/// `min(max(2 · 2√(κt), rigid), h/2)`.
pub fn fold_crust(kappa: f64, contact: f64, rigid: f64, h: f64) -> f64 {
    (2.0 * crust_from_contact(kappa, contact)).max(rigid).min(0.5 * h)
}

/// Raises the crust of every cell under a fold particle (its centre and both ends, the
/// cylinder's footprint) to at least [`fold_crust`]. Call after the folds moved, each step.
/// Returns the number of cells raised.
pub fn thicken_crust_under_folds(
    sys: &FoldSystem,
    field: &FlowField,
    surface: &mut SurfaceState,
    lava: &LavaParams,
    params: &FoldParams,
) -> usize {
    if !params.enabled || surface.size() != (field.nx(), field.ny()) {
        return 0;
    }
    let h = field.thickness().data();
    let kappa = lava.kappa();
    let half = 0.5 * params.particle_length;
    let mut raised = 0;
    for q in &sys.particles {
        let ends: [DVec2; 3] = [q.pos, q.pos + q.tangent * half, q.pos - q.tangent * half];
        for p in ends {
            let Some(k) = cell(field, p) else { continue };
            if h[k] < lava.min_thickness {
                continue;
            }
            let target = fold_crust(kappa, surface.contact[k], lava.rigid_crust, h[k]);
            if surface.crust[k] < target {
                surface.crust[k] = target;
                raised += 1;
            }
        }
    }
    raised
}
