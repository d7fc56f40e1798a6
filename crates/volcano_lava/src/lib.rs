//! Pahoehoe lava (thesis chapter 5, DESIGN.md §5): a mass-exact viscous heightfield flow with
//! temperature-dependent viscosity, cooling and solidification (layer 1).
//!
//! [`model`] holds plain data and functions, testable without ECS.

pub mod model;

pub use model::budget::VolumeBudget;
pub use model::field::{CellProbe, Edge, Edges, FlowField, Placement, Source};
pub use model::params::{LavaParams, ViscosityModel};
pub use model::{StepReport, step};
pub mod scenario;

pub use model::surface::SurfaceState;
pub use scenario::{LavaSummary, Scenario, ScenarioConfig, ScenarioKind, run_scenario};
