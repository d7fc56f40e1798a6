//! Quality levels switched while the game runs: `cargo run --example quality_levels`, or
//! `cargo run --example quality_levels -- low` (`medium`, `high`, `ultra`) to start at
//! another level.
//!
//! `VolcanoQuality` is one resource. The game inserts a level and `VolcanoQualityPlugin` (in
//! `VolcanoPlugins`) writes that level's numbers into the crates' settings: the cloud volume
//! and its ray march, the ash-fall march, the plume instances drawn per frame and the plume's
//! caps; whenever the game changes the resource, the new level applies on the next frame. Keys
//! 1 to 4 pick Low, Medium, High (the crates' defaults) and Ultra; the game's egui window
//! shows the active level and what it sets. The atmosphere's grid is the one number that
//! needs a restart: it is chosen when the atmosphere is spawned, here from the starting
//! level (`VolcanoQuality::atmosphere_cells`: 32 cells a side at Low, 256 at Ultra).
//!
//! The world: an island, a Plinian volcano and the `eruption` atmosphere over it, so the
//! column, the clouds and the ash fall all show what a level changes. Left-drag orbits,
//! right-drag pans, the wheel zooms.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};
use volcano::prelude::*;

/// The keys that pick the levels, in the order of `VolcanoQuality::ALL`.
const KEYS: [KeyCode; 4] = [KeyCode::Digit1, KeyCode::Digit2, KeyCode::Digit3, KeyCode::Digit4];

fn main() -> AppExit {
    // The starting level: the first argument, by name; High without one.
    let start = std::env::args()
        .nth(1)
        .and_then(|arg| VolcanoQuality::ALL.into_iter().find(|q| format!("{q:?}").eq_ignore_ascii_case(&arg)))
        .unwrap_or_default();
    App::new()
        .add_plugins((DefaultPlugins, EguiPlugin::default(), VolcanoPlugins, VolcanoSkyPlugin))
        // Inserted before the app runs: every crate starts at this level.
        .insert_resource(start)
        .add_systems(Startup, setup)
        .add_systems(Update, pick_level)
        .add_systems(EguiPrimaryContextPass, hud)
        .run()
}

/// The island, the air over it (its grid from the starting level), the volcano and a camera.
fn setup(mut commands: Commands, quality: Res<VolcanoQuality>) -> Result {
    let terrain = StratovolcanoParams::default().generate()?;
    let scenario = WeatherScenario::builtin("eruption")?;
    AtmosphereSpawner::new(&scenario)
        .over(&terrain)
        // The scenario's 128 cells a side, scaled by the level.
        .grid(quality.atmosphere_cells(scenario.grid))
        .prespin(30)
        .spawn(&mut commands)?;
    commands.spawn((Name::new("Island"), terrain));
    commands.spawn((
        Name::new("Volcano"),
        Volcano::new(100.0, 42)?,
        Eruption::plinian(),
        Transform::default(),
    ));
    commands.spawn(camera_bundle(OrbitCamera {
        pitch: 8f32.to_radians(),
        ..OrbitCamera::looking_at(Vec3::new(2_000.0, 5_000.0, 0.0), 30_000.0)
    }));
    Ok(())
}

/// Keys 1 to 4: a new level, applied on the next frame.
fn pick_level(keys: Res<ButtonInput<KeyCode>>, mut quality: ResMut<VolcanoQuality>) {
    for (key, level) in KEYS.into_iter().zip(VolcanoQuality::ALL) {
        if keys.just_pressed(key) {
            // Only a real change marks the resource changed (and re-applies the level).
            quality.set_if_neq(level);
        }
    }
}

/// The game's window: the levels, the active one in bold, and what it sets.
fn hud(mut contexts: EguiContexts, quality: Res<VolcanoQuality>, atmospheres: Query<&Atmosphere>) -> Result {
    let s = quality.settings();
    egui::Window::new("Quality").show(contexts.ctx_mut()?, |ui| {
        for (i, level) in VolcanoQuality::ALL.into_iter().enumerate() {
            let text = egui::RichText::new(format!("{}: {level:?}", i + 1));
            ui.label(if level == *quality { text.strong().underline() } else { text.weak() });
        }
        ui.separator();
        ui.label(format!(
            "clouds: {0} × {0} × {1} voxels, {2} steps",
            s.cloud_voxels_xy, s.cloud_voxels_z, s.cloud_steps
        ));
        ui.label(format!("cloud samples per step: {}, lumps: {}", s.cloud_substeps, s.cloud_detail));
        ui.label(format!("ash fall: {} steps, {} samples per step", s.ash_fall_steps, s.ash_fall_substeps));
        ui.label(format!("plume instances per frame: {}", s.max_instances));
        ui.label(format!(
            "caps: {} slices, {} particles, {} umbrella spheres",
            s.caps.max_live_slices, s.caps.max_particles, s.caps.max_umbrella_spheres
        ));
        for air in &atmospheres {
            ui.label(format!("atmosphere: {} cells a side (set at start-up)", air.n));
        }
    });
    Ok(())
}
