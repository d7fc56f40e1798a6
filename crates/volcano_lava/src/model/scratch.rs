//! The flow layer's reusable work arrays, owned by each [`super::field::FlowField`] and
//! filled by [`super::flow`]'s passes (a module of their own so the field and the flow step
//! do not import each other).

use volcano_core::Grid2;

/// Reusable work arrays of one field (allocated once).
#[derive(Debug, Clone, PartialEq)]
pub struct Scratch {
    /// x-face fluxes, `(nx+1) × ny` (m²/s, +x positive); face `i` is west of cell `i`.
    pub(super) fx: Vec<f64>,
    /// y-face fluxes, `nx × (ny+1)`; face `j` is south of row `j`.
    pub(super) fy: Vec<f64>,
    pub(super) h_new: Grid2<f64>,
    pub(super) t_new: Grid2<f64>,
}

impl Scratch {
    pub(crate) fn new(template: &Grid2<f64>) -> Self {
        let (nx, ny) = (template.nx(), template.ny());
        Self {
            fx: vec![0.0; (nx + 1) * ny],
            fy: vec![0.0; nx * (ny + 1)],
            h_new: template.clone(),
            t_new: template.clone(),
        }
    }
}
