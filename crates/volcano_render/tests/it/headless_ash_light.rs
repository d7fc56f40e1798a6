//! The ash is lit: one smoke puff in front of the camera, the sun from the camera's right.
//!
//! 1. Its sun side (right half) is brighter than its shadow side (left half): luminance 183
//!    against 103 when written. Tried without the per-fragment sun term (`direct` with
//!    `t_sun * 0.5` in place of `t_sun * max(ndl, 0)`): 161 against 156, and this fails.
//! 2. The same puff with a dense cloud of parents between it and the sun (not drawn: only the
//!    puff is packed, its light comes from `light_parents` over all of them) is darker than
//!    without: sun half 92 against 183. Tried with the transmittance ignored in the shader
//!    (`t_sun = 1.0 * …`): 183 both times, and this fails.

use crate::common;

use std::sync::Arc;

use bevy::prelude::*;
use volcano_plume::view::{AshLightSettings, ParentSphere, light_parents};
use volcano_render::plume::layout::pack_light;
use volcano_render::plume::{AshParents, PlumeParents, update_parents};
use volcano_render::{VolcanoViewer, headless_default_plugins};
use volcano_test_support::rgb_region_mean;

use common::{PUFF_DISTANCE as DISTANCE, PUFF_H as H, PUFF_RADIUS as RADIUS, PUFF_W as W};

#[derive(Resource, Clone, Copy)]
struct Occluded(bool);

/// Points the sun from the camera's right and replaces the frame's parents with the puff.
fn puff(
    camera: Query<&GlobalTransform, With<VolcanoViewer>>,
    mut sun: Query<&mut Transform, With<DirectionalLight>>,
    occluded: Res<Occluded>,
    mut list: ResMut<PlumeParents>,
) {
    let Some(cam) = camera.iter().next() else { return };
    let (fwd, right) = (cam.forward().as_vec3(), cam.right().as_vec3());
    // Toward the sun: right, a little up and toward the camera (the lit half faces it).
    let toward = (right + 0.3 * Vec3::Y - 0.3 * fwd).normalize();
    for mut t in &mut sun {
        *t = Transform::from_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -toward));
    }
    let center = cam.translation() + fwd * DISTANCE;
    let sphere = |id: u64, c: Vec3, r: f32| ParentSphere {
        id,
        eruption: 0,
        center: c,
        radius: r,
        rotation: Quat::IDENTITY,
        density: 5.0,
        umbrella: true,
        flow: false,
        cloud: false,
    };
    let mut spheres = vec![sphere(0, center, RADIUS / 1.35)];
    if occluded.0 {
        for i in 0..27u64 {
            let o = Vec3::new((i % 3) as f32, (i / 3 % 3) as f32, (i / 9) as f32) * 120.0 - 120.0;
            spheres.push(sphere(1 + i, center + toward * 1_500.0 + o, 100.0));
        }
    }
    let light = light_parents(&spheres, &AshLightSettings { sun: toward, ..default() });
    let parent = common::puff_parent(center, pack_light(light[0]));
    list.0 = Arc::new(AshParents { parents: vec![parent], starts: vec![0, 1] });
}

/// Renders the puff; returns the mean RGB of its left (shadow) and right (sun) halves.
fn render(occluded: bool) -> ([f64; 3], [f64; 3]) {
    let name = if occluded { "headless_ash_light_occluded.png" } else { "headless_ash_light.png" };
    let out = common::out_path(name);
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.insert_resource(Occluded(occluded))
        .add_systems(Startup, common::ash_stage)
        .add_systems(PostUpdate, puff.after(update_parents));
    let (_, _, rgb) = common::run_and_read(app, &out);
    let (cx, cy) = (W / 2, H / 2);
    let left = rgb_region_mean(&rgb, W, (cx - 55, cx - 15), (cy - 20, cy + 20));
    let right = rgb_region_mean(&rgb, W, (cx + 15, cx + 55), (cy - 20, cy + 20));
    eprintln!("occluded {occluded}: shadow half {left:?}, sun half {right:?} ({})", out.display());
    (left, right)
}

#[test]
fn ash_has_a_sun_side_and_is_shadowed_by_ash_toward_the_sun() {
    let (shadow, sun) = render(false);
    let (ls, lu) = (common::luminance(shadow), common::luminance(sun));
    assert!(lu > ls + 25.0, "sun side {lu:.1} not clearly brighter than shadow side {ls:.1}");
    let (o_shadow, o_sun) = render(true);
    let (os, ou) = (common::luminance(o_shadow), common::luminance(o_sun));
    assert!(ou < lu - 25.0, "behind ash the sun side is {ou:.1}, in the open {lu:.1}");
    assert!(os <= ls + 2.0, "behind ash the shadow side is {os:.1}, in the open {ls:.1}");
}
