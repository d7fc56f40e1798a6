//! egui on its own overlay camera, so the scene camera can be HDR with bloom.
//!
//! bevy_egui puts the primary egui context on the first camera an app spawns; with bevy_egui
//! 0.40 nothing is drawn when that camera is HDR (seen with llvmpipe, in a window and headless:
//! `tests/overlay_hdr.rs`). [`EguiOverlayCameraPlugin`] turns that automatic choice off and
//! spawns a 2D camera that draws only egui: LDR, after every other camera of its target, cleared
//! to transparent and alpha-blended over what they drew. The scene camera is then free to be a
//! [`volcano_render::GlowCamera`] (HDR, bloom, tonemapping). Opt-in: it moves every egui
//! panel of the app, the game's own too, onto that camera.

use bevy::camera::{CameraOutputMode, ClearColorConfig};
use bevy::prelude::*;
use bevy::render::render_resource::BlendState;
use bevy_egui::{EguiGlobalSettings, PrimaryEguiContext};

/// Marks the camera [`EguiOverlayCameraPlugin`] spawns for egui.
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct EguiOverlayCamera;

/// Draws egui on its own overlay camera (see the module docs). Add it with `EguiPlugin`, in
/// either order, before the app spawns its first camera.
#[derive(Debug, Default, Clone, Copy)]
pub struct EguiOverlayCameraPlugin;

impl EguiOverlayCameraPlugin {
    /// Camera order of the overlay: after any camera a scene or game is likely to use.
    pub const ORDER: isize = 100;
}

impl Plugin for EguiOverlayCameraPlugin {
    fn build(&self, app: &mut App) {
        // `EguiPlugin` only initialises the settings when they are missing, so this holds
        // whichever plugin comes first.
        match app.world_mut().get_resource_mut::<EguiGlobalSettings>() {
            Some(mut settings) => settings.auto_create_primary_context = false,
            None => {
                app.insert_resource(EguiGlobalSettings { auto_create_primary_context: false, ..default() });
            }
        }
        app.register_type::<EguiOverlayCamera>().add_systems(PreStartup, spawn_overlay_camera);
    }
}

/// The overlay camera's components: a 2D camera that draws after every camera of order below
/// [`EguiOverlayCameraPlugin::ORDER`], clears its own texture to transparent and blends it over
/// theirs, and holds the primary egui context. Its target is the primary window (insert a
/// `RenderTarget` to change it).
pub fn overlay_camera_bundle() -> impl Bundle {
    (
        Camera2d,
        Camera {
            order: EguiOverlayCameraPlugin::ORDER,
            clear_color: ClearColorConfig::Custom(Color::NONE),
            output_mode: CameraOutputMode::Write {
                blend_state: Some(BlendState::ALPHA_BLENDING),
                clear_color: ClearColorConfig::None,
            },
            ..default()
        },
        PrimaryEguiContext,
        EguiOverlayCamera,
        Name::new("egui overlay camera"),
    )
}

fn spawn_overlay_camera(mut commands: Commands) {
    commands.spawn(overlay_camera_bundle());
}
