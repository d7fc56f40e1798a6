//! The main scene: `cargo run --example eruption`.
//!
//! A procedural stratovolcano with its vent, the sun and sky, an orbit camera (left-drag to
//! orbit, right-drag to pan, wheel to zoom) and the tuning panel (pause, step, speed, frame
//! time). The same scene renders headless with `volcano render --scene eruption`.

use bevy::prelude::*;
use volcano::prelude::*;

fn main() -> AppExit {
    let scene = match VolcanoScenePlugin::builtin("eruption") {
        Ok(scene) => scene,
        Err(e) => {
            eprintln!("error: {e}");
            return AppExit::error();
        }
    };
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window { title: "volcano: eruption".into(), ..default() }),
        ..default()
    }))
    .add_plugins((VolcanoPlugins, scene));
    // `VOLCANO_SCREENSHOT=out.png` (e.g. under xvfb-run): screenshot after 60 frames and exit.
    if let Some(capture) = volcano::render::WindowScreenshotPlugin::from_env() {
        app.add_plugins(capture);
    }
    app.run()
}
