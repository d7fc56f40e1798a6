//! The flow layer's reusable work arrays, owned by each [`super::field::FlowField`] and
//! filled by [`super::flow`]'s passes (a module of their own so the field and the flow step
//! do not import each other).

use volcano_core::Grid2;

/// Reusable work arrays of one field (allocated once).
#[derive(Debug, Clone, PartialEq)]
pub struct Scratch {
    /// Cell mobilities ρ g h³/(3η(T)) kept by the flux pass for the update pass when the
    /// viscosity depends on temperature (empty for a constant viscosity, which the update pass
    /// recomputes).
    pub(super) mob: Vec<f64>,
    /// Periodic south/north edge face fluxes (`nx`; face row 0 = face row ny).
    pub(super) wrap: Vec<f64>,
    pub(super) h_new: Grid2<f64>,
    pub(super) t_new: Grid2<f64>,
}

impl Scratch {
    pub(crate) fn new(template: &Grid2<f64>) -> Self {
        let nx = template.nx();
        Self { mob: Vec::new(), wrap: vec![0.0; nx], h_new: template.clone(), t_new: template.clone() }
    }
}
