//! The terrain's per-pixel detail ([`GroundDetail`]) draws and follows its setting, keeps
//! detail on grazing views, and does not alias: a flat bare terrain (one vertex colour, one
//! normal) under a low sun, rendered with the default detail and with [`GroundDetail::OFF`].
//!
//! - Close up (camera 60 m above the ground, looking 45° down: about 0.5 m a pixel) the mean
//!   luminance step between neighbouring pixels must be clearly larger with detail than
//!   without. If the detail pass drew nothing or ignored its setting, both frames would match.
//! - Grazing (ground 1–3 km off seen from 150 m up: a pixel covers about 7 m across the view
//!   and 100 m along it) the frame with detail must show far more contrast than the one
//!   without. Fading by the footprint's long side alone leaves only the coarsest octave there
//!   (contrast 1.75, which fails the bound), and the ground in front of every scene camera a
//!   smear.
//! - Far away (ground from 1.6 to 15 km off, seen from 1 km up: metres to tens of metres a pixel
//!   across, up to hundreds along the view) the frame must match the same view rendered at
//!   four times the size and averaged down 4 × 4 (a supersampled frame, the reference for
//!   antialiasing): the mean luminance difference over the ground must stay small. Detail
//!   sampled below its wavelength turns to speckle that the averaged frame does not have, and
//!   detail faded too early (by the long side alone) leaves a smear where
//!   the averaged frame has texture: either moves the frame away from the reference.
use crate::common;

use bevy::prelude::*;
use volcano_core::Terrain;
use volcano_render::{GroundDetail, OrbitCamera, camera_bundle, headless_default_plugins};

const W: u32 = 320;
const H: u32 = 240;

/// Renders a flat bare terrain at 100 m (20.5 km square) from a camera at `eye` looking north
/// `pitch_deg` down, with `detail`, at `W × H` times `scale`; returns the frame's RGB.
fn render(name: &str, detail: GroundDetail, eye: Vec3, pitch_deg: f32, scale: u32) -> Vec<u8> {
    let out = common::out_path(name);
    // One app after the other in this process: only the first may set the global logger.
    let mut app = common::capture_app(
        headless_default_plugins().disable::<bevy::log::LogPlugin>(),
        W * scale,
        H * scale,
        &out,
        4,
    );
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

/// A `W·scale × H·scale` RGB frame averaged down to `W × H` (each pixel the mean of its
/// `scale × scale` block, in encoded values).
fn average_down(rgb: &[u8], scale: u32) -> Vec<u8> {
    let mut out = vec![0u8; (W * H * 3) as usize];
    for y in 0..H {
        for x in 0..W {
            for c in 0..3 {
                let mut sum = 0u32;
                for dy in 0..scale {
                    for dx in 0..scale {
                        sum += rgb[(((y * scale + dy) * W * scale + x * scale + dx) * 3 + c) as usize] as u32;
                    }
                }
                out[((y * W + x) * 3 + c) as usize] = (sum as f64 / (scale * scale) as f64).round() as u8;
            }
        }
    }
    out
}

/// Luminance (0–255, Rec. 709 weights on the encoded values) of pixel `(x, y)` of a `W × H`
/// RGB frame.
fn lum(rgb: &[u8], x: u32, y: u32) -> f64 {
    let i = ((y * W + x) * 3) as usize;
    common::luminance([rgb[i] as f64, rgb[i + 1] as f64, rgb[i + 2] as f64])
}

/// Mean |luminance difference| between two `W × H` frames over rows `y0..y1`.
fn mean_luminance_difference(a: &[u8], b: &[u8], (y0, y1): (u32, u32)) -> f64 {
    let n = ((y1 - y0) * W) as f64;
    (y0..y1)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .map(|(x, y)| (lum(a, x, y) - lum(b, x, y)).abs())
        .sum::<f64>()
        / n
}

/// Mean |luminance difference| between each pixel and its right and lower neighbours, over
/// rows `y0..y1` of a `W × H` frame.
fn neighbour_contrast(rgb: &[u8], (y0, y1): (u32, u32)) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for y in y0..y1 - 1 {
        for x in 0..W - 1 {
            let l = lum(rgb, x, y);
            sum += (lum(rgb, x + 1, y) - l).abs() + (lum(rgb, x, y + 1) - l).abs();
            n += 2.0;
        }
    }
    sum / n
}

#[test]
fn detail_shows_up_close_and_on_grazing_views_and_does_not_alias_far_away() {
    // Close: the eye 60 m above the ground, 45° down; the whole frame is ground.
    let close = Vec3::new(0.0, 160.0, 0.0);
    let off = render("headless_detail_close_off.png", GroundDetail::OFF, close, 45.0, 1);
    let on = render("headless_detail_close_on.png", GroundDetail::default(), close, 45.0, 1);
    let (c_off, c_on) = (neighbour_contrast(&off, (0, H)), neighbour_contrast(&on, (0, H)));
    eprintln!("close: neighbour contrast {c_off:.2} without detail, {c_on:.2} with");
    assert!(c_on > 2.0 * c_off + 1.0, "no ground detail up close: {c_on:.2} vs {c_off:.2} without");

    // Grazing: the eye 150 m above the ground near the south edge, 4° down. 50° vertical
    // field: row 120 + 120·tan(θ − 4°)/tan 25° at θ below the horizontal; ground 1 km off
    // (8.5°) is at row ≈ 140, 3 km off (2.9°) at row ≈ 115.
    let grazing = Vec3::new(0.0, 250.0, 9_500.0);
    let off = render("headless_detail_grazing_off.png", GroundDetail::OFF, grazing, 4.0, 1);
    let on = render("headless_detail_grazing_on.png", GroundDetail::default(), grazing, 4.0, 1);
    let band = (115, 140);
    let (g_off, g_on) = (neighbour_contrast(&off, band), neighbour_contrast(&on, band));
    eprintln!("grazing: neighbour contrast {g_off:.3} without detail, {g_on:.3} with");
    // 5.48 against 0.40 without detail; 1.75 when the octaves faded by the long side alone.
    assert!(g_on > g_off + 3.0, "no ground detail on a grazing view: {g_on:.3} vs {g_off:.3} without");

    // Far: the eye 1 km above the ground near the south edge, 7.5° down: ground 15 km off
    // (3.8°) is at row ≈ 103, 5 km off (11.3°) at row ≈ 137, 1.6 km off at the bottom row.
    let far = Vec3::new(0.0, 1_100.0, 9_500.0);
    let on = render("headless_detail_far_on.png", GroundDetail::default(), far, 7.5, 1);
    let big = render("headless_detail_far_on_x4.png", GroundDetail::default(), far, 7.5, 4);
    let reference = average_down(&big, 4);
    let miss = mean_luminance_difference(&on, &reference, (105, H));
    eprintln!("far: mean luminance difference from the frame rendered 4x and averaged down {miss:.3}");
    // 2.86; 4.96 when the octaves faded by the long side alone, 5.20 when they never fade.
    assert!(miss < 4.0, "distant ground does not match a supersampled frame: {miss:.3} of 255");
}
