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
    App::new()
        .add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window { title: "volcano: eruption".into(), ..default() }),
            ..default()
        }))
        .add_plugins((VolcanoPlugins, scene))
        .run()
}
