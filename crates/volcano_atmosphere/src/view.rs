//! What renderers and panels read of an atmosphere (docs/ARCHITECTURE.md §2.3): the grid and
//! the layers' fields, ash sampled between layers, 2D maps of a field, and the clouds as a 3D
//! density. Read-only: nothing here changes a state. The functions are the model's own (this
//! module re-exports or wraps them, it copies nothing), so a renderer draws exactly what the
//! simulation holds.
//!
//! Painting into the fields (the "Atmosphere" window's brush) writes, so it is not a view: it
//! is [`crate::paint`] at the crate root.

pub use crate::model::ash::{ash_at, ash_blended, blend_layers, layer_ash, layer_blend};
pub use crate::model::fields::{AtmosphereState, GridSpec, LayerFields};
pub use crate::model::maps::{MapField, field_values, png_bytes};
pub use crate::model::volume::{ClusterMemory, VolumeSpec};

use crate::model::amplify::density_volume;
use crate::model::volume::coherent_forms_with;

/// The clouds of `state` on `spec`'s voxels (condensed water, g/m³, amplified by noise; x
/// fastest, then y, then z), thesis §4.2.6: the cloud forms of
/// [`coherent_forms_with`] (cells with more than `threshold` g/m³ of water; k-means with
/// `clusters` means where more than `fragmentation` of the cloudy cells border another form;
/// seed 0), starting from and replacing `memory`, then [`density_volume`].
pub fn cloud_density(
    state: &AtmosphereState,
    threshold: f64,
    clusters: usize,
    fragmentation: f64,
    memory: &mut ClusterMemory,
    spec: &VolumeSpec,
) -> Vec<f32> {
    let forms = coherent_forms_with(state, threshold, clusters, fragmentation, 0, memory);
    density_volume(state, &forms, spec)
}
