//! The volumetric clouds draw: an atmosphere whose western half (the left of the view) holds
//! a dense cumulonimbus wall in every layer is rendered from the south with the sun behind
//! the camera, so without clouds the sky would be left–right symmetric. The left half of the
//! sky band must differ clearly from the right half (clear sky); if the cloud box, its
//! material or its density image were missing, both halves would match.

use crate::common;

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use volcano_atmosphere::{AtmosphereParams, WeatherScenario, spawn_atmosphere};
use volcano_render::{
    CloudRenderSettings, CloudVolume, OrbitCamera, Sun, camera_bundle, headless_default_plugins, sun_bundle,
};
use volcano_test_support::rgb_region_mean;

const W: u32 = 256;
const H: u32 = 160;

fn scene(mut commands: Commands) {
    let mut state = WeatherScenario::builtin("convection").unwrap().build(Some(16)).unwrap();
    let n = state.grid.n;
    for layer in &mut state.layers {
        for k in 0..n * n {
            if state.grid.centre(k).0 < 0.0 {
                layer.w.data_mut()[k] = 1.0;
                layer.d.data_mut()[k] = 1.0;
            }
        }
    }
    spawn_atmosphere(&mut commands, state, AtmosphereParams::default()).unwrap();
    let orbit = OrbitCamera {
        focus: Vec3::new(0.0, 1_500.0, 0.0),
        yaw: 0.0,
        pitch: 0.0,
        distance: 40_000.0,
        ..default()
    };
    commands.spawn(camera_bundle(orbit));
    commands.spawn(sun_bundle(Sun { azimuth_deg: 180.0, elevation_deg: 40.0, illuminance: 130_000.0 }));
}

#[test]
fn a_dense_cloud_wall_hides_the_sky() {
    let out = common::out_path("headless_clouds.png");
    // `App::run` consumes the world: copy the volumes' fill out as the app runs.
    let seen: Arc<Mutex<Vec<f32>>> = Arc::default();
    let sink = seen.clone();
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    // Built in the frame the weather moves, so the capture shows it.
    app.insert_resource(CloudRenderSettings { off_thread: false, ..default() })
        .add_systems(Startup, scene)
        .add_systems(Last, move |volumes: Query<&CloudVolume>| {
            *sink.lock().unwrap() = volumes.iter().map(|v| v.filled_fraction).collect();
        });
    let (_, _, rgb) = common::run_and_read(app, &out);
    let filled = seen.lock().unwrap().clone();
    assert_eq!(filled.len(), 1, "one cloud volume");
    assert!(filled[0] > 0.05, "density image nearly empty: {filled:?}");
    // Just above the horizon (rays cross the cloud layers inside the volume).
    let rows = (H / 2 - 24, H / 2 - 2);
    let left = rgb_region_mean(&rgb, W, (8, W / 2 - 16), rows);
    let right = rgb_region_mean(&rgb, W, (W / 2 + 16, W - 8), rows);
    let diff: f64 = left.iter().zip(&right).map(|(a, b)| (a - b).abs()).sum();
    eprintln!("cloud side {left:?}, clear side {right:?}, |Δ| {diff:.1} ({})", out.display());
    assert!(diff > 40.0, "the clouds draw nothing: left {left:?} vs right {right:?}");
}
