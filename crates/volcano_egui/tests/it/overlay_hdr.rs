//! egui over an HDR scene camera: with [`EguiOverlayCameraPlugin`], a panel drawn by egui
//! shows over a [`GlowCamera`] (HDR, bloom) scene, and the scene shows around it.
//!
//! A 320 × 240 headless frame of the sky with a 100 × 100 px magenta square painted by egui.
//! The square must be there (at least 9,500 of its 10,000 pixels magenta), and the frame's
//! centre, outside the square, must be the sky as drawn with no egui at all. Without the
//! overlay (egui on the HDR camera itself) the square is missing: 0 magenta pixels under
//! llvmpipe with bevy_egui 0.40, printed, not asserted (that is bevy_egui's behaviour, not
//! ours). With an overlay that writes its texture over the scene's instead of blending it, the
//! square is drawn but the centre turns black (tried: (0, 0, 0) against (157, 173, 192)).

use bevy::camera::RenderTarget;
use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};
use volcano_core::VolcanoCorePlugin;
use volcano_egui::{EguiOverlayCamera, EguiOverlayCameraPlugin};
use volcano_render::{
    GlowCamera, HeadlessCapturePlugin, OrbitCamera, VolcanoRenderPlugins, VolcanoSkyPlugin, VolcanoViewer,
    camera_bundle, headless_default_plugins,
};
use volcano_test_support::read_png_rgb;

const W: u32 = 320;
const H: u32 = 240;

/// Egui in a headless app; which camera draws it.
#[derive(Clone, Copy, PartialEq)]
enum Egui {
    None,
    OnTheSceneCamera,
    Overlay,
}

/// The overlay camera was pointed at the capture image.
#[derive(Component)]
struct Retargeted;

/// Renders the sky through an HDR [`GlowCamera`] with `egui`; returns the frame's RGB.
fn render(name: &str, egui: Egui) -> Vec<u8> {
    let out = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_file(&out);
    let mut app = App::new();
    // One app after the other in this process: only the first may set the global logger.
    app.add_plugins(headless_default_plugins().disable::<bevy::log::LogPlugin>())
        .add_plugins((VolcanoCorePlugin, VolcanoRenderPlugins, VolcanoSkyPlugin))
        .add_plugins(HeadlessCapturePlugin {
            width: W,
            height: H,
            out: out.clone(),
            capture_after_updates: 12,
        });
    if egui != Egui::None {
        app.add_plugins(EguiPlugin::default());
    }
    if egui == Egui::Overlay {
        app.add_plugins(EguiOverlayCameraPlugin);
    }
    app.add_systems(Startup, |mut commands: Commands| {
        let orbit =
            OrbitCamera { focus: Vec3::new(0.0, 500.0, 0.0), pitch: 0.05, distance: 5_000.0, ..default() };
        commands.spawn((camera_bundle(orbit), GlowCamera));
    });
    // The overlay targets the primary window; here it draws into the capture image instead.
    app.add_systems(
        Update,
        |viewer: Query<&RenderTarget, With<VolcanoViewer>>,
         overlay: Query<Entity, (With<EguiOverlayCamera>, Without<Retargeted>)>,
         mut commands: Commands| {
            let Ok(target) = viewer.single() else { return };
            for e in &overlay {
                commands.entity(e).insert((target.clone(), Retargeted));
            }
        },
    );
    if egui != Egui::None {
        app.add_systems(EguiPrimaryContextPass, |mut contexts: EguiContexts| -> Result {
            let square = egui::Rect::from_min_size(egui::pos2(10.0, 10.0), egui::vec2(100.0, 100.0));
            let layer = egui::LayerId::new(egui::Order::Foreground, egui::Id::new("square"));
            contexts.ctx_mut()?.layer_painter(layer).rect_filled(
                square,
                0.0,
                egui::Color32::from_rgb(255, 0, 255),
            );
            Ok(())
        });
    }
    let exit = app.run();
    assert!(exit.is_success(), "app exited with {exit:?}");
    read_png_rgb(&out).expect("PNG written").2
}

fn magenta_pixels(rgb: &[u8]) -> usize {
    rgb.chunks(3).filter(|p| p[0] > 200 && p[1] < 60 && p[2] > 200).count()
}

fn centre(rgb: &[u8]) -> [u8; 3] {
    let i = (((H / 2) * W + W / 2) * 3) as usize;
    [rgb[i], rgb[i + 1], rgb[i + 2]]
}

#[test]
fn egui_on_the_overlay_shows_over_an_hdr_scene() {
    let plain = render("overlay_none.png", Egui::None);
    let on_scene = render("overlay_on_scene_camera.png", Egui::OnTheSceneCamera);
    let overlay = render("overlay_camera.png", Egui::Overlay);
    eprintln!(
        "magenta pixels: {} on the HDR scene camera, {} on the overlay; centre {:?} without egui, {:?} with the overlay",
        magenta_pixels(&on_scene),
        magenta_pixels(&overlay),
        centre(&plain),
        centre(&overlay)
    );
    assert!(
        magenta_pixels(&overlay) >= 9_500,
        "the overlay drew no egui: {} magenta pixels",
        magenta_pixels(&overlay)
    );
    let (a, b) = (centre(&plain), centre(&overlay));
    assert!(
        a.iter().zip(b).all(|(x, y)| x.abs_diff(y) <= 2),
        "the scene does not show around the overlay: centre {b:?}, {a:?} without egui"
    );
}
