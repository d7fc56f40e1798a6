//! Any built-in scene in a window with the debug panels:
//! `cargo run --example scene_viewer -- eruption_night` (no name: `eruption`, the main scene).
//! `--list` prints the names. The same scenes render headless with
//! `volcano render --scene NAME`.
//!
//! A scene is a RON file in `assets/scenes/` (terrain, volcano, eruption, atmosphere, lava, sky
//! and camera); `VolcanoScenePlugin` spawns it. The window has the orbit camera (left-drag to
//! orbit, right-drag to pan, wheel to zoom) and the tuning panels (pause, step, speed, frame
//! time), drawn on their own overlay camera over the HDR scene.

use bevy::prelude::*;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    let name = std::env::args().nth(1).unwrap_or_else(|| "eruption".to_string());
    if name == "--list" {
        println!("{}", volcano::scenes::names().join("\n"));
        return AppExit::Success;
    }
    volcano::scenes::run_scene_window(
        &name,
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
