//! The lit cloud pass (`volcano_render::clouds::material`), drawn on llvmpipe with hand-made
//! density images (no atmosphere: the pass alone).
//!
//! 1. A round cloud in front of the camera, the sun from the camera's right: its sun side
//!    (right half) must be clearly brighter than its shadow side (left half): luminance 228.5
//!    against 125.4 when written. Without the march toward the sun (tried: `exp(-tau)` and
//!    its octaves replaced by 1 in `clouds.wgsl`) both halves are 238.8 and this fails.
//! 2. A cloud slab over the western half of a flat plane, the sun high in the south, the
//!    camera under the slab looking down at the plane: the ground under the slab (left half of
//!    the frame) must be clearly darker than the open ground (right half): 124.7 against
//!    189.7 when written. With the shadow removed (tried: `shade = 1.0` in `clouds.wgsl`) both
//!    halves are 189.7 and this fails; with an empty density image they match too (the second
//!    render of the test).
//! 3. The same round cloud with the lumps noise (`CloudRenderSettings::detail`) and without:
//!    the outline must turn lumpy (the standard deviation of its radius over 72 directions
//!    more than doubles) and the inside more textured (the mean luminance step between
//!    neighbouring pixels rises by 30 %), at about the same size. With `sigma_detailed`
//!    returning `sigma_at(p)` in `clouds.wgsl` both renders are the same and this fails.
//! 4. A sheet one voxel thick seen at a grazing angle with steps longer than the rays' path
//!    through it: with one density sample per view step neighbouring pixels alternate between
//!    seeing it and missing it (a checker); with eight (`CloudRenderSettings::substeps`) the
//!    mean step between neighbouring pixels must drop below 0.3 of that.
//! 5. A density image replaced in place under its handle (as a game may do) is drawn as a
//!    fresh one: its maximum levels must follow the new image, not keep the first image's.
//! 6. The empty-step skip changes (almost) nothing: faint sparse puffs drawn with it and with
//!    every step marched.

use crate::common;

use bevy::light::{NotShadowCaster, NotShadowReceiver};
use bevy::prelude::*;
use volcano_render::clouds::{CloudMaterial, CloudUniform};
use volcano_render::density_volume::density_image;
use volcano_render::{CloudRenderSettings, OrbitCamera, camera_bundle, headless_default_plugins};
use volcano_test_support::rgb_region_mean;

const W: u32 = 256;
const H: u32 = 192;

#[derive(Resource, Clone)]
struct Setup {
    lo: Vec3,
    hi: Vec3,
    density: Vec<f32>,
    n: usize,
    orbit: OrbitCamera,
    /// Direction toward the sun.
    toward_sun: Vec3,
    plane: bool,
    settings: CloudRenderSettings,
}

/// The box's density image and material (to replace them in place, as a game may).
#[derive(Resource)]
struct BoxHandles {
    image: Handle<Image>,
    material: Handle<CloudMaterial>,
}

/// Inserted: the pass marches every view step (`CloudUniform::skip_empty` = 0).
#[derive(Resource)]
struct MarchEveryStep;

fn scene(
    setup: Res<Setup>,
    no_skip: Option<Res<MarchEveryStep>>,
    mut commands: Commands,
    mut images: ResMut<Assets<Image>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut clouds: ResMut<Assets<CloudMaterial>>,
    mut standard: ResMut<Assets<StandardMaterial>>,
) {
    let s = &*setup;
    let settings = &s.settings;
    let image = density_image(&s.density, s.n, s.n, settings.density_scale).unwrap();
    let mut uniform = CloudUniform::new(s.lo, s.hi, settings);
    if no_skip.is_some() {
        uniform.skip_empty = 0;
    }
    let image = images.add(image);
    let material = clouds.add(CloudMaterial::new(uniform, image.clone()));
    commands.insert_resource(BoxHandles { image, material: material.clone() });
    commands.spawn((
        Mesh3d(meshes.add(Cuboid::new(1.0, 1.0, 1.0))),
        MeshMaterial3d(material),
        Transform::from_translation(0.5 * (s.lo + s.hi)).with_scale(s.hi - s.lo),
        NotShadowCaster,
        NotShadowReceiver,
    ));
    if s.plane {
        commands.spawn((
            Mesh3d(meshes.add(Plane3d::default().mesh().size(40_000.0, 40_000.0))),
            MeshMaterial3d(standard.add(StandardMaterial {
                base_color: Color::srgb(0.5, 0.5, 0.5),
                perceptual_roughness: 1.0,
                ..default()
            })),
            Transform::default(),
        ));
    }
    commands.spawn(camera_bundle(s.orbit.clone()));
    commands.spawn((
        DirectionalLight { illuminance: 100_000.0, shadow_maps_enabled: false, ..default() },
        Transform::from_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -s.toward_sun)),
    ));
}

/// The default settings without the lumps noise (the first two checks are of the lighting
/// of a smooth volume).
fn smooth() -> CloudRenderSettings {
    CloudRenderSettings { detail: 0.0, ..default() }
}

/// Renders the setup; returns the mean RGB of the left and right thirds' inner bands.
fn render(name: &str, setup: Setup) -> ([f64; 3], [f64; 3]) {
    render_after(name, setup, 4)
}

/// [`render`] with the capture asked for after `updates` updates.
fn render_after(name: &str, setup: Setup, updates: u32) -> ([f64; 3], [f64; 3]) {
    let out = common::out_path(name);
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, updates);
    app.insert_resource(setup).add_systems(Startup, scene);
    let (_, _, rgb) = common::run_and_read(app, &out);
    let (cx, cy) = (W / 2, H / 2);
    let left = rgb_region_mean(&rgb, W, (cx - 60, cx - 20), (cy - 20, cy + 20));
    let right = rgb_region_mean(&rgb, W, (cx + 20, cx + 60), (cy - 20, cy + 20));
    eprintln!("{name}: left {left:?}, right {right:?} ({})", out.display());
    (left, right)
}

/// A 1.2 km ball of 0.5 g/m³ with a soft rim (or, `empty`, its volume without cloud), 4 km in
/// front of the camera (≈ 60 px). The camera looks north (−z) from the south; its right is
/// +x. Sun from the right, a little up and a little behind the camera.
fn ball_setup(settings: CloudRenderSettings, empty: bool) -> Setup {
    let (lo, hi) = (Vec3::new(-1_500.0, 500.0, -1_500.0), Vec3::new(1_500.0, 3_500.0, 1_500.0));
    let centre = Vec3::new(0.0, 2_000.0, 0.0);
    let density = common::density_volume(64, lo, hi, |p| {
        let d = 0.5 * (1.0 - ((p - centre).length() - 1_000.0) / 200.0).clamp(0.0, 1.0);
        if empty { 0.0 } else { d }
    });
    let orbit = OrbitCamera { focus: centre, yaw: 0.0, pitch: 0.0, distance: 4_000.0, ..default() };
    let toward_sun = Vec3::new(1.0, 0.3, 0.3).normalize();
    Setup { lo, hi, density, n: 64, orbit, toward_sun, plane: false, settings }
}

#[test]
fn a_cloud_has_a_sun_side_and_a_shadow_side() {
    let (shadow, sun) = render("headless_lit_clouds_ball.png", ball_setup(smooth(), false));
    let (ls, lu) = (common::luminance(shadow), common::luminance(sun));
    assert!(lu > ls + 30.0, "sun side {lu:.1} not clearly brighter than the shadow side {ls:.1}");
}

/// A capture asked for at the first update waits until every render pipeline has compiled, so
/// the frame shows the lit ball of check 1, not a frame drawn while the cloud's shader was
/// still loading: asked for at the third update without that wait, the frame had no cloud.
#[test]
fn a_capture_asked_for_at_once_waits_for_the_shaders() {
    let (shadow, sun) = render_after("headless_lit_clouds_ball_at_once.png", ball_setup(smooth(), false), 1);
    let (ls, lu) = (common::luminance(shadow), common::luminance(sun));
    assert!(lu > ls + 30.0, "sun side {lu:.1}, shadow side {ls:.1}: the cloud is not drawn");
}

/// The ball of [`ball_setup`] rendered: the frame's RGB.
fn ball(name: &str, settings: CloudRenderSettings, empty: bool) -> Vec<u8> {
    let out = common::out_path(name);
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.insert_resource(ball_setup(settings, empty)).add_systems(Startup, scene);
    common::run_and_read(app, &out).2
}

/// (mean luminance step between horizontal neighbours over the ball's box, mean and standard
/// deviation of the outline's radius in pixels over 72 directions from the centre) of a
/// render of the ball; a pixel is cloud where it differs from the `sky` render (the empty
/// volume) by more than 12 in the sum of its channels.
fn ball_texture(name: &str, rgb: &[u8], sky: &[u8]) -> (f64, f64, f64) {
    let at = |x: u32, y: u32| 3 * (y * W + x) as usize;
    let lum = |x: u32, y: u32| {
        let i = at(x, y);
        common::luminance([rgb[i] as f64, rgb[i + 1] as f64, rgb[i + 2] as f64])
    };
    let cloud = |x: u32, y: u32| {
        (0..3).map(|c| (rgb[at(x, y) + c] as i32 - sky[at(x, y) + c] as i32).abs()).sum::<i32>() > 12
    };
    let (cx, cy) = (W / 2, H / 2);
    let (mut step, mut steps) = (0.0, 0usize);
    for y in cy - 80..cy + 80 {
        for x in cx - 80..cx + 79 {
            step += (lum(x + 1, y) - lum(x, y)).abs();
            steps += 1;
        }
    }
    let step = step / steps as f64;
    let radii: Vec<f64> = (0..72)
        .map(|k| {
            let a = (k as f64 * 5.0).to_radians();
            (1..95)
                .map(|r| r as f64)
                .find(|r| !cloud((cx as f64 + r * a.cos()) as u32, (cy as f64 - r * a.sin()) as u32))
                .unwrap_or(95.0)
        })
        .collect();
    let mean = radii.iter().sum::<f64>() / radii.len() as f64;
    let sd = (radii.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / radii.len() as f64).sqrt();
    eprintln!("{name}: mean step {step:.2}, outline radius {mean:.1} ± {sd:.2} px");
    (step, mean, sd)
}

#[test]
fn the_detail_noise_breaks_up_a_smooth_cloud() {
    let sky = ball("headless_lit_clouds_sky.png", default(), true);
    let smooth_rgb = ball("headless_lit_clouds_smooth.png", smooth(), false);
    let detail_rgb = ball("headless_lit_clouds_detail.png", default(), false);
    let (smooth_step, smooth_r, smooth_sd) = ball_texture("smooth", &smooth_rgb, &sky);
    let (detail_step, detail_r, detail_sd) = ball_texture("with the noise", &detail_rgb, &sky);
    assert!(smooth_sd < 3.0, "the smooth ball is not round: outline {smooth_r:.1} ± {smooth_sd:.2} px");
    assert!(
        detail_sd > 2.0 * smooth_sd + 2.0,
        "no lumps on the outline: ± {detail_sd:.2} px with the noise, ± {smooth_sd:.2} without"
    );
    assert!(
        detail_step > 1.3 * smooth_step,
        "no lumps inside: mean step {detail_step:.2} with the noise, {smooth_step:.2} without"
    );
    assert!(
        (detail_r - smooth_r).abs() < 0.25 * smooth_r,
        "the noise should reshape the cloud, not shrink or grow it: {detail_r:.1} against {smooth_r:.1} px"
    );
}

#[test]
fn a_cloud_slab_shades_the_ground_under_it() {
    // Slab 1.5–2.5 km up over x < 0, 0.3 g/m³; the box reaches down to the ground.
    let (lo, hi) = (Vec3::new(-6_000.0, -100.0, -6_000.0), Vec3::new(6_000.0, 3_000.0, 6_000.0));
    let slab = |p: Vec3| if p.x < 0.0 && (1_500.0..2_500.0).contains(&p.y) { 0.3 } else { 0.0 };
    let orbit = OrbitCamera {
        focus: Vec3::new(0.0, 0.0, -1_000.0),
        yaw: 0.0,
        pitch: 40f32.to_radians(),
        distance: 1_200.0,
        ..default()
    };
    // Sun 70° high in the south: the shadow's edge runs along x = 0, shifted only in z.
    let toward_sun = Vec3::new(0.0, 70f32.to_radians().sin(), 70f32.to_radians().cos()).normalize();
    let setup = |density| Setup {
        lo,
        hi,
        density,
        n: 64,
        orbit: orbit.clone(),
        toward_sun,
        plane: true,
        settings: smooth(),
    };
    let (under, open) =
        render("headless_lit_clouds_shadow.png", setup(common::density_volume(64, lo, hi, slab)));
    let (lu, lo_) = (common::luminance(under), common::luminance(open));
    assert!(lu < lo_ - 25.0, "ground under the slab {lu:.1} not clearly darker than open ground {lo_:.1}");
    // Without cloud: both halves alike (the plane and the light are symmetric).
    let (a, b) =
        render("headless_lit_clouds_no_shadow.png", setup(common::density_volume(64, lo, hi, |_| 0.0)));
    let (la, lb) = (common::luminance(a), common::luminance(b));
    assert!((la - lb).abs() < 5.0, "an empty volume shades the ground: {la:.1} vs {lb:.1}");
    assert!((lb - lo_).abs() < 5.0, "the open half changed with the slab: {lb:.1} vs {lo_:.1}");
}

/// (mean luminance step between horizontal neighbours, mean luminance) over the band of the
/// frame where a thin sheet is seen at a grazing angle, with `substeps` density samples per
/// view step. The sheet is 60 m thick (one voxel) at 1.5 km in a 40 km box, the camera 500 m
/// above it looking 5° down; 32 view steps over the ≈ 20 km to the box's far side are ≈ 600 m
/// each, and the rays below the horizon cross the sheet over 250–600 m, in under one step: with
/// one jittered sample per step one pixel sees it and the next one does not.
fn thin_sheet(substeps: u32) -> (f64, f64) {
    let (lo, hi) = (Vec3::new(-20_000.0, 0.0, -20_000.0), Vec3::new(20_000.0, 3_840.0, 20_000.0));
    // Optical depth ≈ 1.3–3 along the rays. No ground under it: the cloud's shadow on
    // the ground has a checker of its own (the 6-step sun march jitters over steps of up to a
    // kilometre), which this test is not about.
    let sheet = |p: Vec3| if (1_470.0..1_530.0).contains(&p.y) { 0.1 } else { 0.0 };
    let orbit = OrbitCamera {
        focus: Vec3::new(0.0, 1_500.0, -6_000.0),
        yaw: 0.0,
        pitch: 5f32.to_radians(),
        distance: 5_700.0,
        ..default()
    };
    let toward_sun = Vec3::new(0.3, 0.8, 0.4).normalize();
    let settings = CloudRenderSettings { substeps, step_count: 32, ..smooth() };
    let density = common::density_volume(64, lo, hi, sheet);
    let setup = Setup { lo, hi, density, n: 64, orbit, toward_sun, plane: false, settings };
    let out = common::out_path(&format!("headless_lit_clouds_sheet_{substeps}.png"));
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.insert_resource(setup).add_systems(Startup, scene);
    let (_, _, rgb) = common::run_and_read(app, &out);
    let lum = |x: u32, y: u32| {
        let i = 3 * (y * W + x) as usize;
        common::luminance([rgb[i] as f64, rgb[i + 1] as f64, rgb[i + 2] as f64])
    };
    // Under the horizon: the sheet seen from above, out to the box's far side.
    let (mut step, mut sum, mut n) = (0.0, 0.0, 0usize);
    for y in H / 2 + 4..H / 2 + 40 {
        for x in 20..W - 21 {
            step += (lum(x + 1, y) - lum(x, y)).abs();
            sum += lum(x, y);
            n += 1;
        }
    }
    let (step, mean) = (step / n as f64, sum / n as f64);
    eprintln!(
        "thin sheet, {substeps} samples per step: mean step {step:.2}, mean {mean:.1} ({})",
        out.display()
    );
    (step, mean)
}

/// A sheet thinner than a view step reads as a sheet, not as a per-pixel checker (the checker
/// one sample per step draws on `skyscape_island`'s near deck): with eight samples per step
/// the mean step between neighbouring pixels is far below the single sample's, and the sheet
/// is still there (brighter than the sky behind it with none).
#[test]
fn a_thin_sheet_seen_grazing_is_not_a_checker() {
    let (one, one_mean) = thin_sheet(1);
    let (eight, eight_mean) = thin_sheet(8);
    // When written: 3.23 with one sample, 0.16 with eight; means 221.7 and 222.9.
    assert!(one > 1.5, "no checker with one sample per step ({one:.2}): the scene tests nothing");
    assert!(eight < 0.3 * one, "still a checker: mean step {eight:.2} with 8 samples, {one:.2} with 1");
    assert!(
        (eight_mean - one_mean).abs() < 40.0,
        "the sheet changed: mean {eight_mean:.1} against {one_mean:.1}"
    );
}

/// How many channel values of two frames differ by more than 2 (of 255).
fn values_differing(a: &[u8], b: &[u8]) -> usize {
    a.iter().zip(b).filter(|(x, y)| x.abs_diff(**y) > 2).count()
}

/// At the third update, the box's density image and material are replaced in place, under
/// their handles, by [`ball_setup`]'s ball, as a game may do. (The cloud and ash-fall rebuilds
/// add a new image each time the weather moves instead.)
fn replace_by_the_ball(
    mut updates: Local<u32>,
    handles: Option<Res<BoxHandles>>,
    mut images: ResMut<Assets<Image>>,
    mut clouds: ResMut<Assets<CloudMaterial>>,
) {
    *updates += 1;
    let Some(h) = handles.filter(|_| *updates == 3) else { return };
    let ball = ball_setup(smooth(), false);
    let image = density_image(&ball.density, ball.n, ball.n, ball.settings.density_scale).unwrap();
    assert!(images.insert(h.image.id(), image).is_ok());
    let uniform = CloudUniform::new(ball.lo, ball.hi, &ball.settings);
    assert!(clouds.insert(h.material.id(), CloudMaterial::new(uniform, h.image.clone())).is_ok());
}

/// A density image replaced in place draws its new cloud: the ball put into an empty box's
/// image after two frames looks as the ball drawn from the start. (Bevy reuses the texture and
/// writes only its finest level: maximum levels that do not follow still say "empty", the
/// pass skips every step, and the frame stays empty: a cloud that forms where the first
/// volume had none is never drawn, as beside the `eruption` column.)
#[test]
fn a_density_image_replaced_in_place_is_drawn_whole() {
    let direct = ball("headless_lit_clouds_ball_direct.png", smooth(), false);
    let empty = ball("headless_lit_clouds_ball_none.png", smooth(), true);
    let out = common::out_path("headless_lit_clouds_ball_replaced.png");
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.insert_resource(ball_setup(smooth(), true))
        .add_systems(Startup, scene)
        .add_systems(Update, replace_by_the_ball);
    let replaced = common::run_and_read(app, &out).2;
    let (ball_values, off) = (values_differing(&direct, &empty), values_differing(&replaced, &direct));
    eprintln!(
        "replaced in place: {off} channel values differ from the ball drawn from the start (it draws {ball_values})"
    );
    assert!(ball_values > 5_000, "the ball hardly shows ({ball_values} values): the test tests nothing");
    assert!(
        off * 100 < ball_values,
        "the replaced image is not drawn as it is: {off} of {ball_values} values differ"
    );
}

/// The frame of a field of faint, sparse puffs (each one voxel of texel value 1–3 out of 255,
/// made visible by a high extinction per gram) in a box `half` (m, half-extents) resting on
/// the ground, seen from `distance` through `steps` view steps, with the occupancy skip or
/// marching every step; `empty`: the same box without the puffs.
fn faint_puffs(half: Vec3, distance: f32, steps: u32, skip: bool, empty: bool) -> Vec<u8> {
    let (lo, hi) = (Vec3::new(-half.x, 0.0, -half.z), Vec3::new(half.x, 2.0 * half.y, half.z));
    let d0 = CloudRenderSettings::default().density_scale;
    // Density (g/m³) whose texel is k/255 (the image's encoding, `density_volume::texel`).
    let faint = |k: f32| -d0 * (1.0 - k / 255.0).ln();
    let voxel = (hi - lo) / 64.0;
    let density = common::density_volume(64, lo, hi, |p| {
        // Voxel indices; a hash picks about one voxel in 300 and its value.
        let v = ((p - lo) / voxel).floor().as_ivec3();
        let h = (v.x.wrapping_mul(73_856_093) ^ v.y.wrapping_mul(19_349_663) ^ v.z.wrapping_mul(83_492_791))
            .rem_euclid(1_000);
        if h < 3 && !empty { faint(1.0 + h as f32) } else { 0.0 }
    });
    let orbit =
        OrbitCamera { focus: Vec3::new(0.0, half.y, 0.0), yaw: 0.4, pitch: 0.3, distance, ..default() };
    let settings = CloudRenderSettings { step_count: steps, extinction_per_gram: 10.0, ..smooth() };
    let toward_sun = Vec3::new(0.3, 0.8, 0.4).normalize();
    let setup = Setup { lo, hi, density, n: 64, orbit, toward_sun, plane: false, settings };
    let out =
        common::out_path(&format!("headless_lit_clouds_faint_puffs_{}_{steps}_{skip}_{empty}.png", half.x));
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.insert_resource(setup).add_systems(Startup, scene);
    if !skip {
        app.insert_resource(MarchEveryStep);
    }
    common::run_and_read(app, &out).2
}

/// The occupancy skip drops only steps that hold no density: the frame of faint, sparse puffs
/// is (nearly) the same with it and without it. (A skip that reads the maximum levels through
/// the linear filter, whose 8-bit result rounds a faint texel's small share to 0, drops faint
/// puffs near the edges of the coarse texels and fails. Blocks and a missing cloud in a frame
/// such as `eruption`'s come mostly from stale levels: see
/// `a_density_image_replaced_in_place_is_drawn_whole`.)
#[test]
fn the_empty_step_skip_drops_no_faint_cloud() {
    for (half, distance, steps) in
        [(Vec3::splat(3_200.0), 9_000.0, 192), (Vec3::new(20_000.0, 2_000.0, 20_000.0), 40_000.0, 128)]
    {
        let with = faint_puffs(half, distance, steps, true, false);
        let without = faint_puffs(half, distance, steps, false, false);
        let none = faint_puffs(half, distance, steps, false, true);
        let (differing, drawn) = (values_differing(&with, &without), values_differing(&without, &none));
        eprintln!(
            "faint puffs {half} {steps}: {drawn} channel values show the puffs, {differing} differ with the skip"
        );
        // When written, with a filtered read of the maximum levels: 641 of 24,459 and 499
        // of 19,442 values differ (2.6 % each). With the unfiltered read of the widened
        // levels: 0 and 57. What the second view still loses (20 pixels in three rows near
        // the box's far top edge, where a sample reads density in a step whose texel is 0;
        // flagged by a temporary shader switch) has no known cause. (A third view, 32 steps
        // over the same box: 42 with the filtered read, 21 with the unfiltered one.)
        assert!(drawn > 5_000, "the puffs hardly show ({drawn} channel values): the scene tests nothing");
        assert!(
            differing * 100 <= drawn,
            "the skip changed {differing} of the {drawn} values the puffs draw"
        );
    }
}

/// Wall time per frame (ms) of updates 10–40 of a `w`×`h` view from inside a 24 km cloud field
/// (the box covers the whole frame; cumulus-sized blobs), with the pass drawn or hidden, its
/// density samples per step and its lumps' strength (`CloudRenderSettings::detail`, 0 = off).
fn frame_ms(drawn: bool, substeps: u32, detail: f32, w: u32, h: u32) -> f64 {
    let (lo, hi) = (Vec3::new(-12_000.0, 0.0, -12_000.0), Vec3::new(12_000.0, 4_000.0, 12_000.0));
    let density = common::density_volume(128, lo, hi, |p| {
        let blob = (p.x / 1_700.0).sin() * (p.z / 1_300.0).cos() - ((p.y - 2_000.0) / 900.0).powi(2);
        0.4 * blob.clamp(0.0, 1.0)
    });
    let orbit = OrbitCamera {
        focus: Vec3::new(0.0, 600.0, 0.0),
        yaw: 0.3,
        pitch: 0.05,
        distance: 9_000.0,
        ..default()
    };
    let toward_sun = Vec3::new(0.5, 0.6, 0.3).normalize();
    let settings = CloudRenderSettings { substeps, detail, ..default() };
    let setup = Setup { lo, hi, density, n: 128, orbit, toward_sun, plane: true, settings };
    let out = common::out_path(&format!("headless_lit_clouds_cost_{drawn}_{substeps}_{detail}_{w}.png"));
    let mut app = common::capture_app(headless_default_plugins(), w, h, &out, 40);
    app.insert_resource(setup).add_systems(Startup, scene).add_systems(
        Update,
        move |mut boxes: Query<&mut Visibility, With<MeshMaterial3d<CloudMaterial>>>| {
            for mut v in &mut boxes {
                v.set_if_neq(if drawn { Visibility::Inherited } else { Visibility::Hidden });
            }
        },
    );
    common::mean_frame_ms(app, &out)
}

/// Not a check (timings vary with the machine): prints what the pass costs on this adapter,
/// and what its per-step density samples and its lumps noise add, at 480×270 (a quarter of
/// the pixels of 960×540, so the five runs take minutes, not an hour, on llvmpipe).
/// `cargo test -p volcano_render --test headless_lit_clouds -- --ignored --nocapture`
#[test]
#[ignore]
fn cloud_pass_frame_cost() {
    let (w, h) = (480, 270);
    let without = frame_ms(false, 8, 0.5, w, h);
    for (substeps, detail) in [(8, 0.5), (1, 0.5), (8, 0.0), (1, 0.0)] {
        let ms = frame_ms(true, substeps, detail, w, h);
        eprintln!(
            "{w}×{h} frame: {ms:.0} ms with the cloud pass ({substeps} samples per step, lumps \
             {detail}), {without:.0} ms without it"
        );
    }
}
