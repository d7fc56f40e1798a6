//! Pahoehoe folds: `cargo run --example lava_folds`.
//!
//! Lava from a source runs down a 3° slope (thesis Fig 5.10, 64 m table of 0.5 m cells) into
//! a long obstacle: the surface glows where it is fresh and darkens as its crust grows, the
//! crust thickens where the flow is held back, and folds (ropes of oriented particles) form and
//! pile up in front of the obstacle after about three minutes. The "Lava" window switches the
//! three Fig 5.10 terrains (long obstacle, small obstacle, canyon), edits the viscosity model,
//! cooling, crust and fold parameters live, and switches to the debug views (crust in the
//! colours of Figs 5.11–5.13); Ctrl + left click on the table places another source.
//! Headless: `volcano render --scene lava_folds --ticks 12000 [--lava-view crust]`; maps and
//! numbers: `volcano lava --scenario obstacle --seconds 240 --out DIR`.

use bevy::prelude::AppExit;
use bevy_egui::EguiPlugin;
use volcano_egui::{EguiOverlayCameraPlugin, VolcanoDebugPlugins};

fn main() -> AppExit {
    volcano::scenes::run_scene_window(
        "lava_folds",
        (EguiPlugin::default(), EguiOverlayCameraPlugin, VolcanoDebugPlugins),
    )
}
