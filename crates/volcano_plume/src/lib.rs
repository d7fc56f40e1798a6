//! Explosive eruption columns (thesis chapter 3): Lagrangian slices whose mass grows by air
//! entrainment, forces of weight, buoyancy, friction and wind, and the phases jet → buoyant
//! plume → umbrella, or collapse.
//!
//! [`model`] holds plain data and functions, testable without ECS; its [`model::domain::step`]
//! (`model::domain::step`) advances one volcano's whole plume by one step. [`plugin`] runs it in
//! the `PlumeStep` domain ([`PlumeSystems`]): add an [`Eruption`] next to a `Volcano` and
//! slices, s1 spheres and the umbrella appear as entities.
#![forbid(unsafe_code)]

pub mod caps;
pub mod components;
mod faults;
pub mod ground;
pub mod model;
pub mod plugin;
pub mod pyroclastic;
pub mod view;

pub use caps::{PlumeCapReport, PlumeCaps};
pub use components::{
    AshReleased, EmissionState, Eruption, EruptionScript, NeutralBuoyancyReached, PlumeAmbient,
    PlumeAshBudget, PlumeCollapsed, PlumeSlice, S1, SecondaryColumnRising, SliceCollapsed, Umbrella,
    UmbrellaSpreading,
};
pub use ground::{DepositMap, PyroclasticBudget};
pub use model::ambient::{AmbientLevel, LayeredAmbient};
pub use model::domain::{PlumeAir, PlumeInputs, PlumeReport, PlumeState};
pub use model::params::{Dynamics, PlumeParams, Preset};
pub use model::pyroclastic::PyroclasticParams;
pub use model::slice::{Phase, Slice, SliceEnv, SliceStepReport};
pub use model::timeline::{EruptionTimeline, TimelineKey, TimelineState};
pub use model::wind::WindProfile;
pub use plugin::{MAX_PLUME_STEP_S, PlumePlugin, PlumeStep, PlumeSystems};
pub use pyroclastic::{
    PyroParticle, PyroclasticFlowStarted, PyroclasticPlugin, PyroclasticQuery, PyroclasticStep,
    PyroclasticSystems, SecondaryColumnFormed,
};
pub use view::{AshInstance, AshLightSettings, PlumeInstances, PlumeViewSettings, PlumeViewpoint};
