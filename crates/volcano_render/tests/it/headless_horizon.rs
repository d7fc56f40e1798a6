//! The far ring draws and follows its input: from 250 m above a 2 km flat terrain, looking north
//! just below the horizon, the band of the frame between the terrain's edge and the horizon
//! shows the sky's below-horizon haze without a [`TerrainHorizon`], land with one, and sea when
//! the ring's base sinks below the sea level. If the ring mesh, its child entity or its colours
//! were missing, the three bands would look alike.

use crate::common;

use bevy::prelude::*;
use volcano_core::Terrain;
use volcano_render::{GlowCamera, OrbitCamera, TerrainHorizon, camera_bundle, headless_default_plugins};
use volcano_test_support::rgb_region_mean;

const W: u32 = 320;
const H: u32 = 240;

/// Renders the flat terrain with `horizon` from `height` metres over its centre, looking north
/// `pitch_deg` down, through an HDR camera with bloom when `glow`; returns the frame's RGB.
fn render(name: &str, horizon: Option<TerrainHorizon>, height: f32, pitch_deg: f32, glow: bool) -> Vec<u8> {
    let out = common::out_path(name);
    // One app after the other in this process: only the first may set the global logger.
    let mut app =
        common::capture_app(headless_default_plugins().disable::<bevy::log::LogPlugin>(), W, H, &out, 4);
    app.add_systems(Startup, move |mut commands: Commands| {
        // 1.92 km square at 100 m; the sea level is 0 m.
        let flat = Terrain::flat(65, 30.0, 100.0).unwrap();
        let flat = Terrain::new(flat.heights().clone(), flat.cover().clone(), 0.0).unwrap();
        let mut terrain = commands.spawn(flat);
        if let Some(h) = horizon.clone() {
            terrain.insert(h);
        }
        let (sin, cos) = pitch_deg.to_radians().sin_cos();
        let orbit = OrbitCamera {
            focus: Vec3::new(0.0, height - 20_000.0 * sin, -20_000.0 * cos),
            yaw: 0.0,
            pitch: pitch_deg.to_radians(),
            distance: 20_000.0,
            ..default()
        };
        let mut camera = commands.spawn(camera_bundle(orbit));
        if glow {
            camera.insert(GlowCamera);
        }
    });
    let (_, _, rgb) = common::run_and_read(app, &out);
    rgb
}

/// The flat terrain with `horizon` from 350 m, looking 1° down; returns the mean RGB of the
/// band 4°–9° below the horizon (ground 1.5–3.6 km beyond the terrain's edge).
fn band(name: &str, horizon: Option<TerrainHorizon>) -> [f64; 3] {
    let rgb = render(name, horizon, 350.0, 1.0, false);
    // 50° vertical field: row 120 + 120·tan(θ − 1°)/tan 25° for θ below the horizontal; the
    // terrain's edge (14°) is at row ≈ 179.
    let band = rgb_region_mean(&rgb, W, (0, W), (137, 152));
    eprintln!("{name}: band {band:?}");
    band
}

fn diff(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|c| (a[c] - b[c]).abs()).sum()
}

#[test]
fn the_far_ring_draws_land_or_sea_beyond_the_edge() {
    let none = band("headless_horizon_none.png", None);
    let land = band(
        "headless_horizon_land.png",
        Some(TerrainHorizon { blend: 1_000.0, hills: 0.0, base_altitude: Some(100.0), ..default() }),
    );
    let sea = band(
        "headless_horizon_sea.png",
        Some(TerrainHorizon { blend: 1_000.0, hills: 0.0, base_altitude: Some(-500.0), ..default() }),
    );
    assert!(diff(land, none) > 30.0, "the ring draws nothing: {land:?} vs the sky's {none:?}");
    assert!(land[0] > land[2], "bare land beyond the edge is not brown: {land:?}");
    assert!(sea[2] > sea[0] + 20.0, "the sunk ring is not sea: {sea:?}");
    assert!(diff(sea, land) > 30.0, "the ring ignores its base altitude: {sea:?} vs {land:?}");
}

/// The far ring's outer edge does not show: from 5 km up, looking level, the fogged far land
/// just inside the ring's edge (95–108 km away, 2.6°–3.0° down) and the sky just beyond it
/// (1.4°–2.1° down) look alike, on an LDR camera and on an HDR one with bloom (whose skybox
/// is tonemapped like the fog; with the LDR fog colour the HDR frame showed a bright band
/// under the horizon, 70 apart in summed RGB in the eruption scene).
#[test]
fn the_far_ring_fades_into_the_sky_on_ldr_and_hdr_cameras() {
    let ring = TerrainHorizon { hills: 0.0, base_altitude: Some(100.0), ..default() };
    for glow in [false, true] {
        let name = if glow { "headless_horizon_seam_hdr.png" } else { "headless_horizon_seam_ldr.png" };
        let rgb = render(name, Some(ring.clone()), 5_000.0, 0.0, glow);
        // Row 120 + 120·tan θ / tan 25° for θ below the horizontal; the ring's outer edge
        // (111 km away, 4.9 km below the camera: 2.53°) is at row ≈ 131.
        let sky = rgb_region_mean(&rgb, W, (0, W), (126, 129));
        let land = rgb_region_mean(&rgb, W, (0, W), (133, 135));
        eprintln!("{name}: sky {sky:?}, far land {land:?}");
        assert!(diff(sky, land) < 15.0, "{name}: a seam at the ring's edge: sky {sky:?}, land {land:?}");
    }
}
