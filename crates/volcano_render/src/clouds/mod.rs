//! Volumetric clouds of the layered atmosphere (thesis §4.2.6), lit by a ray-marching pass of
//! our own: each [`Atmosphere`] gets one box mesh with a [`CloudMaterial`] over its footprint
//! whose 3D density image is the crate's cloud density volume
//! (`volcano_atmosphere::view::cloud_density`: Table 4.3 forms, k-means++ coherence,
//! type-keyed noise), rebuilt when the weather steps or a layer is edited, not every frame, on
//! the async compute task pool from a snapshot of the layers (module `rebuild`: same content as
//! a main-thread build, only when it appears varies). The shader marches toward the sun from
//! each sample (Beer–Lambert, multiple-scattering octaves, two-lobe Henyey–Greenstein phase,
//! powder), adds ambient sky light, and shades the opaque scene behind by the clouds' shadow
//! (module [`material`]). It reads the first `DirectionalLight` and the ambient light of the
//! view, so it follows a game's own sun; it adds nothing to cameras or lights.
//! The ash fall ([`crate::ash_fall`]) is drawn by the same pass with its own material. Each box
//! is drawn twice, behind and in front of the ash ([`split`]).

pub mod material;
mod rebuild;
pub mod split;

pub use crate::density_volume::{
    density_image, density_texels, filled_fraction, smooth_density, texel, volume_transform,
};
pub use material::{CloudMaterial, CloudUniform, box_transform, volume_bounds};
pub use rebuild::{BuiltClouds, CloudBuild, CloudBuildStatus, build_clouds};
pub use split::{CloudFrontDraw, CloudFrontOf, split_materials};

use bevy::asset::embedded_asset;
use bevy::prelude::*;
use volcano_atmosphere::view::{AtmosphereState, ClusterMemory, VolumeSpec, cloud_density};
use volcano_atmosphere::{AirLayer, Atmosphere};
use volcano_core::ConfigError;
use volcano_core::error::in_range;

/// How clouds are built and lit (a resource; edits rebuild the volumes and their material).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct CloudRenderSettings {
    /// Draw the clouds.
    pub enabled: bool,
    /// Voxels per side horizontally (8–512).
    pub voxels_xy: u32,
    /// Voxels vertically (4–256).
    pub voxels_z: u32,
    /// Passes of [`smooth_density`] over the volume before it is encoded (0–8): rounds the
    /// blocks that atmosphere cells of several voxels make.
    pub smoothing_passes: u32,
    /// Condensed water (g/m³) at which the texel reaches 1 − 1/e (see [`texel`]); the shader
    /// decodes texels back to g/m³.
    pub density_scale: f32,
    /// Extinction (1/m) per g/m³ of condensed water, ≈ 3 / (2 ρ_w r_eff): 0.15 for 10 µm
    /// droplets, 0.05 for 30 µm. Lower than the physical value softens the edges of the
    /// 100 m voxels.
    pub extinction_per_gram: f32,
    /// Single-scattering albedo (cloud water ≈ 1).
    pub albedo: f32,
    /// Multiplier of the sun's light in the clouds: stands for the multiple scattering that
    /// the shader's three octaves miss (with 1, a thick sunlit cloud is several times darker
    /// than sunlit ground seen from the side; real ones are brighter).
    pub sun_gain: f32,
    /// Multiplier of the view's ambient light as sky light in the clouds.
    pub ambient_gain: f32,
    /// Henyey–Greenstein asymmetry of the forward lobe (silver lining), 0–0.99.
    pub forward_g: f32,
    /// Asymmetry of the backward lobe, −0.99–0.
    pub backward_g: f32,
    /// Weight of the backward lobe (0–1).
    pub backward_weight: f32,
    /// Powder term strength (0 = off, 1 = full): dark thin edges facing away from the sun.
    pub powder: f32,
    /// Path length (m) over which the powder term saturates.
    pub powder_length_m: f32,
    /// Strength of the procedural lumps (0 = the smooth volume and no noise at all, up to
    /// 0.9): the density is multiplied by 1 ± `detail` by a noise of mean 0 and read at a
    /// displaced position ([`Self::detail_displacement_m`]). The density volume's voxels are
    /// ≈ 100 m and smoothed, so without it every cloud is a smooth, rounded blob. A look
    /// setting, not physics (`clouds.wgsl`, `sigma_detailed`).
    pub detail: f32,
    /// Size (m) of the noise's features (the displacement's; the density noise's are 1.9 and
    /// 4.3 times smaller).
    pub detail_m: f32,
    /// How far (m, at most) the noise displaces where the volume is read: the clouds'
    /// outlines bulge out and in by up to this much.
    pub detail_displacement_m: f32,
    /// Ray-march steps per pixel along the view ray (8–1024).
    pub step_count: u32,
    /// Density samples per view step (1–8): the light is computed once per step, the
    /// density at this many jittered points in it, so that a sheet thinner than a step shows
    /// as a sheet rather than as a per-pixel checker (1: a single sample per step). Steps
    /// whose stretch of the volume is empty are skipped whole.
    pub substeps: u32,
    /// Steps of the march toward the sun per sample (1–32).
    pub sun_steps: u32,
    /// Length (m) of the march toward the sun.
    pub sun_distance_m: f32,
    /// How much of the ground's light a fully shadowing cloud removes (0–1; the sun's share).
    pub shadow_strength: f32,
    /// The drawn box reaches down to this altitude (m) when the volume starts higher, so the
    /// ground under the lowest layer receives cloud shadows.
    pub shadow_floor_m: f32,
    /// k-means clusters for the coherence pass (over the cloudy cells of all layers).
    pub clusters: usize,
    /// Fraction of the cloudy cells bordering another form in their layer that triggers k-means.
    pub fragmentation: f64,
    /// Rebuild the volume on Bevy's `AsyncComputeTaskPool` (module `rebuild`); off, it is built
    /// on the main thread in the frame the weather moved (the reference, and for captures that
    /// must show the clouds in a given frame).
    pub off_thread: bool,
}

impl Default for CloudRenderSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            voxels_xy: 256,
            voxels_z: 96,
            smoothing_passes: 2,
            density_scale: 0.15,
            extinction_per_gram: 0.05,
            albedo: 0.98,
            sun_gain: 3.0,
            ambient_gain: 1.0,
            forward_g: 0.7,
            backward_g: -0.2,
            backward_weight: 0.5,
            powder: 0.6,
            powder_length_m: 60.0,
            detail: 0.5,
            detail_m: 450.0,
            detail_displacement_m: 220.0,
            step_count: 192,
            substeps: 8,
            sun_steps: 6,
            sun_distance_m: 3_000.0,
            shadow_strength: 0.6,
            shadow_floor_m: -500.0,
            clusters: 8,
            fragmentation: 0.3,
            off_thread: true,
        }
    }
}

impl CloudRenderSettings {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("voxels_xy", self.voxels_xy as f64, 8.0, 512.0)?;
        in_range("voxels_z", self.voxels_z as f64, 4.0, 256.0)?;
        in_range("smoothing_passes", self.smoothing_passes as f64, 0.0, 8.0)?;
        in_range("density_scale", self.density_scale as f64, 1e-4, 100.0)?;
        in_range("extinction_per_gram", self.extinction_per_gram as f64, 1e-6, 10.0)?;
        in_range("albedo", self.albedo as f64, 0.0, 1.0)?;
        in_range("sun_gain", self.sun_gain as f64, 0.0, 100.0)?;
        in_range("ambient_gain", self.ambient_gain as f64, 0.0, 100.0)?;
        in_range("forward_g", self.forward_g as f64, 0.0, 0.99)?;
        in_range("backward_g", self.backward_g as f64, -0.99, 0.0)?;
        in_range("backward_weight", self.backward_weight as f64, 0.0, 1.0)?;
        in_range("powder", self.powder as f64, 0.0, 1.0)?;
        in_range("powder_length_m", self.powder_length_m as f64, 1.0, 10_000.0)?;
        in_range("detail", self.detail as f64, 0.0, 0.9)?;
        in_range("detail_m", self.detail_m as f64, 10.0, 10_000.0)?;
        in_range("detail_displacement_m", self.detail_displacement_m as f64, 0.0, 5_000.0)?;
        in_range("step_count", self.step_count as f64, 8.0, 1024.0)?;
        in_range("substeps", self.substeps as f64, 1.0, 8.0)?;
        in_range("sun_steps", self.sun_steps as f64, 1.0, 32.0)?;
        in_range("sun_distance_m", self.sun_distance_m as f64, 10.0, 100_000.0)?;
        in_range("shadow_strength", self.shadow_strength as f64, 0.0, 1.0)?;
        in_range("shadow_floor_m", self.shadow_floor_m as f64, -20_000.0, 20_000.0)?;
        in_range("clusters", self.clusters as f64, 1.0, 64.0)?;
        in_range("fragmentation", self.fragmentation, 0.0, 1.0)?;
        Ok(())
    }
}

/// On an [`Atmosphere`] entity: its cloud box entity, density image and material.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(Component, Debug)]
pub struct CloudVolume {
    /// The drawn box ([`CloudDraw`]).
    pub draw: Entity,
    /// The 3D density image: a new handle at every rebuild (see
    /// `density_volume::density_image` for why it is not replaced in place).
    pub image: Handle<Image>,
    /// The box's material.
    pub material: Handle<CloudMaterial>,
    /// Weather time (s) the image was built for.
    pub built_at_s: f64,
    /// Fraction of non-empty texels in the last build (diagnostics, tests).
    pub filled_fraction: f32,
    /// The last k-means clustering of the cloud forms, which the next rebuild starts from
    /// (thesis §4.2.6, temporal coherence).
    pub memory: ClusterMemory,
    /// The settings the image was built with (a change rebuilds it).
    pub settings: CloudRenderSettings,
}

/// Marks the box entity drawing an atmosphere's clouds.
#[derive(Component, Debug, Clone, Copy, Reflect)]
#[reflect(Component, Debug)]
pub struct CloudDraw {
    /// The atmosphere it shows.
    pub atmosphere: Entity,
}

/// Volumetric clouds for every [`Atmosphere`] entity.
#[derive(Debug, Default, Clone)]
pub struct CloudRenderPlugin;

impl Plugin for CloudRenderPlugin {
    fn build(&self, app: &mut App) {
        embedded_asset!(app, "clouds.wgsl");
        crate::add_material::<CloudMaterial>(app);
        app.register_type::<CloudRenderSettings>()
            .register_type::<CloudVolume>()
            .register_type::<CloudDraw>()
            .register_type::<CloudMaterial>()
            .register_type::<CloudBuildStatus>()
            .init_resource::<CloudRenderSettings>()
            .init_resource::<CloudBuildStatus>()
            .register_type::<CloudFrontDraw>()
            .register_type::<CloudFrontOf>()
            .add_systems(
                PostUpdate,
                (rebuild::start_cloud_builds, rebuild::apply_cloud_builds, split::split_cloud_draws)
                    .chain()
                    .before(bevy::transform::TransformSystems::Propagate),
            );
    }
}

/// What a cloud rebuild starts from: the atmosphere's clock and grid, and its layers' fields
/// shared (not copied: [`volcano_atmosphere::SharedFields`]); [`CloudSnapshot::into_state`]
/// copies them, on the rebuild's own thread.
#[derive(Debug, Clone)]
pub struct CloudSnapshot {
    shell: AtmosphereState,
    layers: Vec<std::sync::Arc<volcano_atmosphere::LayerFields>>,
}

impl CloudSnapshot {
    /// The model state the volume functions read (layers only; the ground is not used), and
    /// the shared fields let go of.
    pub fn into_state(self) -> AtmosphereState {
        let layers = self.layers.iter().map(|l| (**l).clone()).collect();
        AtmosphereState { layers, ..self.shell }
    }
}

/// Takes a [`CloudSnapshot`] of `atmo` and its `layers` (any order).
pub fn cloud_state(atmo: &Atmosphere, layers: &[&AirLayer]) -> Result<CloudSnapshot, ConfigError> {
    let mut sorted: Vec<&AirLayer> = layers.to_vec();
    sorted.sort_by_key(|l| l.index);
    Ok(CloudSnapshot {
        shell: atmo.state_shell()?,
        layers: sorted.iter().map(|l| l.fields.share()).collect(),
    })
}

/// The voxel grid over a state's layers: from the lowest layer's bottom to one thickness
/// above the top layer (cumulonimbus towers reach a full thickness above their layer).
pub fn volume_spec(state: &AtmosphereState, settings: &CloudRenderSettings) -> VolumeSpec {
    let z_min = state.layers.first().map_or(0.0, |l| l.bottom.max(0.0));
    let z_max = state.layers.last().map_or(1000.0, |l| l.altitude + l.thickness);
    VolumeSpec {
        nxy: settings.voxels_xy as usize,
        nz: settings.voxels_z as usize,
        z_min,
        z_max: z_max.max(z_min + 1.0),
        seed: 7,
    }
}

/// Density image, fog transform and filled fraction of an atmosphere's clouds; `memory` is the
/// previous rebuild's clustering and becomes this one's.
pub fn build_cloud_image(
    state: &AtmosphereState,
    settings: &CloudRenderSettings,
    cloud_threshold: f64,
    memory: &mut ClusterMemory,
) -> Result<(Image, Transform, f32), ConfigError> {
    settings.validate()?;
    let spec = volume_spec(state, settings);
    let mut density =
        cloud_density(state, cloud_threshold, settings.clusters, settings.fragmentation, memory, &spec);
    smooth_density(&mut density, spec.nxy, spec.nz, settings.smoothing_passes)?;
    let image = density_image(&density, spec.nxy, spec.nz, settings.density_scale)?;
    let filled = filled_fraction(&image);
    let transform = volume_transform(state.grid.extent() as f32, spec.z_min as f32, spec.z_max as f32);
    Ok((image, transform, filled))
}

/// The [`CloudMaterial`] for a density image in a volume of this transform.
pub fn cloud_material(
    image: Handle<Image>,
    transform: &Transform,
    settings: &CloudRenderSettings,
) -> CloudMaterial {
    let (lo, hi) = volume_bounds(transform);
    CloudMaterial::new(CloudUniform::new(lo, hi, settings), image)
}
