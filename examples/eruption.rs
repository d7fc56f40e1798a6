//! The main scene: `cargo run --example eruption`.
//!
//! A procedural stratovolcano with its vent, the sun and sky, an orbit camera (left-drag to
//! orbit, right-drag to pan, wheel to zoom) and the tuning panel (pause, step, speed, frame
//! time). The same scene renders headless with `volcano render --scene eruption`.

use bevy::prelude::AppExit;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    volcano::scenes::run_scene_window(
        "eruption",
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
