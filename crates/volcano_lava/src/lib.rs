//! Pahoehoe lava (thesis chapter 5, docs/physics/lava.md §6): a mass-exact viscous heightfield
//! flow with temperature-dependent viscosity, cooling and solidification (layer 1), the crust
//! (layer 2) and folds of oriented particles that collide and roll (layer 3).
//!
//! [`model`] holds plain data and functions, testable without ECS; [`plugin`] runs them in
//! the `LavaStep` domain: spawn a [`LavaField`] (a grid placed on the terrain) and
//! [`LavaSource`]s; query the lava with [`LavaQuery`]; [`scenario`] runs headless test cases;
//! [`view`] is what renderers and panels read.

pub mod components;
pub mod fountains;
pub mod model;
pub mod plugin;
pub mod vents;
pub mod view;

pub use model::budget::VolumeBudget;
pub use model::field::{CellProbe, Edge, Edges, FlowField, Placement, Source};
pub use model::params::{LavaParams, ViscosityModel};
pub use model::{DomainReport, LavaStepReport, LayersMut};
pub mod scenario;

pub use components::{
    LavaBreakout, LavaField, LavaFieldStatus, LavaProbe, LavaQuery, LavaReached, LavaSource,
    LavaSourceStatus, LavaState, LavaZone, TerrainLink, field_placement,
};
pub use fountains::{LavaFountain, LavaFountainState};
pub use model::folds::{FoldParams, FoldSystem};
pub use model::fountain::{Clot, Fountain, FountainParams, FountainReport};
pub use model::runout::{Runout, RunoutSettings, Vent};
pub use model::surface::SurfaceState;
pub use plugin::{LavaPlugin, LavaStep};
pub use scenario::terrains::scenario_terrain;
pub use scenario::{LavaScenario, LavaSummary, ScenarioConfig, ScenarioKind};
pub use vents::{
    LavaFlowFront, LavaFlowStopped, LavaVent, LavaVentOpened, LavaVentStatus, TerrainLava, VentLavaSettings,
};
