//! The volcano panel over a small procedural volcano, in a window.
//!
//! `cargo run -p volcano_egui --example volcano_panel`. With `VOLCANO_SCREENSHOT=out.png` the
//! window is captured after 60 frames and the app exits (handy under `xvfb-run`).

use bevy::prelude::*;
use bevy_egui::EguiPlugin;
use volcano_core::{StratovolcanoParams, Volcano, VolcanoCorePlugin};
use volcano_egui::VolcanoDebugPlugins;
use volcano_render::{OrbitCamera, VolcanoRenderPlugins, VolcanoSkyPlugin, camera_bundle};

fn main() -> AppExit {
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window {
            title: "Volcano panel".into(),
            resolution: (960, 600).into(),
            ..default()
        }),
        ..default()
    }))
    .add_plugins((VolcanoCorePlugin, VolcanoRenderPlugins, VolcanoSkyPlugin))
    .add_plugins((EguiPlugin::default(), VolcanoDebugPlugins))
    .add_systems(Startup, scene);
    if let Some(capture) = volcano_render::WindowScreenshotPlugin::from_env() {
        app.add_plugins(capture);
    }
    app.run()
}

fn scene(mut commands: Commands) {
    let terrain =
        StratovolcanoParams { resolution: 256, cell: 80.0, ..default() }.generate().expect("valid terrain");
    commands.spawn((Name::new("Terrain"), terrain));
    commands.spawn((Name::new("Volcano"), Volcano::default(), Transform::default()));
    let orbit = OrbitCamera {
        focus: Vec3::new(0.0, 1_000.0, 0.0),
        pitch: 14f32.to_radians(),
        distance: 17_000.0,
        ..default()
    };
    commands.spawn(camera_bundle(orbit));
}
