//! A parent's detail spheres behind its centre are seen through its body: one parent with 300
//! s2 children in front of the camera, the sun behind the camera, so the children facing the
//! eye are sunlit and the ones on the far side are in the parent's own shadow. The children
//! are blended in their enumeration (hash) order, not sorted; unless the parent's body hides
//! the far ones, the shadowed back children are drawn over the lit front ones and the parent's
//! face reads as a dark disc ringed with light (as on the umbrella of the `eruption` scene).
//! The face must be at least as bright as the rim: luminance 202 against 204 when written;
//! with the body's transmittance left out of the alpha, 136 against 201, and this fails.

use crate::common;

use std::sync::Arc;

use bevy::prelude::*;
use volcano_plume::view::ParentLight;
use volcano_plume::view::parent_key;
use volcano_render::plume::layout::pack_light;
use volcano_render::plume::{AshParent, AshParents, PlumeParents, update_parents};
use volcano_render::{VolcanoViewer, headless_default_plugins};
use volcano_test_support::rgb_region_mean;

const W: u32 = 320;
const H: u32 = 240;
/// Parent radius (m), 2 km in front of the camera: ≈ 53 px on screen.
const RADIUS: f32 = 370.0;
const DISTANCE: f32 = 2_000.0;
const CHILDREN: u32 = 300;

/// Points the sun from behind the camera (a little above) and packs the parent.
fn parent(
    camera: Query<&GlobalTransform, With<VolcanoViewer>>,
    mut sun: Query<&mut Transform, With<DirectionalLight>>,
    mut list: ResMut<PlumeParents>,
) {
    let Some(cam) = camera.iter().next() else { return };
    let fwd = cam.forward().as_vec3();
    let toward = (-fwd + 0.25 * Vec3::Y).normalize();
    for mut t in &mut sun {
        *t = Transform::from_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -toward));
    }
    let center = cam.translation() + fwd * DISTANCE;
    let parent = AshParent {
        center: center.to_array(),
        radius: RADIUS,
        rotation: Quat::IDENTITY.to_array(),
        angle: 0.0,
        shade: 0.6,
        coverage: 1.0,
        variant: 0.4,
        key: parent_key(0x5eed, 7),
        flags: AshParent::BILLBOARD,
        billboard_radius: RADIUS * 1.35,
        light: pack_light(ParentLight { sun: 1.0, sky: 1.0, vent: 0.0 }),
    };
    list.0 = Arc::new(AshParents { parents: vec![parent], starts: vec![0, 1 + CHILDREN] });
}

#[test]
fn a_parents_face_is_not_darkened_by_its_back_children() {
    let out = common::out_path("headless_ash_body.png");
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.add_systems(Startup, common::ash_stage).add_systems(PostUpdate, parent.after(update_parents));
    let (_, _, rgb) = common::run_and_read(app, &out);
    let (cx, cy) = (W / 2, H / 2);
    let face = common::luminance(rgb_region_mean(&rgb, W, (cx - 15, cx + 15), (cy - 15, cy + 15)));
    let rim = 0.5
        * (common::luminance(rgb_region_mean(&rgb, W, (cx - 55, cx - 44), (cy - 10, cy + 10)))
            + common::luminance(rgb_region_mean(&rgb, W, (cx + 44, cx + 55), (cy - 10, cy + 10))));
    let sky = common::luminance(rgb_region_mean(&rgb, W, (5, 40), (5, 40)));
    eprintln!("face {face:.1}, rim {rim:.1}, sky {sky:.1} ({})", out.display());
    assert!((face - sky).abs() > 10.0, "nothing drawn: face {face:.1}, sky {sky:.1}");
    assert!(face >= rim - 3.0, "the sunlit face ({face:.1}) is darker than the rim ({rim:.1})");
}
