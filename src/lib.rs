//! # volcano
//!
//! Real-time, plausible volcanic eruptions for Bevy 0.19, after Lastic (2023), *Efficient visual
//! simulation of volcanic phenomena*. Add [`VolcanoPlugins`] (or [`VolcanoSimPlugins`] for
//! headless games and tests), put a [`Terrain`](volcano_core::Terrain) and a
//! [`Volcano`](volcano_core::Volcano) in the world, and the simulation steps at fixed rates.
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
//! Crates: [`volcano_core`] (units, atmosphere profiles, grids, terrain, RNG, multi-rate
//! clock), [`volcano_plume`] (eruption columns), [`volcano_atmosphere`] (layered atmosphere),
//! [`volcano_coupling`] (plume ↔ atmosphere, ash), [`volcano_lava`] (pahoehoe lava), `volcano_render` (feature `render`) and
//! `volcano_egui` (feature `egui`).

pub mod lava_scene;
pub mod scenes;

use bevy::app::{PluginGroup, PluginGroupBuilder};

pub use volcano_atmosphere as atmosphere;
pub use volcano_core as core;
pub use volcano_coupling as coupling;
#[cfg(feature = "egui")]
pub use volcano_egui as egui;
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
            // Costs one empty query every 50 ticks when no `Atmosphere` entity exists.
            .add(volcano_atmosphere::AtmospherePlugin::default())
            // A volcano inside an atmosphere's grid couples to it (thesis §4.3.3).
            .add(volcano_coupling::CouplingPlugin)
    }
}

/// Everything: the simulation, its rendering (feature `render`) and the tuning panel (feature
/// `egui`). Needs `DefaultPlugins` (or the headless set in `volcano_render::headless`).
#[derive(Debug, Default, Clone, Copy)]
pub struct VolcanoPlugins;

impl PluginGroup for VolcanoPlugins {
    fn build(self) -> PluginGroupBuilder {
        #[allow(unused_mut)]
        let mut group = PluginGroupBuilder::start::<Self>().add_group(VolcanoSimPlugins);
        #[cfg(feature = "render")]
        {
            group = group.add(volcano_render::VolcanoRenderPlugin);
        }
        #[cfg(feature = "egui")]
        {
            group = group.add(volcano_egui::VolcanoEguiPlugin);
        }
        group
    }
}

/// What a game usually imports.
pub mod prelude {
    pub use crate::scenes::{SceneSpec, VolcanoScenePlugin};
    pub use crate::{VolcanoPlugins, VolcanoSimPlugins};
    pub use volcano_core::prelude::*;
    pub use volcano_coupling::{CouplingBudget, CouplingSettings, CouplingSystems};
    pub use volcano_plume::{
        Eruption, NeutralBuoyancyReached, PlumeCollapsed, PlumeParams, PlumeSlice, UmbrellaSpreading,
        WindProfile,
    };
}
