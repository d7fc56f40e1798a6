//! # volcano
//!
//! Real-time, plausible volcanic eruptions for Bevy 0.19, after Lastic (2023), *Efficient visual
//! simulation of volcanic phenomena*. Add [`VolcanoPlugins`] (or [`VolcanoSimPlugins`] for
//! headless games and tests), put a [`Terrain`](volcano_core::Terrain) and a
//! [`Volcano`](volcano_core::Volcano) in the world, and the simulation steps on the game's
//! `Time<Fixed>`, whatever its rate.
//!
//! The plugins leave the game's cameras, lights, fog and clocks alone: the sun, ambient light
//! and sky are the opt-in `volcano::render::VolcanoSkyPlugin`, the debug panels the opt-in
//! `volcano::debug::VolcanoDebugPlugins` (feature `debug`), and the camera tagged
//! `volcano::render::VolcanoViewer` is the one the ash billboards face and the clouds fog.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use volcano::prelude::*;
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, VolcanoPlugins))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         let terrain = StratovolcanoParams::default().generate().expect("valid parameters");
//!         commands.spawn(terrain);
//!         commands.spawn((Volcano::default(), Eruption::plinian(), Transform::default()));
//!     })
//!     .run();
//! ```
//!
//! A game can also write the volcano as a Bevy scene, `bsn!` (feature `bsn`, default): a
//! terrain and a volcano are built from their templates ([`TerrainTemplate`](volcano_core::TerrainTemplate),
//! [`VolcanoTemplate`](volcano_core::VolcanoTemplate)) when the scene spawns, an
//! [`AtmosphereScenario`](volcano_atmosphere::AtmosphereScenario) becomes an atmosphere at the
//! next tick, and the other components patch their defaults (`examples/bsn_volcano.rs`).
//!
//! Crates: [`volcano_core`] (units, atmosphere profiles, grids, terrain, RNG, multi-rate
//! clock), [`volcano_plume`] (eruption columns), [`volcano_atmosphere`] (layered atmosphere),
//! [`volcano_coupling`] (plume ↔ atmosphere, ash), [`volcano_lava`] (pahoehoe lava),
//! `volcano_render` (feature `render`, default) and `volcano_egui` (feature `debug`).
#![forbid(unsafe_code)]

pub mod assets;
pub mod export;
pub mod lava_scene;
pub mod quality;
pub mod scenes;
pub mod styles;

use bevy::app::{PluginGroup, PluginGroupBuilder};

pub use volcano_atmosphere as atmosphere;
pub use volcano_core as core;
pub use volcano_coupling as coupling;
#[cfg(feature = "debug")]
pub use volcano_egui as debug;
pub use volcano_lava as lava;
pub use volcano_plume as plume;
#[cfg(feature = "render")]
pub use volcano_render as render;

/// Simulation only: no rendering, works on `MinimalPlugins` (headless games, servers, tests).
#[derive(Debug, Default, Clone, Copy)]
pub struct VolcanoSimPlugins;

impl PluginGroup for VolcanoSimPlugins {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add(volcano_core::VolcanoCorePlugin)
            .add(volcano_plume::PlumePlugin)
            .add(volcano_lava::LavaPlugin)
            // Costs one empty query per simulated second when no `Atmosphere` entity exists.
            .add(volcano_atmosphere::AtmospherePlugin::default())
            // A volcano inside an atmosphere's grid couples to it (thesis §4.3.3).
            .add(volcano_coupling::CouplingPlugin)
            // Applies a `VolcanoQuality` the game inserts (nothing without one).
            .add(quality::VolcanoQualityPlugin)
            // A timeline's lava channel drives the volcano's lava vent.
            .add(styles::EruptionStylePlugin)
    }
}

/// The simulation and its visuals (feature `render`: `volcano_render::VolcanoRenderPlugins`);
/// every member can be disabled (`VolcanoPlugins.build().disable::<LavaRenderPlugin>()`). Not
/// the sky (`VolcanoSkyPlugin`) nor the debug panels (`VolcanoDebugPlugins`): both opt-in.
/// Needs `DefaultPlugins` (or the headless set in `volcano_render::headless`) with `render`.
#[derive(Debug, Default, Clone, Copy)]
pub struct VolcanoPlugins;

impl PluginGroup for VolcanoPlugins {
    fn build(self) -> PluginGroupBuilder {
        // The asset types need Bevy's `AssetPlugin` (in `DefaultPlugins`); without it the
        // plugin warns and does nothing.
        #[allow(unused_mut)]
        let mut group =
            PluginGroupBuilder::start::<Self>().add_group(VolcanoSimPlugins).add(assets::VolcanoAssetPlugin);
        #[cfg(feature = "render")]
        {
            group = group.add_group(volcano_render::VolcanoRenderPlugins);
        }
        group
    }
}

/// What a game usually imports: the plugins, the volcano and its eruption, terrains and their
/// generators, lava sources and zones, the atmosphere, every gameplay message and point query,
/// quality levels, the templates a scene (`bsn!`) builds them with, and (feature `render`) the
/// camera markers and the opt-in sky.
pub mod prelude {
    pub use crate::assets::{
        EruptionTimelineSource, HeightmapSource, PlumePresetSource, VolcanoAssetPlugin, VolcanoSceneSource,
    };
    pub use crate::quality::VolcanoQuality;
    pub use crate::scenes::{SceneSpec, VolcanoScenePlugin};
    pub use crate::styles::{EruptionStylePlugin, hawaiian};
    pub use crate::{VolcanoPlugins, VolcanoSimPlugins};
    pub use volcano_atmosphere::{
        AirLayer, Atmosphere, AtmospherePlugin, AtmosphereScenario, AtmosphereScenarioStatus,
        AtmosphereSpawner, AtmosphereTimeline, WeatherScenario, WeatherStepped, WeatherSystems, air_ash_at,
        spawn_atmosphere, spawn_scenario, spawn_scenario_with,
    };
    pub use volcano_core::prelude::*;
    pub use volcano_coupling::{CouplingBudget, CouplingPlugin, CouplingSettings, CouplingSystems};
    pub use volcano_lava::{
        LavaBreakout, LavaField, LavaFieldStatus, LavaFlowFront, LavaFlowStopped, LavaFountain,
        LavaFountainState, LavaParams, LavaPlugin, LavaProbe, LavaQuery, LavaReached, LavaSource,
        LavaSourceStatus, LavaVent, LavaVentOpened, LavaVentStatus, LavaZone, TerrainLava, VentLavaSettings,
    };
    pub use volcano_plume::{
        AshReleased, Eruption, EruptionScript, EruptionTimeline, NeutralBuoyancyReached, PlumeCapReport,
        PlumeCaps, PlumeCollapsed, PlumeParams, PlumePlugin, PlumeSlice, PlumeSystems, Preset,
        PyroclasticFlowStarted, PyroclasticQuery, SecondaryColumnFormed, SecondaryColumnRising,
        SliceCollapsed, UmbrellaSpreading, WindProfile,
    };
    #[cfg(feature = "render")]
    pub use volcano_render::{
        GlowCamera, OrbitCamera, VolcanoRenderPlugins, VolcanoSkyCamera, VolcanoSkyPlugin, VolcanoViewer,
        camera_bundle,
    };
}

/// The guide's ```` ```rust ```` blocks, compiled by `cargo test` as doc tests (the other
/// blocks are shell, RON or fragments marked `text`).
#[cfg(doctest)]
mod guide {
    #[doc = include_str!("../docs/GAMEPLAY.md")]
    struct Gameplay;
    #[doc = include_str!("../docs/EMBEDDING.md")]
    struct Embedding;
    #[doc = include_str!("../docs/ASSETS.md")]
    struct Assets;
    #[doc = include_str!("../docs/SAVING.md")]
    struct Saving;
    #[doc = include_str!("../docs/EXPORT.md")]
    struct Export;
}
