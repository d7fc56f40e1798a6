//! An eruption driven by a timeline asset that can be edited while it plays:
//! `cargo run --example timeline_asset`.
//!
//! The volcano's story is the file `assets/timelines/plinian_to_collapse.timeline.ron`, loaded
//! through the game's `AssetServer` and put beside the `Eruption` as an
//! `EruptionTimelineSource`: a Plinian minute, a 30 s weakening of the vent to 70 m/s that
//! collapses the column into pyroclastic flows, and the end at 5 minutes. The script runs on
//! the plume's own clock, so the story is the same at any frame rate. Every 5 s of the story
//! the game logs the vent's exit speed, whether it emits and how many pyroclastic particles
//! are running down the flanks.
//!
//! Editing the story live: while the example runs, open the file, change a key (`v0: Some(70)`
//! at 90 s to `v0: Some(200)` and the column keeps standing; the last key's `at_s: 300` to
//! `600` and it erupts for ten minutes), save it, and press R in the window:
//! `AssetServer::reload` reads the file again and the new keys apply from the script's current
//! time (a reload replaces the keys and keeps the script's clock). Built with Bevy's file
//! watcher, `cargo run --example timeline_asset --features bevy/file_watcher` (which rebuilds
//! Bevy once), saving the file is enough. A file that does not parse is logged with the key
//! and field at fault, and the keys loaded before keep playing.

use bevy::asset::AssetEvent;
use bevy::prelude::*;
use volcano::assets::EruptionTimelineAsset;
use volcano::prelude::*;

/// The timeline, relative to the game's `assets/` folder.
const TIMELINE: &str = "timelines/plinian_to_collapse.timeline.ron";

fn main() -> AppExit {
    App::new()
        .add_plugins((DefaultPlugins, VolcanoPlugins, VolcanoSkyPlugin))
        .add_systems(Startup, setup)
        .add_systems(Update, (reload_on_r, log_loaded_timelines, log_the_story))
        .run()
}

/// The world: a terrain, a volcano whose eruption follows the timeline file, and a camera.
fn setup(mut commands: Commands, assets: Res<AssetServer>) -> Result {
    commands.spawn(StratovolcanoParams::default().generate()?);
    commands.spawn((
        Name::new("Volcano"),
        Volcano::new(100.0, 42)?,
        // The eruption the timeline starts from; its first key switches it to the Plinian
        // showcase preset.
        Eruption::plinian(),
        // When the file has loaded, an `EruptionScript` with its keys is put beside the
        // `Eruption`; when it is reloaded, the script's keys are replaced.
        EruptionTimelineSource(assets.load(TIMELINE)),
        Transform::default(),
    ));
    commands.spawn((
        Camera3d::default(),
        VolcanoViewer,
        VolcanoSkyCamera,
        Transform::from_xyz(16_000.0, 4_000.0, 22_000.0).looking_at(Vec3::new(0.0, 5_000.0, 0.0), Vec3::Y),
    ));
    Ok(())
}

/// R reads the timeline file again (what the file watcher does on its own when it is built in).
fn reload_on_r(keys: Res<ButtonInput<KeyCode>>, assets: Res<AssetServer>) {
    if keys.just_pressed(KeyCode::KeyR) {
        info!("reloading {TIMELINE}");
        assets.reload(TIMELINE);
    }
}

/// Says when the timeline has loaded, or reloaded after an edit, and what it holds.
fn log_loaded_timelines(
    mut events: MessageReader<AssetEvent<EruptionTimelineAsset>>,
    timelines: Res<Assets<EruptionTimelineAsset>>,
) {
    for event in events.read() {
        // Sent once the file has loaded, and again after each reload that parsed.
        let AssetEvent::LoadedWithDependencies { id } = event else { continue };
        let Some(timeline) = timelines.get(*id) else { continue };
        let keys: Vec<String> = timeline.0.keys.iter().map(|k| format!("{} s", k.at_s)).collect();
        info!("timeline loaded: {} keys, at {}", keys.len(), keys.join(", "));
    }
}

/// Every 5 s of the script's clock: where the story stands.
fn log_the_story(
    eruptions: Query<(&Eruption, &EruptionScript)>,
    flows: PyroclasticQuery,
    mut next_s: Local<f64>,
) {
    for (eruption, script) in &eruptions {
        if script.elapsed_s < *next_s {
            continue;
        }
        *next_s = script.elapsed_s + 5.0;
        info!(
            "{:.0} s into the story: v0 {:.0} m/s, {}, {} pyroclastic particles",
            script.elapsed_s,
            eruption.params.v0,
            if eruption.active { "erupting" } else { "quiet" },
            flows.particle_count()
        );
    }
}
