//! Explosive eruption columns (thesis chapter 3): Lagrangian slices whose mass grows by air
//! entrainment, forces of weight, buoyancy, friction and wind, and the phases jet → buoyant
//! plume → umbrella, or collapse.
//!
//! This first part holds the *model* layer ([`model`]): plain data and functions, testable
//! without ECS. The plugin, spheres, umbrella and rendering build on it.

pub mod model;

pub use model::params::{PlumeParams, Preset};
pub use model::slice::{Phase, Slice, SliceEnv, StepReport};
pub use model::wind::WindProfile;
