//! The debug panels work whether the game adds `EguiPlugin` before or after them (bevy_egui's
//! advice to plugin authors: never add `EguiPlugin` for the user).

use bevy::prelude::*;
use bevy_egui::EguiPlugin;
use volcano_core::VolcanoCorePlugin;
use volcano_render::headless_default_plugins;

fn run(app: &mut App) {
    while app.plugins_state() == bevy::app::PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    for _ in 0..3 {
        app.update();
    }
}

#[test]
fn egui_plugin_added_before_the_panels() {
    let mut app = App::new();
    app.add_plugins(headless_default_plugins())
        .add_plugins(EguiPlugin::default())
        .add_plugins(VolcanoCorePlugin)
        .add_plugins(volcano_egui::VolcanoDebugPlugins);
    run(&mut app);
}

#[test]
fn egui_plugin_added_after_the_panels() {
    let mut app = App::new();
    app.add_plugins(headless_default_plugins())
        .add_plugins(VolcanoCorePlugin)
        .add_plugins(volcano_egui::VolcanoDebugPlugins)
        .add_plugins(EguiPlugin::default());
    run(&mut app);
}
