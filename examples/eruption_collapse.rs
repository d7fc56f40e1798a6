//! The main scene with a collapsing column: `cargo run --example eruption_collapse`.
//!
//! The `eruption` world (procedural stratovolcano, coupled five-layer atmosphere) with Table 3.1
//! at 70 m/s: the column falls back, pyroclastic flows run down the flanks depositing ash, and
//! lighter-than-air clusters lift off as secondary columns whose ash the layers carry. The
//! "Eruption" window switches presets (back to `plinian_showcase`, for instance). Headless:
//! `volcano render --scene eruption_collapse --ticks 5000`.

use bevy::prelude::AppExit;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    volcano::scenes::run_scene_window(
        "eruption_collapse",
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
