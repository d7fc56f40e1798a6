//! The set-up the headless render tests share: an app with Bevy's headless plugins, the
//! core, render and sky plugins and a capture of one frame, run to its end, the frame read back.
#![allow(dead_code, reason = "each test crate uses its own part")]

use std::path::{Path, PathBuf};

use bevy::app::PluginGroupBuilder;
use bevy::prelude::*;
use volcano_core::VolcanoCorePlugin;
use volcano_render::{
    HeadlessCapturePlugin, OrbitCamera, VolcanoRenderPlugins, VolcanoSkyPlugin, camera_bundle, read_png_rgb,
};

/// `name` in Cargo's scratch directory for integration tests (kept, so the frame can be looked
/// at), with any frame of an earlier run removed.
pub fn out_path(name: &str) -> PathBuf {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_file(&out);
    out
}

/// An app with `headless` (`headless_default_plugins()`, possibly trimmed), the core, render
/// and sky plugins, capturing a `width × height` frame to `out` after `updates` updates.
pub fn capture_app(headless: PluginGroupBuilder, width: u32, height: u32, out: &Path, updates: u32) -> App {
    let mut app = App::new();
    app.add_plugins(headless)
        .add_plugins((VolcanoCorePlugin, VolcanoRenderPlugins, VolcanoSkyPlugin))
        .add_plugins(HeadlessCapturePlugin {
            width,
            height,
            out: out.to_path_buf(),
            capture_after_updates: updates,
        });
    app
}

/// Runs `app` to its end, checks that it exited successfully and returns the frame written to
/// `out` (width, height, RGB).
pub fn run_and_read(mut app: App, out: &Path) -> (u32, u32, Vec<u8>) {
    let exit = app.run();
    assert!(exit.is_success(), "app exited with {exit:?}");
    read_png_rgb(out).expect("PNG written")
}

/// The ash tests' stage: the camera 5 km from a point 500 m up, looking nearly level, and a
/// shadowless 100,000-lux sun that each test turns where it needs it.
pub fn ash_stage(mut commands: Commands) {
    commands.spawn(camera_bundle(ash_stage_orbit()));
    commands.spawn((
        DirectionalLight { illuminance: 100_000.0, shadow_maps_enabled: false, ..default() },
        Transform::default(),
    ));
}

/// The ash tests' camera (see [`ash_stage`]).
pub fn ash_stage_orbit() -> OrbitCamera {
    OrbitCamera { focus: Vec3::new(0.0, 500.0, 0.0), pitch: 0.05, distance: 5_000.0, ..default() }
}

/// Luminance of an sRGB-encoded mean colour, Rec. 709 weights on the encoded values (what the
/// tests compare, not a photometric quantity).
pub fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Frame size of the one-puff ash tests (px).
pub const PUFF_W: u32 = 320;
pub const PUFF_H: u32 = 240;
/// On-screen radius (m) of the one-puff tests' smoke billboard, [`PUFF_DISTANCE`] in front of
/// the camera: ≈ 72 px.
pub const PUFF_RADIUS: f32 = 500.0;
pub const PUFF_DISTANCE: f32 = 2_000.0;

/// The one-puff tests' parent: a smoke billboard of [`PUFF_RADIUS`] at `center` (no detail
/// spheres), mid shade, full coverage, with the packed light word `light`.
pub fn puff_parent(center: Vec3, light: u32) -> volcano_render::plume::AshParent {
    use volcano_render::plume::AshParent;
    AshParent {
        center: center.to_array(),
        radius: PUFF_RADIUS / 1.35,
        rotation: Quat::IDENTITY.to_array(),
        angle: 0.3,
        shade: 0.5,
        coverage: 1.0,
        variant: 0.4,
        key: 11,
        flags: AshParent::BILLBOARD,
        billboard_radius: PUFF_RADIUS,
        light,
    }
}

/// A cloud density volume (g/m³) of `n³` voxels over `lo..hi` from a function of the world
/// position, in the layout of `volcano_render::density_volume::density_image` (x fastest, then
/// world z, then altitude).
pub fn density_volume(n: usize, lo: Vec3, hi: Vec3, f: impl Fn(Vec3) -> f32) -> Vec<f32> {
    let mut d = vec![0.0; n * n * n];
    for iz in 0..n {
        for jy in 0..n {
            for ix in 0..n {
                let t = (Vec3::new(ix as f32, iz as f32, jy as f32) + 0.5) / n as f32;
                d[(iz * n + jy) * n + ix] = f(lo + (hi - lo) * t);
            }
        }
    }
    d
}

/// Runs `app` (a [`capture_app`] of at least 40 updates writing `out`) and returns the mean wall
/// time (ms) per update of updates 10–40: what a frame costs once the pipelines are compiled.
pub fn mean_frame_ms(mut app: App, out: &Path) -> f64 {
    use std::sync::{Arc, Mutex};
    use std::time::Instant;
    let stamps: Arc<Mutex<Vec<Instant>>> = Arc::default();
    let sink = stamps.clone();
    app.add_systems(Last, move || sink.lock().unwrap().push(Instant::now()));
    run_and_read(app, out);
    let t = stamps.lock().unwrap();
    (t[40] - t[10]).as_secs_f64() * 1e3 / 30.0
}
