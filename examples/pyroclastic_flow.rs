//! Pyroclastic flows: `cargo run --example pyroclastic_flow`.
//!
//! Table 3.1 at 70 m/s over a volcano with a shallow crater: the column falls back from
//! ≈255 m, its slices become pyroclastic particles (drawn as dark ash puffs) that run down the
//! gullies while they deposit ash, and clusters of particles that turned lighter than the air
//! lift off as secondary columns (after about a minute and a half). The "Eruption" window
//! switches presets and edits the column live. Headless:
//! `volcano render --scene pyroclastic_flow --ticks 6000`; deposit map and numbers:
//! `volcano pyroclastic --preset pyroclastic_showcase --seconds 120 --out DIR`.

use bevy::prelude::*;
use volcano::prelude::*;

fn main() -> AppExit {
    let scene = match VolcanoScenePlugin::builtin("pyroclastic_flow") {
        Ok(scene) => scene,
        Err(e) => {
            eprintln!("error: {e}");
            return AppExit::error();
        }
    };
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window { title: "volcano: pyroclastic flow".into(), ..default() }),
        ..default()
    }))
    .add_plugins((VolcanoPlugins, scene));
    // `VOLCANO_SCREENSHOT=out.png` (e.g. under xvfb-run): screenshot after 60 frames and exit.
    if let Some(capture) = volcano::render::WindowScreenshotPlugin::from_env() {
        app.add_plugins(capture);
    }
    app.run()
}
