//! A scene spawned from a loaded [`SceneAsset`] (a `.scene.ron` file of the game's, or a
//! built-in under `embedded://volcano/scenes/`), for games that place volcanoes from data
//! instead of adding [`crate::scenes::VolcanoScenePlugin`] (which also brings the scene's camera, sun
//! and sky, and spawns once at startup).

use bevy::asset::AssetEvent;
use bevy::prelude::*;
use volcano_atmosphere::WeatherStep;
use volcano_core::DomainClock;

use super::SceneAsset;
use crate::quality::VolcanoQuality;

/// Spawns the simulation of a loaded [`SceneAsset`] when it loads: its terrain (and far ring,
/// with the `render` feature), its volcano and eruption, its lava patch and sources, and its
/// atmosphere over the terrain (which also sets the weather clock's time scale, as the scene
/// file says). Not its camera, sun or sky: those stay the game's. What it spawned is listed in
/// [`SpawnedScene`] on the same entity; when the file is reloaded (Bevy's `file_watcher`, or
/// `AssetServer::reload`) those entities are despawned and the new file's are spawned.
/// Despawning this entity leaves them in the world.
#[derive(Component, Debug, Clone, Reflect, FromTemplate)]
#[reflect(Component, Debug)]
#[require(SpawnedScene)]
pub struct VolcanoSceneSource(pub Handle<SceneAsset>);

/// The entities a [`VolcanoSceneSource`] spawned (terrain, volcano, lava field and sources,
/// atmosphere; the air layers are the atmosphere's children).
#[derive(Component, Debug, Clone, Default, PartialEq, Reflect)]
#[reflect(Component, Debug, Default)]
pub struct SpawnedScene(#[entities] pub Vec<Entity>);

/// Spawns (or, on reload, respawns) the scene of each [`VolcanoSceneSource`] whose asset loaded
/// or changed. In `PreUpdate` (added by [`super::VolcanoAssetPlugin`]), so the frame's
/// fixed steps already see the scene. A terrain that fails to build is logged and nothing is
/// spawned (the file itself was validated by its loader).
pub fn apply_scene_sources(
    mut commands: Commands,
    mut events: MessageReader<AssetEvent<SceneAsset>>,
    assets: Res<Assets<SceneAsset>>,
    mut sources: Query<(Ref<VolcanoSceneSource>, &mut SpawnedScene)>,
    quality: Option<Res<VolcanoQuality>>,
    mut clock: Option<ResMut<Time<DomainClock<WeatherStep>>>>,
) {
    let changed = super::changed_ids(&mut events);
    for (source, mut spawned) in &mut sources {
        let id = source.0.id();
        if !(source.is_changed() || changed.contains(&id)) {
            continue;
        }
        let Some(scene) = assets.get(id) else { continue };
        let spec = &scene.0;
        let terrain = match spec.terrain.build() {
            Ok(t) => t,
            Err(e) => {
                error!("scene `{}` not spawned: its terrain: {e}", spec.name);
                continue;
            }
        };
        for entity in spawned.0.drain(..) {
            commands.entity(entity).try_despawn();
        }
        spawned.0 = crate::scenes::spawn_simulation(&mut commands, spec, terrain.clone(), true);
        if let Some(a) = &spec.atmosphere {
            match crate::scenes::spawn_atmosphere(
                &mut commands,
                a,
                &terrain,
                quality.as_deref(),
                clock.as_deref_mut(),
            ) {
                Ok(atmosphere) => spawned.0.push(atmosphere),
                Err(e) => error!("scene `{}`: atmosphere `{}` not spawned: {e}", spec.name, a.scenario),
            }
        }
    }
}
