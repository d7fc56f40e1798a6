//! Bevy assets: plume presets, eruption timelines, scenes and atmosphere
//! scenarios as RON asset types, heightmaps as PNG assets, each with its loader; the built-in
//! files embedded under `embedded://volcano/…`; and four components that put a loaded asset
//! to work on an entity, again whenever it is reloaded (with Bevy's `file_watcher` feature a
//! saved file reloads by itself; `AssetServer::reload` does it by hand):
//!
//! | Component | Asset | What it does |
//! |---|---|---|
//! | [`PlumePresetSource`] | [`PlumePresetAsset`] (`*.plume.ron`) | sets the [`Eruption`]'s parameters (new slices use them) |
//! | [`EruptionTimelineSource`] | [`EruptionTimelineAsset`] (`*.timeline.ron`) | drives the eruption ([`EruptionScript`]); a reload keeps the script's clock |
//! | [`HeightmapSource`] | [`HeightmapAsset`] (`*.height.png`) | inserts the [`Terrain`] |
//! | [`VolcanoSceneSource`] | [`SceneAsset`] (`*.scene.ron`) | spawns the scene's terrain, volcano, lava and atmosphere (respawned on reload; [`SpawnedScene`] lists them) |
//!
//! Built-ins: `embedded://volcano/presets/{thesis, plinian_showcase, pyroclastic_showcase,
//! physical}.plume.ron`, `embedded://volcano/timelines/plinian_to_collapse.timeline.ron`,
//! `embedded://volcano/scenes/NAME.scene.ron` (the scenes of [`crate::scenes`]),
//! `embedded://volcano/scenarios/NAME.atmosphere.ron` (the atmosphere's scenarios) and
//! `embedded://volcano/terrain/stratovolcano.height.png` (the default stratovolcano, 257 × 257
//! samples of 80 m, 0.1 m per unit: [`HeightmapSettings::default`]). A heightmap carries heights
//! only: its land cover (water, snow, bare rock, vegetation) comes from its relief
//! (`HeightmapSettings::snow_line`, `bare_slope_deg`).
//!
//! [`VolcanoAssetPlugin`] is in [`crate::VolcanoPlugins`]; it needs Bevy's `AssetPlugin`
//! (in `DefaultPlugins`) and does nothing, with a warning, without it.
//!
//! In a scene (`bsn!`) each component takes the asset's path, which Bevy loads when the scene
//! spawns (their templates, from `FromTemplate`, hold the path):
//! `HeightmapSource("embedded://volcano/terrain/stratovolcano.height.png")`.

mod loaders;
mod scene_source;

use std::path::{Path, PathBuf};

use bevy::asset::io::embedded::EmbeddedAssetRegistry;
use bevy::asset::{AssetApp, AssetEvent, AssetPlugin};
use bevy::prelude::*;
use volcano_core::Terrain;
use volcano_plume::{Eruption, EruptionScript, Preset};

pub use loaders::{
    AtmosphereScenarioAsset, EruptionTimelineAsset, HeightmapAsset, HeightmapLoader, HeightmapSettings,
    PlumePresetAsset, RonAsset, RonAssetLoader, SceneAsset, VolcanoAssetError,
};
pub use scene_source::{SpawnedScene, VolcanoSceneSource, apply_scene_sources};

/// The built-in timeline: a Plinian column that weakens after a minute and collapses into
/// pyroclastic flows, then stops.
const PLINIAN_TO_COLLAPSE: &str = include_str!("../../assets/timelines/plinian_to_collapse.timeline.ron");
/// The default stratovolcano as a 16-bit heightmap (see the module docs).
const STRATOVOLCANO_PNG: &[u8] = include_bytes!("../../assets/terrain/stratovolcano.height.png");

/// Sets the [`Eruption`] on this entity to a loaded [`PlumePresetAsset`] (its whole
/// `params`), when it loads and whenever it is reloaded.
#[derive(Component, Debug, Clone, Reflect, FromTemplate)]
#[reflect(Component, Debug)]
pub struct PlumePresetSource(pub Handle<PlumePresetAsset>);

/// Drives the [`Eruption`] on this entity with a loaded [`EruptionTimelineAsset`]: inserts an
/// [`EruptionScript`] when it loads; a reload replaces the keys and keeps the script's clock.
#[derive(Component, Debug, Clone, Reflect, FromTemplate)]
#[reflect(Component, Debug)]
pub struct EruptionTimelineSource(pub Handle<EruptionTimelineAsset>);

/// Inserts the loaded [`HeightmapAsset`]'s [`Terrain`] on this entity (replaced on reload).
#[derive(Component, Debug, Clone, Reflect, FromTemplate)]
#[reflect(Component, Debug)]
pub struct HeightmapSource(pub Handle<HeightmapAsset>);

/// Registers the asset types and loaders, embeds the built-ins and applies the `*Source`
/// components (see the module docs).
#[derive(Debug, Default, Clone, Copy)]
pub struct VolcanoAssetPlugin;

impl Plugin for VolcanoAssetPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<AssetPlugin>() {
            warn!(
                "VolcanoAssetPlugin: no AssetPlugin (add DefaultPlugins or AssetPlugin first); volcano assets are off"
            );
            return;
        }
        app.init_asset::<PlumePresetAsset>()
            .init_asset::<EruptionTimelineAsset>()
            .init_asset::<SceneAsset>()
            .init_asset::<AtmosphereScenarioAsset>()
            .init_asset::<HeightmapAsset>()
            .init_asset_loader::<RonAssetLoader<PlumePresetAsset>>()
            .init_asset_loader::<RonAssetLoader<EruptionTimelineAsset>>()
            .init_asset_loader::<RonAssetLoader<SceneAsset>>()
            .init_asset_loader::<RonAssetLoader<AtmosphereScenarioAsset>>()
            .init_asset_loader::<HeightmapLoader>()
            .register_type::<PlumePresetSource>()
            .register_type::<EruptionTimelineSource>()
            .register_type::<HeightmapSource>()
            .register_type::<VolcanoSceneSource>()
            .register_type::<SpawnedScene>()
            // Before the simulation's tick, so a preset or a terrain loaded this frame is used by
            // this frame's steps.
            .add_systems(PreUpdate, (apply_presets, apply_timelines, apply_heightmaps, apply_scene_sources));
        embed_builtins(app.world().resource::<EmbeddedAssetRegistry>());
    }
}

/// Puts the built-in files under `embedded://volcano/…`.
fn embed_builtins(registry: &EmbeddedAssetRegistry) {
    let text = |dir: &str, name: &str, ext: &str, body: &'static str| {
        let path = PathBuf::from(format!("volcano/{dir}/{name}.{ext}"));
        registry.insert_asset(path.clone(), &path, body.as_bytes());
    };
    for p in Preset::ALL {
        text("presets", p.name(), "plume.ron", p.ron());
    }
    for (name, body) in crate::scenes::BUILTIN {
        text("scenes", name, "scene.ron", body);
    }
    for (name, body) in volcano_atmosphere::BUILTIN_SCENARIOS {
        text("scenarios", name, "atmosphere.ron", body);
    }
    text("timelines", "plinian_to_collapse", "timeline.ron", PLINIAN_TO_COLLAPSE);
    let png = Path::new("volcano/terrain/stratovolcano.height.png");
    registry.insert_asset(png.to_path_buf(), png, STRATOVOLCANO_PNG);
}

/// The ids of assets of type `A` that loaded or changed since the last run.
fn changed_ids<A: Asset>(events: &mut MessageReader<AssetEvent<A>>) -> Vec<AssetId<A>> {
    events
        .read()
        .filter_map(|e| match e {
            AssetEvent::LoadedWithDependencies { id } | AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect()
}

fn apply_presets(
    mut events: MessageReader<AssetEvent<PlumePresetAsset>>,
    assets: Res<Assets<PlumePresetAsset>>,
    mut eruptions: Query<(Ref<PlumePresetSource>, &mut Eruption)>,
) {
    let changed = changed_ids(&mut events);
    for (source, mut eruption) in &mut eruptions {
        let id = source.0.id();
        if !(source.is_changed() || changed.contains(&id)) {
            continue;
        }
        if let Some(preset) = assets.get(id)
            && eruption.params != preset.0
        {
            eruption.params = preset.0.clone();
        }
    }
}

fn apply_timelines(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<EruptionTimelineAsset>>,
    assets: Res<Assets<EruptionTimelineAsset>>,
    mut sources: Query<(Entity, Ref<EruptionTimelineSource>, Option<&mut EruptionScript>)>,
) {
    let changed = changed_ids(&mut events);
    for (entity, source, script) in &mut sources {
        let id = source.0.id();
        if !(source.is_changed() || changed.contains(&id)) {
            continue;
        }
        let Some(timeline) = assets.get(id) else { continue };
        match script {
            Some(mut script) => script.timeline = timeline.0.clone(),
            None => {
                // Validated by the loader.
                if let Ok(script) = EruptionScript::new(timeline.0.clone()) {
                    commands.entity(entity).insert(script);
                }
            }
        }
    }
}

fn apply_heightmaps(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<HeightmapAsset>>,
    assets: Res<Assets<HeightmapAsset>>,
    sources: Query<(Entity, Ref<HeightmapSource>)>,
) {
    let changed = changed_ids(&mut events);
    for (entity, source) in &sources {
        let id = source.0.id();
        if (source.is_changed() || changed.contains(&id))
            && let Some(map) = assets.get(id)
        {
            let terrain: Terrain = map.0.clone();
            commands.entity(entity).insert(terrain);
        }
    }
}
