//! The lava surface draws: a disc of hot lava (no crust) on flat ground, seen from above, must
//! glow orange-red where it lies and leave the bare ground beside it as it is; under a rigid
//! crust in the debug-crust view the same disc must turn blue (thesis Fig 5.11 colours). If
//! the surface mesh, its emissive texture or the material were broken, the ground would show.
//! On a [`GlowCamera`] (HDR with bloom) the glow spills onto the ground next to the disc.
//! The glow light (`LavaRenderSettings::glow_light`) lights the ground beside the disc orange,
//! more near it than further away.

use crate::common;

use bevy::prelude::*;
use volcano_core::Terrain;
use volcano_lava::model::breakout::BreakoutState;
use volcano_lava::{Edges, FlowField, FoldSystem, LavaField, LavaParams, LavaState, Placement, SurfaceState};
use volcano_render::{
    GlowCamera, LavaRenderMode, LavaRenderSettings, OrbitCamera, camera_bundle, headless_default_plugins,
};
use volcano_test_support::rgb_region_mean;

const W: u32 = 320;
const H: u32 = 240;

/// Renders the disc with `crust` (m) in `mode`, through a [`GlowCamera`] if `glow`, with the
/// lava's glow light if `light`; returns the mean RGB over the disc, over bare ground just
/// right of it and over bare ground further right.
fn render(
    name: &str,
    crust: f64,
    mode: LavaRenderMode,
    glow: bool,
    light: bool,
) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let out = common::out_path(name);
    let terrain = Terrain::flat(129, 0.5, 0.0).unwrap();
    let placement = Placement { centre: Vec2::new(-8.0, 0.0), nx: 32, ny: 64, cell: 0.5 };
    let mut flow = FlowField::on_terrain(&terrain, placement, Edges::default()).unwrap();
    flow.place_volume(Vec2::new(-8.0, 0.0), 6.0, 60.0, 1450.0).unwrap();
    let mut surface = SurfaceState::new(32, 64);
    surface.crust.fill(crust);
    let state = LavaState {
        imprint: None,
        flow,
        surface,
        folds: FoldSystem::new(0),
        breakouts: BreakoutState::new(32 * 64),
        last_substeps: 0,
        mobility_capped: false,
        folds_at_cap: false,
    };
    let field = LavaField::new(placement, LavaParams::default()).unwrap();
    // One app after the other in this process: only the first may set the global logger.
    let mut app =
        common::capture_app(headless_default_plugins().disable::<bevy::log::LogPlugin>(), W, H, &out, 4);
    app.insert_resource(mode)
        .insert_resource(LavaRenderSettings { glow_light: light, ..default() })
        .add_systems(Startup, move |mut commands: Commands| {
            commands.spawn(terrain.clone());
            commands.spawn((field.clone(), state.clone()));
            // Straight down from 40 m: screen right = +x, the disc (x = −8 m) left of centre.
            let orbit = OrbitCamera {
                focus: Vec3::ZERO,
                yaw: 0.0,
                pitch: 89f32.to_radians(),
                distance: 40.0,
                min_distance: 1.0,
                ..default()
            };
            let camera = commands.spawn(camera_bundle(orbit)).id();
            if glow {
                commands.entity(camera).insert(GlowCamera);
            }
        });
    let (_, _, rgb) = common::run_and_read(app, &out);
    // ~0.14 m per pixel: the disc spans x ≈ 59..145 px; bare ground at x ≈ 150..158 px (next
    // to it) and 220..260 px.
    let disc = rgb_region_mean(&rgb, W, (85, 120), (105, 135));
    let near = rgb_region_mean(&rgb, W, (150, 158), (105, 135));
    let bare = rgb_region_mean(&rgb, W, (220, 260), (105, 135));
    eprintln!("{name}: disc {disc:?}, next to it {near:?}, bare ground {bare:?} ({})", out.display());
    (disc, near, bare)
}

#[test]
fn hot_lava_glows_and_crust_shows_in_the_debug_view() {
    let (disc, near, bare) = render("headless_lava_lit.png", 0.0, LavaRenderMode::Lit, false, false);
    assert!(disc[0] > bare[0] + 80.0, "hot lava is not brighter than the ground: {disc:?} vs {bare:?}");
    assert!(disc[0] > disc[2] + 80.0, "hot lava is not red-orange: {disc:?}");
    let (glow_disc, glow_near, glow_bare) =
        render("headless_lava_glow.png", 0.0, LavaRenderMode::Lit, true, false);
    assert!(glow_disc[0] > glow_bare[0] + 80.0, "no glow on an HDR camera: {glow_disc:?} vs {glow_bare:?}");
    let spill = (glow_near[0] - glow_bare[0]) - (near[0] - bare[0]);
    assert!(spill > 4.0, "no bloom next to the lava: {glow_near:?} vs {near:?} ({spill:.1})");
    let (disc, _, bare) = render("headless_lava_crust.png", 0.05, LavaRenderMode::DebugCrust, false, false);
    assert!(disc[2] > disc[0] + 60.0 && disc[2] > disc[1] + 40.0, "crust > 2 cm is not blue: {disc:?}");
    assert!(bare[2] < disc[2] - 60.0, "the ground is as blue as the crust: {bare:?}");
}

#[test]
fn glowing_lava_lights_the_ground_beside_it() {
    let (_, dark_near, dark_bare) =
        render("headless_lava_unlit_ground.png", 0.0, LavaRenderMode::Lit, false, false);
    let (_, lit_near, lit_bare) =
        render("headless_lava_lit_ground.png", 0.0, LavaRenderMode::Lit, false, true);
    let gain = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let (near, far) = (gain(lit_near, dark_near), gain(lit_bare, dark_bare));
    eprintln!("glow light: ground next to the lava {near:?}, further away {far:?}");
    // Lit, and orange: red gains most, blue least. By day (this camera's exposure, the sky's
    // ambient on the ground) a 6 m disc's light is small beside the daylight: +2.3 of 255 in
    // red 1–2 m from the disc's edge when written; the same frame without the light is
    // identical (0), so any gain is the light's.
    assert!(near[0] > 1.0, "the ground beside the lava is not lit: {near:?}");
    assert!(near[0] > near[1] && near[1] >= near[2], "not an orange light: {near:?}");
    // Falling off with distance.
    assert!(far[0] < 0.3 * near[0], "no falloff: {near:?} near vs {far:?} further");
}
