//! Pyroclastic flows: `cargo run --example pyroclastic_flow`.
//!
//! Table 3.1 at 70 m/s over a volcano with a shallow crater: the column falls back from
//! ≈255 m, its slices become pyroclastic particles (drawn as dark ash puffs) that run down the
//! gullies while they deposit ash, and clusters of particles that turned lighter than the air
//! lift off as secondary columns (after about a minute and a half). The "Eruption" window
//! switches presets and edits the column live. Headless:
//! `volcano render --scene pyroclastic_flow --ticks 6000`; deposit map and numbers:
//! `volcano pyroclastic --preset pyroclastic_showcase --seconds 120 --out DIR`.

use bevy::prelude::AppExit;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    volcano::scenes::run_scene_window(
        "pyroclastic_flow",
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
