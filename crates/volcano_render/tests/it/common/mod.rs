//! The stages and scenes the headless render tests share; the capture app and the PNG
//! read-back are `volcano_test_support`'s.

use std::path::{Path, PathBuf};

use bevy::prelude::*;
use volcano_render::{OrbitCamera, camera_bundle};
pub use volcano_test_support::{capture_app, luminance, run_and_read};

/// `name` in Cargo's scratch directory for integration tests (kept, so the frame can be looked
/// at), with any frame of an earlier run removed.
pub fn out_path(name: &str) -> PathBuf {
    volcano_test_support::out_path(env!("CARGO_TARGET_TMPDIR"), name)
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
