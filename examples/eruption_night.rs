//! The main scene by night: `cargo run --example eruption_night`.
//!
//! The `eruption` world and eruption under a moonlit sky, exposed for what glows: the vent, the
//! incandescent base of the column and the lava on the flank (the scene file's `sky`: EV100 11,
//! dark sky colours, dim blue ambient light). Headless:
//! `volcano render --scene eruption_night --ticks 6000`.

use bevy::prelude::AppExit;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    volcano::scenes::run_scene_window(
        "eruption_night",
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
