//! [`VolcanoCorePlugin`]: the base tick, the chained [`SimSystems`] sets, simulation control
//! and the volcano bookkeeping systems.

use bevy::app::{App, FixedUpdate, Plugin, Update};
use bevy::ecs::schedule::IntoScheduleConfigs;

use crate::clock::driver::{begin_tick, tick_is_running};
use crate::clock::{SimControl, SimSystems, SimTick};
use crate::volcano;

/// Core plugin: orders [`SimSystems`] in `FixedUpdate`, adds [`SimControl`] and [`SimTick`],
/// and snaps [`crate::Volcano`] vents to the terrain. The base tick is the game's
/// `Time<Fixed>`, whatever rate it set; this plugin never changes it (nor `Time<Virtual>`).
/// Requires `TimePlugin` (in `MinimalPlugins` and `DefaultPlugins`).
#[derive(Debug, Default, Clone)]
pub struct VolcanoCorePlugin;

impl Plugin for VolcanoCorePlugin {
    fn build(&self, app: &mut App) {
        let [begin, plume, pyro, before, weather, after, lava, end] = SimSystems::ORDER;
        app.init_resource::<SimControl>()
            .init_resource::<SimTick>()
            .register_type::<SimControl>()
            .register_type::<SimTick>()
            .add_message::<crate::SimFault>()
            .register_type::<crate::SimFault>()
            .register_type::<crate::SimDomain>()
            .register_type::<crate::AirHeatSources>()
            .register_type::<crate::Volcano>()
            .register_type::<crate::VentPosition>()
            .register_type::<crate::OnTerrain>()
            .register_type::<crate::TerrainVolcanoes>()
            .register_type::<crate::VolcanoSpec>()
            .register_type::<crate::Cadence>()
            .register_type::<crate::LandCover>()
            .register_type::<crate::Terrain>()
            .register_type::<crate::VolcanoRng>()
            .configure_sets(FixedUpdate, (begin, plume, pyro, before, weather, after, lava, end).chain())
            .configure_sets(
                FixedUpdate,
                (
                    SimSystems::Plume,
                    SimSystems::Pyroclastic,
                    SimSystems::BeforeWeather,
                    SimSystems::Weather,
                    SimSystems::AfterWeather,
                    SimSystems::Lava,
                )
                    .run_if(tick_is_running),
            )
            .add_systems(FixedUpdate, begin_tick.in_set(SimSystems::Begin))
            // Vents snap in Update (visible at once) and again before each tick, so a volcano
            // spawned or moved between ticks is on the ground when its domains step.
            // Terrains move to their entity's translation first, so the vents land on them.
            .add_systems(Update, (crate::terrain::place_terrains::<true>, volcano::snap_vents).chain())
            .add_systems(
                FixedUpdate,
                (crate::terrain::place_terrains::<false>, volcano::snap_vents)
                    .chain()
                    .in_set(SimSystems::Begin)
                    .after(begin_tick),
            );
    }
}
