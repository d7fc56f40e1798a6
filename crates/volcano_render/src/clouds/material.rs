//! The lit cloud pass: [`CloudMaterial`] on a box mesh around an atmosphere's cloud density
//! volume. Its fragment shader (`clouds.wgsl`) ray-marches the 3D density image from the
//! camera, with a short march toward the sun per sample, and darkens the opaque scene behind
//! it by the cloud's shadow (see the shader's header and `docs/ARCHITECTURE.md` §5.6).
//!
//! The box is drawn back faces only and without a depth test, so the pass runs whether the
//! camera is outside or inside it; the march stops at the opaque scene when the camera has a
//! [`DepthPrepass`](bevy::core_pipeline::prepass::DepthPrepass) (scene cameras from
//! [`crate::camera_bundle`] have one; a game's camera only if it adds one), otherwise it runs to
//! the box's exit and the clouds draw over the terrain. The box extends below the density
//! volume down to [`CloudRenderSettings::shadow_floor_m`] so that ground under the lowest layer
//! is covered and receives the shadows. Each box is drawn twice ([`super::split`]): the part
//! of each ray behind the ash sorts before every other transparent item, the part in front of
//! it after them (see [`crate::plume::AshDepthImage`]).

use bevy::asset::Asset;
use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{Material, MaterialPipeline, MaterialPipelineKey};
use bevy::prelude::*;
use bevy::render::render_resource::{
    AsBindGroup, CompareFunction, Face, RenderPipelineDescriptor, ShaderType, SpecializedMeshPipelineError,
};
use bevy::shader::ShaderRef;

use super::CloudRenderSettings;

/// Asset path of the embedded shader.
pub const CLOUD_SHADER: &str = "embedded://volcano_render/clouds/clouds.wgsl";

/// The shader's uniform (mirrors `CloudUniform` in `clouds.wgsl`).
#[derive(ShaderType, Debug, Clone, Copy, PartialEq, Reflect)]
pub struct CloudUniform {
    /// Lowest corner of the density volume (world, m).
    pub volume_min: Vec3,
    /// Extinction per g/m³ of condensed water (1/m).
    pub extinction: f32,
    /// Highest corner of the density volume (world, m).
    pub volume_max: Vec3,
    /// Condensed water (g/m³) at which a texel reaches 1 − 1/e (the image's encoding).
    pub density_scale: f32,
    /// Forward HG g, backward HG g, backward weight, powder strength.
    pub phase: Vec4,
    /// View steps, sun steps, sun march length (m), shadow strength.
    pub march: Vec4,
    /// Sun gain, ambient gain, single-scattering albedo, powder length (m).
    pub light: Vec4,
    /// Colour of the scattered light (linear RGB, multiplies the albedo; w unused): white for
    /// cloud water, a brown grey for the ash fall ([`crate::ash_fall`]).
    pub tint: Vec4,
    /// Lumps from a procedural noise: x strength of the density noise (0 = none, the shader
    /// skips the noise), y 1 / feature size (1/m), z displacement (m), w unused
    /// ([`CloudRenderSettings::detail`]; 0 for the ash fall).
    pub detail: Vec4,
    /// Which part of each view ray this draw marches: [`CloudMaterial::BEHIND_ASH`] (from the
    /// ash, or the eye where there is none, to the scene; drawn before the ash) or
    /// [`CloudMaterial::IN_FRONT_OF_ASH`] (from the eye to the ash; drawn after it). See
    /// [`crate::plume::AshDepthImage`].
    pub segment: u32,
    /// Density samples per view step (1–8; the shader clamps): a cloud thinner than a step
    /// is then not missed by every other pixel (the per-pixel checker of a single jittered
    /// sample); the light is computed once per step.
    pub substeps: u32,
    /// 1 (the default): skip view steps whose stretch of the volume holds no density, read
    /// from the image's maximum levels ([`crate::density_volume::append_max_levels`]); 0: march
    /// every step. The frame is the same either way (`headless_lit_clouds` checks it); 0 is
    /// for that check and for measuring what the skip saves.
    pub skip_empty: u32,
}

impl CloudUniform {
    /// The uniform for a density volume spanning `volume_min..volume_max` under `settings`.
    pub fn new(volume_min: Vec3, volume_max: Vec3, settings: &CloudRenderSettings) -> Self {
        let s = settings;
        Self {
            volume_min,
            extinction: s.extinction_per_gram,
            volume_max,
            density_scale: s.density_scale,
            phase: Vec4::new(s.forward_g, s.backward_g, s.backward_weight, s.powder),
            march: Vec4::new(s.step_count as f32, s.sun_steps as f32, s.sun_distance_m, s.shadow_strength),
            light: Vec4::new(s.sun_gain, s.ambient_gain, s.albedo, s.powder_length_m),
            tint: Vec4::ONE,
            detail: Vec4::new(s.detail, 1.0 / s.detail_m, s.detail_displacement_m, 0.0),
            segment: CloudMaterial::BEHIND_ASH,
            substeps: s.substeps,
            skip_empty: 1,
        }
    }
}

/// The cloud pass's material: the uniform, the 3D density image (`R8Unorm`, u = x,
/// v = altitude, w = z; [`crate::density_volume::density_image`]) and the viewer's ash depth.
#[derive(Asset, AsBindGroup, Debug, Clone, PartialEq, Reflect)]
pub struct CloudMaterial {
    /// Volume, extinction, phase and march settings.
    #[uniform(0)]
    pub uniform: CloudUniform,
    /// The density image.
    #[texture(1, dimension = "3d")]
    #[sampler(2)]
    pub density: Handle<Image>,
    /// The [`crate::plume::AshDepthImage`] (set by [`super::split`]); without it the whole ray
    /// is marched before the ash, as without an ash-depth pass.
    #[texture(3)]
    pub ash_depth: Option<Handle<Image>>,
}

impl CloudMaterial {
    /// [`CloudUniform::segment`] of a draw behind the ash (the whole ray where there is none).
    pub const BEHIND_ASH: u32 = 0;
    /// [`CloudUniform::segment`] of a draw in front of the ash.
    pub const IN_FRONT_OF_ASH: u32 = 1;

    /// A material for `density` over `uniform`'s volume (no ash depth yet).
    pub fn new(uniform: CloudUniform, density: Handle<Image>) -> Self {
        Self { uniform, density, ash_depth: None }
    }
}

impl Material for CloudMaterial {
    fn fragment_shader() -> ShaderRef {
        CLOUD_SHADER.into()
    }

    fn alpha_mode(&self) -> AlphaMode {
        AlphaMode::Premultiplied
    }

    /// Behind the ash: far behind everything else in the back-to-front sort, drawn first; in
    /// front of it: drawn last.
    fn depth_bias(&self) -> f32 {
        if self.uniform.segment == Self::IN_FRONT_OF_ASH { 1.0e9 } else { -1.0e9 }
    }

    fn enable_prepass() -> bool {
        false
    }

    fn enable_shadows() -> bool {
        false
    }

    fn specialize(
        _pipeline: &MaterialPipeline,
        descriptor: &mut RenderPipelineDescriptor,
        _layout: &MeshVertexBufferLayoutRef,
        _key: MaterialPipelineKey<Self>,
    ) -> Result<(), SpecializedMeshPipelineError> {
        // Back faces: the far side of the box covers every pixel the volume can affect, also
        // with the camera inside it. No depth test: the shader stops at the scene's depth.
        descriptor.primitive.cull_mode = Some(Face::Front);
        if let Some(depth) = descriptor.depth_stencil.as_mut() {
            depth.depth_compare = Some(CompareFunction::Always);
            depth.depth_write_enabled = Some(false);
        }
        Ok(())
    }
}

/// Transform of the drawn box (a unit cube mesh): the density volume's `transform` extended
/// down to `floor` (m) when that is lower than its bottom.
pub fn box_transform(transform: &Transform, floor: f32) -> Transform {
    let bottom = transform.translation.y - 0.5 * transform.scale.y;
    let top = transform.translation.y + 0.5 * transform.scale.y;
    let bottom = bottom.min(floor);
    let mut t = *transform;
    t.translation.y = 0.5 * (bottom + top);
    t.scale.y = (top - bottom).max(1.0);
    t
}

/// World corners (lowest, highest) of a unit cube placed by `transform` (no rotation).
pub fn volume_bounds(transform: &Transform) -> (Vec3, Vec3) {
    let half = 0.5 * transform.scale.abs();
    (transform.translation - half, transform.translation + half)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_box_reaches_down_to_the_floor_and_keeps_its_top() {
        let t = crate::density_volume::volume_transform(1000.0, 500.0, 2500.0);
        let b = box_transform(&t, -200.0);
        let (lo, hi) = volume_bounds(&b);
        assert!((lo.y + 200.0).abs() < 1e-3 && (hi.y - 2500.0).abs() < 1e-3, "{lo} {hi}");
        assert!((lo.x + 500.0).abs() < 1e-3 && (hi.z - 500.0).abs() < 1e-3, "{lo} {hi}");
        // A floor above the bottom changes nothing.
        assert_eq!(box_transform(&t, 800.0), t);
        let (lo, hi) = volume_bounds(&t);
        let u = CloudUniform::new(lo, hi, &CloudRenderSettings::default());
        assert_eq!((u.volume_min.y, u.volume_max.y), (500.0, 2500.0));
    }

    #[test]
    fn the_lumps_settings_are_validated_and_reach_the_uniform() {
        let s =
            CloudRenderSettings { detail: 0.3, detail_m: 200.0, detail_displacement_m: 80.0, ..default() };
        s.validate().unwrap();
        let u = CloudUniform::new(Vec3::ZERO, Vec3::ONE, &s);
        assert_eq!(u.detail, Vec4::new(0.3, 1.0 / 200.0, 80.0, 0.0));
        for (bad, name) in [
            (CloudRenderSettings { detail: 1.5, ..default() }, "detail"),
            (CloudRenderSettings { detail_m: 0.0, ..default() }, "detail_m"),
            (CloudRenderSettings { detail_displacement_m: f32::NAN, ..default() }, "detail_displacement_m"),
        ] {
            let e = bad.validate().unwrap_err().to_string();
            assert!(e.contains(name), "{e}");
        }
    }
}
