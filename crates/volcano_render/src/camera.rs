//! Orbit camera: a camera circling a focus point, driven by the mouse (left drag orbits,
//! right or middle drag pans, the wheel zooms).
//!
//! UI crates tell the camera to ignore the mouse by setting the [`PointerCaptured`] resource
//! (the egui crate does it when egui wants the pointer); this crate does not depend on a UI.

use bevy::camera::{Hdr, PerspectiveProjection, Projection};
use bevy::input::mouse::{AccumulatedMouseMotion, AccumulatedMouseScroll, MouseScrollUnit};
use bevy::post_process::bloom::Bloom;
use bevy::prelude::*;

use crate::sky::{SkySettings, VolcanoSkyCamera, sky_camera_components};

/// Marks the camera the volcano is watched from: the ash billboards face it, [`crate::HeadlessCapturePlugin`]
/// renders it, and the debug panels pick the terrain through it. A game tags its own camera;
/// without one the plume and clouds still simulate, they are just drawn for no viewer.
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct VolcanoViewer;

/// Opt-in HDR with bloom for a camera: adding it brings [`Hdr`] and [`glow_bloom`] (unless the
/// camera already has a `Bloom`), so incandescent lava (and anything brighter than white)
/// glows past its edges instead of clipping. Nothing in the volcano adds it to a game's camera;
/// the headless `volcano render` does to its own and the examples' scenes to theirs. bevy_egui
/// 0.40 draws no panels on an HDR camera: the examples draw them on an overlay camera
/// (`volcano_egui::EguiOverlayCameraPlugin`).
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
#[require(Hdr, Bloom = glow_bloom())]
pub struct GlowCamera;

/// The bloom a [`GlowCamera`] gets: Bevy's energy-conserving `NATURAL` preset, a little
/// stronger.
pub fn glow_bloom() -> Bloom {
    Bloom { intensity: 0.2, ..Bloom::NATURAL }
}

/// Whether a UI owns the pointer this frame; while `true` the orbit camera ignores the mouse.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource, Default, Debug)]
pub struct PointerCaptured(pub bool);

/// A camera orbiting `focus`. Angles in radians, lengths in metres. The system
/// [`apply_orbit`] writes the entity's `Transform` from it; limits are applied there too.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct OrbitCamera {
    /// Point looked at.
    pub focus: Vec3,
    /// Heading of the camera around the focus, radians; 0 puts the camera on the +z side looking
    /// towards −z (north), π/2 on the +x side.
    pub yaw: f32,
    /// Angle above the horizontal plane through the focus, radians (positive looks down).
    pub pitch: f32,
    /// Distance from the focus.
    pub distance: f32,
    /// Closest allowed distance.
    pub min_distance: f32,
    /// Farthest allowed distance.
    pub max_distance: f32,
    /// Lowest allowed pitch.
    pub min_pitch: f32,
    /// Highest allowed pitch.
    pub max_pitch: f32,
    /// Orbit speed, radians per pixel dragged.
    pub orbit_sensitivity: f32,
    /// Zoom factor per wheel line (distance is multiplied by `1 − zoom_sensitivity` per notch).
    pub zoom_sensitivity: f32,
}

impl Default for OrbitCamera {
    /// Looks at the origin from 25 km away, 20° above the horizon, from the south-south-east.
    fn default() -> Self {
        Self {
            focus: Vec3::ZERO,
            yaw: 0.35,
            pitch: 20f32.to_radians(),
            distance: 25_000.0,
            min_distance: 50.0,
            max_distance: 200_000.0,
            min_pitch: -10f32.to_radians(),
            max_pitch: 89f32.to_radians(),
            orbit_sensitivity: 0.005,
            zoom_sensitivity: 0.1,
        }
    }
}

impl OrbitCamera {
    /// An orbit around `focus` at `distance`, with the other fields at their defaults.
    pub fn looking_at(focus: Vec3, distance: f32) -> Self {
        Self { focus, distance, ..default() }
    }

    /// Copy with yaw wrapped to (−π, π] and pitch/distance clamped to the limits (NaN or infinite
    /// yaw and NaN pitch/distance reset to the defaults).
    pub fn clamped(&self) -> Self {
        let mut o = self.clone();
        let d = Self::default();
        if !o.focus.is_finite() {
            o.focus = d.focus;
        }
        o.yaw = if o.yaw.is_finite() { wrap_angle(o.yaw) } else { d.yaw };
        let (lo_p, hi_p) = (o.min_pitch.min(o.max_pitch), o.min_pitch.max(o.max_pitch));
        o.pitch = if o.pitch.is_nan() { d.pitch } else { o.pitch }.clamp(lo_p, hi_p);
        let lo_d = o.min_distance.max(1e-3);
        let hi_d = o.max_distance.max(lo_d);
        o.distance = if o.distance.is_nan() { d.distance } else { o.distance }.clamp(lo_d, hi_d);
        o
    }

    /// Camera position for the current angles and distance (limits applied).
    pub fn eye(&self) -> Vec3 {
        let o = self.clamped();
        let (sy, cy) = o.yaw.sin_cos();
        let (sp, cp) = o.pitch.sin_cos();
        o.focus + o.distance * Vec3::new(cp * sy, sp, cp * cy)
    }

    /// The transform: at [`OrbitCamera::eye`], looking at the focus, y up.
    pub fn transform(&self) -> Transform {
        let o = self.clamped();
        Transform::from_translation(o.eye()).looking_at(o.focus, Vec3::Y)
    }

    /// Applies a mouse drag of `delta` pixels as an orbit (yaw left/right, pitch up/down).
    pub fn orbit(&mut self, delta: Vec2) {
        self.yaw -= delta.x * self.orbit_sensitivity;
        self.pitch += delta.y * self.orbit_sensitivity;
        *self = self.clamped();
    }

    /// Moves the focus (and the camera with it) by a drag of `delta` pixels in a view of
    /// `viewport_height` pixels and vertical field of view `fov` (radians): the ground under the
    /// cursor follows it, on the plane through the focus.
    pub fn pan(&mut self, delta: Vec2, viewport_height: f32, fov: f32) {
        let metres_per_pixel = 2.0 * self.distance * (0.5 * fov).tan() / viewport_height.max(1.0);
        let (sy, cy) = self.yaw.sin_cos();
        // Screen right and screen "up" projected on the horizontal plane.
        let right = Vec3::new(cy, 0.0, -sy);
        let forward = Vec3::new(-sy, 0.0, -cy);
        self.focus += (-delta.x * right + delta.y * forward) * metres_per_pixel;
        *self = self.clamped();
    }

    /// Zooms by `lines` wheel notches (positive zooms in).
    pub fn zoom(&mut self, lines: f32) {
        self.distance *= (1.0 - self.zoom_sensitivity).clamp(0.01, 0.99).powf(lines);
        *self = self.clamped();
    }
}

fn wrap_angle(a: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w <= -PI { w + TAU } else { w }
}

/// Vertical field of view of [`camera_bundle`]'s camera (degrees).
pub const CAMERA_FOV_DEG: f32 = 50.0;

/// Components of a scene camera: [`Camera3d`] with a perspective projection for kilometre
/// scenes, tonemapping and exposure ([`sky_camera_components`]), [`VolcanoViewer`],
/// [`VolcanoSkyCamera`] (so `VolcanoSkyPlugin`, when added, gives it the skybox and fog), a
/// `DepthPrepass` (the clouds stop at the opaque scene and shade it, [`crate::clouds`]) and
/// the orbit with its transform.
pub fn camera_bundle(orbit: OrbitCamera) -> impl Bundle {
    let near = 1.0;
    let projection = Projection::Perspective(PerspectiveProjection {
        fov: CAMERA_FOV_DEG.to_radians(),
        near,
        far: 400_000.0,
        near_clip_plane: Vec4::new(0.0, 0.0, -1.0, -near),
        ..default()
    });
    (
        Name::new("Main camera"),
        Camera3d::default(),
        projection,
        sky_camera_components(SkySettings::default().exposure_ev100),
        VolcanoViewer,
        VolcanoSkyCamera,
        // The instanced ash draw issues direct (not indirect) draws.
        bevy::render::view::NoIndirectDrawing,
        // The cloud march stops at the opaque scene and shades it by the clouds' shadow.
        bevy::core_pipeline::prepass::DepthPrepass,
        orbit.transform(),
        orbit,
    )
}

/// Orbit camera input and placement.
#[derive(Debug, Default, Clone)]
pub struct OrbitCameraPlugin;

impl Plugin for OrbitCameraPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<OrbitCamera>()
            .register_type::<VolcanoViewer>()
            .register_type::<GlowCamera>()
            .register_type::<PointerCaptured>()
            .init_resource::<PointerCaptured>()
            .add_systems(Update, (orbit_input, apply_orbit).chain());
    }
}

/// Mouse controls: left drag orbits, right or middle drag pans, the wheel zooms. Skipped while
/// [`PointerCaptured`] is set, and without an input plugin.
pub fn orbit_input(
    buttons: Option<Res<ButtonInput<MouseButton>>>,
    motion: Option<Res<AccumulatedMouseMotion>>,
    scroll: Option<Res<AccumulatedMouseScroll>>,
    captured: Option<Res<PointerCaptured>>,
    mut cameras: Query<(&mut OrbitCamera, &Camera, &Projection)>,
) {
    if captured.is_some_and(|c| c.0) {
        return;
    }
    let (Some(buttons), Some(motion), Some(scroll)) = (buttons, motion, scroll) else {
        return;
    };
    let delta = motion.delta;
    let lines = match scroll.unit {
        MouseScrollUnit::Line => scroll.delta.y,
        MouseScrollUnit::Pixel => scroll.delta.y / 40.0,
    };
    let orbiting = buttons.pressed(MouseButton::Left);
    let panning = buttons.pressed(MouseButton::Right) || buttons.pressed(MouseButton::Middle);
    if delta == Vec2::ZERO && lines == 0.0 {
        return;
    }
    for (mut orbit, camera, projection) in &mut cameras {
        if orbiting && delta != Vec2::ZERO {
            orbit.orbit(delta);
        } else if panning && delta != Vec2::ZERO {
            let height = camera.logical_viewport_size().map_or(720.0, |s| s.y);
            let fov = match projection {
                Projection::Perspective(p) => p.fov,
                _ => 50f32.to_radians(),
            };
            orbit.pan(delta, height, fov);
        }
        if lines != 0.0 {
            orbit.zoom(lines);
        }
    }
}

/// Writes each [`OrbitCamera`]'s transform when the orbit changes.
pub fn apply_orbit(mut cameras: Query<(&OrbitCamera, &mut Transform), Changed<OrbitCamera>>) {
    for (orbit, mut transform) in &mut cameras {
        *transform = orbit.transform();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eye_and_limits() {
        let o = OrbitCamera { yaw: 0.0, pitch: 0.0, distance: 100.0, ..default() };
        assert!((o.eye() - Vec3::new(0.0, 0.0, 100.0)).length() < 1e-3);
        let mut o = OrbitCamera::default();
        o.zoom(-1000.0);
        assert_eq!(o.distance, o.max_distance);
        o.orbit(Vec2::new(0.0, 1e6));
        assert_eq!(o.pitch, o.max_pitch);
        let nan = OrbitCamera { distance: f32::NAN, yaw: f32::INFINITY, ..default() }.clamped();
        assert!(nan.distance.is_finite() && nan.yaw.is_finite());
        assert!((wrap_angle(3.0 * std::f32::consts::PI) - std::f32::consts::PI).abs() < 1e-5);
    }

    #[test]
    fn mouse_drags_orbit_unless_a_ui_has_the_pointer() {
        let mut app = App::new();
        app.add_plugins(OrbitCameraPlugin)
            .init_resource::<ButtonInput<MouseButton>>()
            .init_resource::<AccumulatedMouseMotion>()
            .init_resource::<AccumulatedMouseScroll>();
        let cam = app.world_mut().spawn((Camera3d::default(), OrbitCamera::default())).id();
        let drag = |app: &mut App| {
            app.world_mut().resource_mut::<ButtonInput<MouseButton>>().press(MouseButton::Left);
            app.world_mut().resource_mut::<AccumulatedMouseMotion>().delta = Vec2::new(40.0, 0.0);
            app.update();
            app.world().get::<OrbitCamera>(cam).unwrap().yaw
        };
        let yaw0 = OrbitCamera::default().yaw;
        app.insert_resource(PointerCaptured(true));
        assert_eq!(drag(&mut app), yaw0, "egui had the pointer");
        app.insert_resource(PointerCaptured(false));
        let yaw1 = drag(&mut app);
        assert!((yaw1 - (yaw0 - 40.0 * 0.005)).abs() < 1e-5, "{yaw1}");
        // The transform follows the orbit.
        let t = app.world().get::<Transform>(cam).unwrap();
        assert!((t.translation - app.world().get::<OrbitCamera>(cam).unwrap().eye()).length() < 1e-2);
    }

    #[test]
    fn pan_moves_focus_under_the_cursor() {
        let mut o = OrbitCamera { yaw: 0.0, pitch: 1.0, distance: 1000.0, ..default() };
        o.pan(Vec2::new(-10.0, 0.0), 500.0, 1.0);
        // Dragging left moves the view right: the focus moves to +x.
        assert!(o.focus.x > 0.0 && o.focus.z.abs() < 1e-3, "{}", o.focus);
        // The camera looks at its focus.
        let t = o.transform();
        let to_focus = (o.focus - t.translation).normalize();
        assert!((t.forward().as_vec3() - to_focus).length() < 1e-4);
    }
}
