//! The volume budget of a lava field: every change of the lava volume has an account.

use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};

/// Running volume accounts (m³, f64). The lava volume on the grid must always equal
/// `initial + sources − solidified − outflow − faulted` up to rounding; [`VolumeBudget::error_rel`]
/// measures how far it is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Reflect, Serialize, Deserialize)]
pub struct VolumeBudget {
    /// Lava placed directly on the grid (initial conditions, tools).
    pub initial: f64,
    /// Lava emitted by sources.
    pub sources: f64,
    /// Lava frozen into the ground below the solidus.
    pub solidified: f64,
    /// Lava that left through open edges.
    pub outflow: f64,
    /// Volume added by clamping round-off negatives (≈1e-18 per event), kept so the
    /// accounts close exactly.
    pub rounding: f64,
    /// Lava removed by the guard with cells whose state was no longer finite
    /// ([`crate::model::guard`]).
    #[serde(default)]
    pub faulted: f64,
}

impl VolumeBudget {
    /// The lava volume the accounts predict.
    pub fn expected(&self) -> f64 {
        self.initial + self.sources - self.solidified - self.outflow - self.faulted + self.rounding
    }

    /// `|actual − expected| / (initial + sources)`, or the absolute error when nothing was
    /// ever added.
    pub fn error_rel(&self, actual: f64) -> f64 {
        let scale = self.initial + self.sources;
        let err = (actual - self.expected()).abs();
        if scale > 0.0 { err / scale } else { err }
    }
}
