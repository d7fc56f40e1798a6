//! Core of the volcano plugin set (Lastic 2023, "Efficient visual simulation of volcanic
//! phenomena"): units and constants, atmosphere profiles, the [`Grid2`] field type, terrain
//! heightfields and generators, seeded random streams, the multi-rate simulation clock and the
//! [`Volcano`] entity.
//!
//! The crate depends on Bevy without its render stack, so its tests build in about a minute.
//! Modules follow the two-layer rule of docs/ARCHITECTURE.md §2: *model* modules are plain
//! data and functions ([`atmosphere`], [`grid`], [`terrain`], [`rng`]); *plugin* modules hold
//! the ECS glue ([`clock`], [`volcano`], [`plugin`]). [`parallel`] is the deterministic
//! row-band helper every domain runs its loops with, on Bevy's task pools; [`interpolation`]
//! shows moving entities between their last two base ticks.
#![forbid(unsafe_code)]

pub mod atmosphere;
pub mod clock;
pub mod error;
pub mod fault;
pub mod grid;
pub mod heat;
pub mod interpolation;
pub mod parallel;
pub mod plugin;
pub mod rng;
pub mod terrain;
pub mod units;
pub mod volcano;

pub use atmosphere::{AirState, AtmosphereProfile, ThesisIsa, UsStandard1976};
pub use clock::{Cadence, DomainClock, SimControl, SimDomainAppExt, SimSystems, SimTick};
pub use error::ConfigError;
pub use fault::{SimDomain, SimFault};
pub use grid::{Boundary, Grid2};
pub use heat::{AirHeatKind, AirHeatSource, AirHeatSources};
pub use interpolation::{TickInterpolation, TickInterpolationPlugin, TickInterpolationSystems};
pub use plugin::VolcanoCorePlugin;
pub use rng::{VolcanoRng, derive_stream};
pub use terrain::{LandCover, NodeRegion, StratovolcanoParams, Terrain, TerrainChanged, TerrainTemplate};
pub use volcano::{OnTerrain, TerrainVolcanoes, VentPosition, Volcano, VolcanoSpec, VolcanoTemplate};

/// Everything a game usually needs from this crate.
pub mod prelude {
    pub use crate::{
        AirHeatKind, AirHeatSource, AirHeatSources, AirState, AtmosphereProfile, Boundary, Cadence,
        ConfigError, DomainClock, Grid2, LandCover, OnTerrain, SimControl, SimDomain, SimDomainAppExt,
        SimFault, SimSystems, SimTick, StratovolcanoParams, Terrain, TerrainChanged, TerrainTemplate,
        TerrainVolcanoes, ThesisIsa, TickInterpolation, TickInterpolationPlugin, UsStandard1976,
        VentPosition, Volcano, VolcanoCorePlugin, VolcanoRng, VolcanoSpec, VolcanoTemplate,
    };
}
