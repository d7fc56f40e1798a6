//! The vent's incandescence lights the ash (`ash.wgsl`'s `from_vent` term, fed by the third
//! byte of a parent's light word, `volcano_plume::view::vent_light`): one smoke puff in front
//! of the camera under a dim 4,000 lux "moon" (the `eruption_night` scene's), drawn once with
//! no vent light and once as a puff at its vent.
//!
//! The vent light makes both halves of the puff brighter and warm: red gains more than blue
//! (when written: red +43 / +55 of 255 on the upper / lower half, blue +3.7 / +5.5). Tried
//! with the term removed from the shader (`from_vent` = 0): every gain is 0 and this fails.
//!
//! Not checked: that the light is strongest on undersides. With the shader's underside factor
//! (`0.6 + 0.4 * max(-n.y, 0)`) the lower half gains 55 red against the upper half's 43; with
//! the factor set to 1 it still gains more (70 against 64), because the lower half starts
//! darker and the tone curve lifts dark values more, so no threshold between them is robust.

use crate::common;

use std::sync::Arc;

use bevy::prelude::*;
use volcano_plume::view::ParentLight;
use volcano_render::plume::layout::pack_light;
use volcano_render::plume::{AshParents, PlumeParents, update_parents};
use volcano_render::{VolcanoViewer, headless_default_plugins};
use volcano_test_support::rgb_region_mean;

use common::{PUFF_DISTANCE as DISTANCE, PUFF_H as H, PUFF_W as W};

#[derive(Resource, Clone, Copy)]
struct Vent(f32);

/// A dim sun from the camera's right and above; the frame's parents replaced by the puff.
fn puff(
    camera: Query<&GlobalTransform, With<VolcanoViewer>>,
    mut sun: Query<(&mut Transform, &mut DirectionalLight)>,
    vent: Res<Vent>,
    mut list: ResMut<PlumeParents>,
) {
    let Some(cam) = camera.iter().next() else { return };
    let (fwd, right) = (cam.forward().as_vec3(), cam.right().as_vec3());
    let toward = (right + Vec3::Y - 0.3 * fwd).normalize();
    for (mut t, mut light) in &mut sun {
        *t = Transform::from_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -toward));
        light.illuminance = 4_000.0;
    }
    let center = cam.translation() + fwd * DISTANCE;
    let parent = common::puff_parent(center, pack_light(ParentLight { sun: 1.0, sky: 1.0, vent: vent.0 }));
    list.0 = Arc::new(AshParents { parents: vec![parent], starts: vec![0, 1] });
}

/// Renders the puff; returns the mean RGB of its upper and lower halves (inside its disc).
fn render(vent: f32) -> ([f64; 3], [f64; 3]) {
    let out = common::out_path(&format!("headless_ash_vent_{vent}.png"));
    let mut app = common::capture_app(headless_default_plugins(), W, H, &out, 4);
    app.insert_resource(Vent(vent))
        .add_systems(Startup, common::ash_stage)
        .add_systems(PostUpdate, puff.after(update_parents));
    let (_, _, rgb) = common::run_and_read(app, &out);
    let (cx, cy) = (W / 2, H / 2);
    let upper = rgb_region_mean(&rgb, W, (cx - 30, cx + 30), (cy - 45, cy - 10));
    let lower = rgb_region_mean(&rgb, W, (cx - 30, cx + 30), (cy + 10, cy + 45));
    eprintln!("vent {vent}: upper {upper:?}, lower {lower:?} ({})", out.display());
    (upper, lower)
}

#[test]
fn the_vent_lights_the_ash_warm() {
    let (dark_up, dark_low) = render(0.0);
    let (lit_up, lit_low) = render(1.0);
    let gain = |a: [f64; 3], b: [f64; 3]| [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let (up, low) = (gain(dark_up, lit_up), gain(dark_low, lit_low));
    eprintln!("gain upper {up:?}, lower {low:?}");
    for g in [up, low] {
        assert!(g[0] > 10.0, "the vent light barely shows: red gain {:.1}", g[0]);
        assert!(g[0] > g[2] + 5.0, "not warm: red gain {:.1}, blue {:.1}", g[0], g[2]);
    }
}
