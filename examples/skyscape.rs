//! Layered atmosphere over a volcanic island (thesis §4.2): the five built-in scenarios
//! (convection, island, sea-breeze, orographic, mixed) with volumetric clouds. The
//! "Atmosphere" window switches scenarios, pauses the weather, shows per-layer field maps
//! (thesis Fig 4.6) and paints into any field of any layer.
//!
//! `cargo run --example skyscape`; the same scene renders headless with
//! `volcano render --scene skyscape --ticks 500 --out sky.png`.

use bevy::prelude::AppExit;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    volcano::scenes::run_scene_window(
        "skyscape",
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
