//! The instanced ash renderer draws: a wall of parents placed across the top of the view
//! hides the blue sky there, on the left as the GPU-expanded detail-sphere impostors of
//! parents without billboards, on the right as smoke billboards. If the pipeline, the parent
//! buffers, the shader's expansion or its fragment stage were broken, the sky would show.

use crate::common;

use std::sync::Arc;

use bevy::prelude::*;
use volcano_plume::view::parent_key;
use volcano_render::plume::{AshParent, AshParents, PlumeParents, update_parents};
use volcano_render::{OrbitCamera, VolcanoViewer, camera_bundle, headless_default_plugins};
use volcano_test_support::rgb_region_mean;

const W: u32 = 320;
const H: u32 = 240;

/// s2 children of each parent on the left (no s3).
const CHILDREN: u32 = 200;

fn scene(mut commands: Commands) {
    let orbit =
        OrbitCamera { focus: Vec3::new(0.0, 500.0, 0.0), pitch: 0.05, distance: 5_000.0, ..default() };
    commands.spawn(camera_bundle(orbit));
}

/// Replaces the frame's parents (after the plume view packed its empty list).
fn wall(camera: Query<&GlobalTransform, With<VolcanoViewer>>, mut list: ResMut<PlumeParents>) {
    let Some(cam) = camera.iter().next() else { return };
    let (fwd, right, up) = (cam.forward().as_vec3(), cam.right().as_vec3(), cam.up().as_vec3());
    let mut out = AshParents { parents: Vec::new(), starts: vec![0] };
    for iy in 0..14 {
        for ix in -34..34 {
            let (x, y) = (ix as f32 * 40.0, 480.0 + iy as f32 * 40.0);
            let center = cam.translation() + fwd * 2_000.0 + right * x + up * y;
            // Left: 200 impostors of radius 12 on a 60 m sphere; right: one billboard.
            let (flags, count) = if ix < 0 { (0, CHILDREN) } else { (AshParent::BILLBOARD, 1) };
            out.parents.push(AshParent {
                center: center.to_array(),
                radius: 60.0,
                rotation: Quat::IDENTITY.to_array(),
                angle: 0.3,
                // Not 0: ash at vent density glows orange (the vent's incandescence).
                shade: 0.3,
                coverage: 1.0,
                variant: 0.4,
                key: parent_key(7, (iy * 100 + ix + 50) as u64),
                flags,
                billboard_radius: 60.0,
                light: u32::MAX,
            });
            out.starts.push(out.starts.last().copied().unwrap_or(0) + count);
        }
    }
    list.0 = Arc::new(out);
}

#[test]
fn instanced_ash_covers_the_sky() {
    let out = common::out_path("headless_ash.png");
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.add_systems(Startup, scene).add_systems(PostUpdate, wall.after(update_parents));
    let (_, _, rgb) = common::run_and_read(app, &out);
    // Top eighth: covered by ash (left: expanded spheres, right: billboards); grey-brown, not
    // sky blue (the sky there is ≈ (118, 150, 215): blue ≫ red). The ash is lit by the sun,
    // so it is not necessarily dark.
    for (name, xs) in [("detail spheres", (8, W / 2 - 8)), ("billboards", (W / 2 + 8, W - 8))] {
        let m = rgb_region_mean(&rgb, W, xs, (2, H / 8));
        eprintln!("{name}: mean {m:?} ({})", out.display());
        assert!(m[2] < 170.0, "{name}: the sky shows through: {m:?}");
        assert!(m[2] - m[0] < 25.0, "{name}: still bluish: {m:?}");
    }
}
