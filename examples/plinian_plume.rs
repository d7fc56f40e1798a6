//! A Plinian column close up: `cargo run --example plinian_plume`.
//!
//! Thesis Table 3.1 at 200 m/s with a 20 m/s wind at 12 km: the column rises as smoke
//! billboards (their texture turning with the projected spin) and detail spheres, shaded by
//! density, and spreads into an umbrella. The "Eruption" window edits every parameter live
//! (preset switch, vent, slice model, wind, sphere counts, view mode) and plots the slices'
//! density against altitude with the air (Fig 3.5 A, live). Orbit camera: left-drag to orbit,
//! right-drag to pan, wheel to zoom. Headless: `volcano render --scene plinian_plume`.

use bevy::prelude::AppExit;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    volcano::scenes::run_scene_window(
        "plinian_plume",
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
