//! Renders a small procedural volcano offscreen (no window, no GPU needed: llvmpipe Vulkan
//! works) and checks the PNG is a real picture: right size, not one colour, terrain in the
//! middle different from the sky at the top.

use crate::common;

use bevy::prelude::*;
use volcano_core::{StratovolcanoParams, Volcano};
use volcano_render::{OrbitCamera, camera_bundle, headless_default_plugins};
use volcano_test_support::{rgb_region_mean, rgb_stddev};

const W: u32 = 320;
const H: u32 = 240;

fn scene(mut commands: Commands) {
    let terrain = StratovolcanoParams { resolution: 96, cell: 200.0, ..Default::default() }
        .generate()
        .expect("valid terrain parameters");
    commands.spawn((Name::new("Terrain"), terrain));
    commands.spawn((Name::new("Volcano"), Volcano::default(), Transform::default()));
    let orbit = OrbitCamera {
        focus: Vec3::new(0.0, 900.0, 0.0),
        yaw: 0.35,
        pitch: 12f32.to_radians(),
        distance: 16_000.0,
        ..default()
    };
    commands.spawn(camera_bundle(orbit));
    // The sun: VolcanoSkyPlugin spawns its default one (south-west, 35° high).
}

#[test]
fn renders_a_volcano_under_a_sky() {
    // Cargo's scratch directory for integration tests (kept, so the frame can be looked at).
    let out = common::out_path("headless_smoke.png");

    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 10);
    app.add_systems(Startup, scene);
    let (w, h, rgb) = common::run_and_read(app, &out);
    eprintln!("smoke frame: {}", out.display());

    assert_eq!((w, h), (W, H));
    let sigma = rgb_stddev(&rgb);
    assert!(sigma > 8.0, "frame looks blank: pixel σ = {sigma:.2}");

    let sky = rgb_region_mean(&rgb, W, (0, W), (0, H / 8));
    let ground = rgb_region_mean(&rgb, W, (W / 4, 3 * W / 4), (3 * H / 4, H));
    let diff: f64 = (0..3).map(|c| (sky[c] - ground[c]).abs()).sum();
    eprintln!("sky mean {sky:?}, ground mean {ground:?}, σ {sigma:.1}");
    assert!(diff > 30.0, "sky {sky:?} and terrain {ground:?} look alike");
    assert!(sky[2] > sky[0], "the sky should be bluish: {sky:?}");
}
