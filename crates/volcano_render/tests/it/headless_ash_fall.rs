//! The ash fall draws, and draws where the ash is: an atmosphere holds an ash curtain in the
//! western half of the view (an umbrella-like sheet in the top layers and the ash falling
//! from it below, drifting west with height as a sheared wind would leave it), none in the
//! eastern half. Seen from the south with the sun behind the camera, the sky above the
//! horizon is otherwise left–right symmetric. The ash side must be clearly darker than the
//! clear side; if the ash box, its density image or its material were missing, both sides
//! would match. (The camera stands 25 km away: from 40 km the scene's distance fog covers the
//! lit ash almost as much as the sky.) A second run with the same atmosphere but no ash checks
//! that the two sides then do match (the asymmetry comes from the ash).

use crate::common;

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use volcano_atmosphere::{AtmosphereParams, WeatherScenario, spawn_atmosphere};
use volcano_render::{
    AshFallSettings, AshFallVolume, OrbitCamera, Sun, camera_bundle, headless_default_plugins, sun_bundle,
};
use volcano_test_support::rgb_region_mean;

const W: u32 = 320;
const H: u32 = 180;

fn scene(with_ash: bool) -> impl Fn(Commands) {
    move |mut commands: Commands| {
        // Dry: no clouds, so only the ash can break the symmetry.
        let mut state = WeatherScenario::builtin("eruption").unwrap().build(Some(32)).unwrap();
        let n = state.grid.n;
        let nl = state.layers.len();
        for (i, layer) in state.layers.iter_mut().enumerate() {
            layer.h.data_mut().fill(0.0);
            layer.w.data_mut().fill(0.0);
            if !with_ash {
                continue;
            }
            // Higher layers: the sheet further west (x from −3 km to −6 km) and denser.
            let up = i as f64 / (nl - 1).max(1) as f64;
            let shift = -3_000.0 - 3_000.0 * up;
            for k in 0..n * n {
                let (x, y) = state.grid.centre(k);
                let r2 = (x - shift).powi(2) + (y / 1.5).powi(2);
                if r2 < 4_500.0f64.powi(2) {
                    layer.ash.data_mut()[k] = 0.01 + 0.04 * up;
                }
            }
        }
        spawn_atmosphere(&mut commands, state, AtmosphereParams::default()).unwrap();
        let orbit = OrbitCamera {
            focus: Vec3::new(0.0, 5_000.0, 0.0),
            yaw: 0.0,
            pitch: 0.0,
            distance: 25_000.0,
            ..default()
        };
        commands.spawn(camera_bundle(orbit));
        commands.spawn(sun_bundle(Sun { azimuth_deg: 180.0, elevation_deg: 40.0, illuminance: 130_000.0 }));
    }
}

/// Renders the scene; returns (left sky band mean, right sky band mean, built volumes' fill).
fn render(with_ash: bool, name: &str) -> ([f64; 3], [f64; 3], Vec<f32>) {
    let out = common::out_path(name);
    let seen: Arc<Mutex<Vec<f32>>> = Arc::default();
    let sink = seen.clone();
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    // Built in the frame, so the capture cannot precede the worker.
    app.insert_resource(AshFallSettings { off_thread: false, ..default() });
    app.add_systems(Startup, scene(with_ash)).add_systems(Last, move |volumes: Query<&AshFallVolume>| {
        *sink.lock().unwrap() = volumes.iter().map(|v| v.filled_fraction).collect();
    });
    let (_, _, rgb) = common::run_and_read(app, &out);
    // Above the horizon, where the rays cross the layers inside the volume.
    let rows = (H / 2 - 50, H / 2 + 10);
    let left = rgb_region_mean(&rgb, W, (16, W / 2 - 24), rows);
    let right = rgb_region_mean(&rgb, W, (W / 2 + 24, W - 16), rows);
    eprintln!("{name}: left {left:?}, right {right:?} ({})", out.display());
    (left, right, seen.lock().unwrap().clone())
}

#[test]
fn an_ash_curtain_darkens_the_sky_where_the_ash_is() {
    let (left, right, filled) = render(true, "headless_ash_fall.png");
    assert_eq!(filled.len(), 1, "one ash volume");
    assert!(filled[0] > 0.05, "ash density image nearly empty: {filled:?}");
    let (l, r) = (common::luminance(left), common::luminance(right));
    assert!(l < r - 12.0, "the ash side is not darker: left {left:?} vs right {right:?}");
    // Without ash: no volume, and the two sides match.
    let (left0, right0, filled0) = render(false, "headless_ash_fall_none.png");
    assert!(filled0.is_empty(), "no ash, no volume: {filled0:?}");
    let d0 = (common::luminance(left0) - common::luminance(right0)).abs();
    assert!(d0 < 3.0, "sky asymmetric without ash: {left0:?} vs {right0:?}");
}
