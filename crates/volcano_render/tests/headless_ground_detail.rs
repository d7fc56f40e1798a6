//! The terrain's per-pixel detail ([`GroundDetail`]) draws and follows its setting, and does not
//! alias: a flat bare terrain (one vertex colour, one normal) under a low sun, rendered with
//! the default detail and with [`GroundDetail::OFF`].
//!
//! - Close up (camera 60 m above the ground, looking 45° down: about 0.5 m a pixel) the mean
//!   luminance step between neighbouring pixels must be clearly larger with detail than
//!   without. If the detail pass drew nothing or ignored its setting, both frames would match.
//! - Far away (ground 5–15 km off, seen from 1 km up: tens of metres a pixel, more along the
//!   view) the frame with detail must show no more pixel-to-pixel contrast than the one
//!   without: every octave is finer than two pixels there and must have faded out. Without the
//!   fade the noise is sampled far below its wavelength and the band turns to speckle.

mod common;

use bevy::prelude::*;
use volcano_core::Terrain;
use volcano_render::{GroundDetail, OrbitCamera, camera_bundle, headless_default_plugins};

const W: u32 = 320;
const H: u32 = 240;

/// Renders a flat bare terrain at 100 m (20.5 km square) from a camera at `eye` looking north
/// `pitch_deg` down, with `detail`; returns the frame's RGB.
fn render(name: &str, detail: GroundDetail, eye: Vec3, pitch_deg: f32) -> Vec<u8> {
    let out = common::out_path(name);
    // One app after the other in this process: only the first may set the global logger.
    let mut app =
        common::capture_app(headless_default_plugins().disable::<bevy::log::LogPlugin>(), W, H, &out, 8);
    app.insert_resource(detail);
    app.add_systems(Startup, move |mut commands: Commands| {
        commands.spawn(Terrain::flat(257, 80.0, 100.0).unwrap());
        let (sin, cos) = pitch_deg.to_radians().sin_cos();
        let d = 1_000.0;
        let orbit = OrbitCamera {
            focus: eye + Vec3::new(0.0, -d * sin, -d * cos),
            yaw: 0.0,
            pitch: pitch_deg.to_radians(),
            distance: d,
            ..default()
        };
        commands.spawn(camera_bundle(orbit));
        // A low sun from the east-south-east: relief shows as lit and shaded faces.
        commands.spawn((
            DirectionalLight { illuminance: 100_000.0, shadow_maps_enabled: false, ..default() },
            Transform::from_xyz(1.0, 0.45, 0.3).looking_at(Vec3::ZERO, Vec3::Y),
        ));
    });
    let (_, _, rgb) = common::run_and_read(app, &out);
    rgb
}

/// Mean |luminance difference| (0–255, Rec. 709 weights on the encoded values) between each
/// pixel and its right and lower neighbours, over rows `y0..y1`.
fn neighbour_contrast(rgb: &[u8], (y0, y1): (u32, u32)) -> f64 {
    let lum = |x: u32, y: u32| {
        let i = ((y * W + x) * 3) as usize;
        0.2126 * rgb[i] as f64 + 0.7152 * rgb[i + 1] as f64 + 0.0722 * rgb[i + 2] as f64
    };
    let (mut sum, mut n) = (0.0, 0.0);
    for y in y0..y1 - 1 {
        for x in 0..W - 1 {
            let l = lum(x, y);
            sum += (lum(x + 1, y) - l).abs() + (lum(x, y + 1) - l).abs();
            n += 2.0;
        }
    }
    sum / n
}

#[test]
fn detail_shows_up_close_and_fades_far_away() {
    // Close: the eye 60 m above the ground, 45° down; the whole frame is ground.
    let close = Vec3::new(0.0, 160.0, 0.0);
    let off = render("headless_detail_close_off.png", GroundDetail::OFF, close, 45.0);
    let on = render("headless_detail_close_on.png", GroundDetail::default(), close, 45.0);
    let (c_off, c_on) = (neighbour_contrast(&off, (0, H)), neighbour_contrast(&on, (0, H)));
    eprintln!("close: neighbour contrast {c_off:.2} without detail, {c_on:.2} with");
    assert!(c_on > 2.0 * c_off + 1.0, "no ground detail up close: {c_on:.2} vs {c_off:.2} without");

    // Far: the eye 1 km above the ground near the south edge, 7.5° down. 50° vertical field:
    // row 120 + 120·tan(θ − 7.5°)/tan 25° at θ below the horizontal; ground 5 km off (11.3°)
    // is at row ≈ 137, 15 km off (3.8°) at row ≈ 103.
    let far = Vec3::new(0.0, 1_100.0, 9_500.0);
    let off = render("headless_detail_far_off.png", GroundDetail::OFF, far, 7.5);
    let on = render("headless_detail_far_on.png", GroundDetail::default(), far, 7.5);
    let band = (105, 135);
    let (f_off, f_on) = (neighbour_contrast(&off, band), neighbour_contrast(&on, band));
    eprintln!("far: neighbour contrast {f_off:.3} without detail, {f_on:.3} with");
    assert!(f_on <= f_off + 0.2, "distant ground aliases: {f_on:.3} vs {f_off:.3} without detail");
}
