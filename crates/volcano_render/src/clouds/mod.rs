//! Volumetric clouds of the layered atmosphere (thesis §4.2.6) with Bevy's volumetric fog:
//! each [`Atmosphere`] gets one [`FogVolume`] over its footprint whose 3D density image is the
//! crate's cloud density volume (`volcano_atmosphere::view::cloud_density`: Table 4.3 forms,
//! k-means++ coherence, type-keyed noise), rebuilt when the weather steps or a layer is
//! edited, not every frame, on the async compute task pool from a snapshot of the layers
//! (module `rebuild`: same content as a main-thread build, only when it appears varies). [`VolcanoViewer`] cameras get [`VolumetricFog`] and [`Sun`]s
//! [`VolumetricLight`] while a cloud volume exists, so scenes without an atmosphere pay nothing
//! (a game lighting the clouds with its own `DirectionalLight` adds `VolumetricLight` to it).
//!
//! Bevy's fog shader attenuates the sunlight reaching a sample by
//! `exp(−density · bounding_radius · extinction)` with the volume's bounding radius (tens of
//! kilometres here), so the peak extinction is chosen from that radius
//! ([`CloudRenderSettings::light_depth`]): dense cores stay grey, edges bright.

mod rebuild;

pub use crate::fog_volume::{
    bounding_radius, density_factor, density_image, density_texels, texel, volume_transform,
};
pub use rebuild::{BuiltClouds, CloudBuild, CloudBuildStatus, build_clouds};

use bevy::light::{FogVolume, VolumetricFog, VolumetricLight};
use bevy::prelude::*;
use volcano_atmosphere::view::{AtmosphereState, ClusterMemory, VolumeSpec, cloud_density};
use volcano_atmosphere::{AirLayer, Atmosphere};
use volcano_core::ConfigError;
use volcano_core::error::in_range;

use crate::camera::VolcanoViewer;
use crate::sky::Sun;

/// How clouds are turned into fog (a resource; edits rebuild the volumes).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct CloudRenderSettings {
    /// Draw the clouds.
    pub enabled: bool,
    /// Voxels per side horizontally (8–512).
    pub voxels_xy: u32,
    /// Voxels vertically (4–256).
    pub voxels_z: u32,
    /// Condensed water (g/m³) at which the texel reaches 1 − 1/e (see [`texel`]).
    pub density_scale: f32,
    /// Optical depth of the light path at full density over the bounding radius (see the
    /// module docs): peak extinction = `light_depth / bounding_radius`.
    pub light_depth: f32,
    /// Multiplier of the in-scattered sunlight (compensates the shader's light attenuation).
    pub light_intensity: f32,
    /// Henyey–Greenstein asymmetry (clouds scatter forward, but a strong lobe hides them when
    /// the sun is behind the camera).
    pub scattering_asymmetry: f32,
    /// Ray-march steps per pixel.
    pub step_count: u32,
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
            density_scale: 0.15,
            light_depth: 6.0,
            light_intensity: 18.0,
            scattering_asymmetry: 0.5,
            step_count: 192,
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
        in_range("density_scale", self.density_scale as f64, 1e-4, 100.0)?;
        in_range("light_depth", self.light_depth as f64, 1e-3, 50.0)?;
        in_range("light_intensity", self.light_intensity as f64, 0.0, 1e4)?;
        in_range("scattering_asymmetry", self.scattering_asymmetry as f64, -0.99, 0.99)?;
        in_range("step_count", self.step_count as f64, 8.0, 1024.0)?;
        in_range("clusters", self.clusters as f64, 1.0, 64.0)?;
        in_range("fragmentation", self.fragmentation, 0.0, 1.0)?;
        Ok(())
    }
}

/// On an [`Atmosphere`] entity: its fog volume entity and density image.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(Component, Debug)]
pub struct CloudVolume {
    /// The [`FogVolume`] entity.
    pub fog: Entity,
    /// The 3D density image.
    pub image: Handle<Image>,
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

/// Marks the fog volume entity of an atmosphere's clouds.
#[derive(Component, Debug, Clone, Copy, Reflect)]
#[reflect(Component, Debug)]
#[require(crate::fog_volume::VolcanoFogVolume)]
pub struct CloudFog {
    /// The atmosphere it shows.
    pub atmosphere: Entity,
}

/// Volumetric clouds for every [`Atmosphere`] entity.
#[derive(Debug, Default, Clone)]
pub struct CloudRenderPlugin;

impl Plugin for CloudRenderPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<CloudRenderSettings>()
            .register_type::<CloudVolume>()
            .register_type::<CloudFog>()
            .register_type::<crate::fog_volume::VolcanoFogVolume>()
            .register_type::<CloudBuildStatus>()
            .init_resource::<CloudRenderSettings>()
            .init_resource::<CloudBuildStatus>()
            .add_systems(
                PostUpdate,
                (rebuild::start_cloud_builds, rebuild::apply_cloud_builds, volumetric_views).chain(),
            );
    }
}

/// Builds the model state the volume functions read (layers only; the ground is not used).
pub fn cloud_state(atmo: &Atmosphere, layers: &[&AirLayer]) -> Result<AtmosphereState, ConfigError> {
    let mut sorted: Vec<&AirLayer> = layers.to_vec();
    sorted.sort_by_key(|l| l.index);
    Ok(AtmosphereState { layers: sorted.iter().map(|l| l.fields.clone()).collect(), ..atmo.state_shell()? })
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
    let density =
        cloud_density(state, cloud_threshold, settings.clusters, settings.fragmentation, memory, &spec);
    let image = density_image(&density, spec.nxy, spec.nz, settings.density_scale)?;
    let filled = image
        .data
        .as_ref()
        .map_or(0.0, |d| d.iter().filter(|&&v| v > 0).count() as f32 / d.len().max(1) as f32);
    let transform = volume_transform(state.grid.extent() as f32, spec.z_min as f32, spec.z_max as f32);
    Ok((image, transform, filled))
}

/// The [`FogVolume`] for a density image in a volume of this transform.
pub fn cloud_fog(image: Handle<Image>, transform: &Transform, settings: &CloudRenderSettings) -> FogVolume {
    let (absorption, scattering) = (0.05, 0.95);
    let sigma_max = settings.light_depth / bounding_radius(transform).max(1.0);
    FogVolume {
        fog_color: Color::WHITE,
        density_factor: density_factor(sigma_max, absorption, scattering).unwrap_or(0.0),
        density_texture: Some(image),
        absorption,
        scattering,
        scattering_asymmetry: settings.scattering_asymmetry,
        light_intensity: settings.light_intensity,
        ..default()
    }
}

/// Fog volumes that need the cameras' volumetric fog: clouds and ash fall.
type FogVolumes = With<crate::fog_volume::VolcanoFogVolume>;

/// Adds [`VolumetricFog`] to [`VolcanoViewer`] cameras and [`VolumetricLight`] to suns while cloud
/// or ash-fall volumes exist, and removes them when none is left.
fn volumetric_views(
    mut commands: Commands,
    settings: Res<CloudRenderSettings>,
    fogs: Query<(), FogVolumes>,
    cameras: Query<(Entity, Option<&VolumetricFog>), With<VolcanoViewer>>,
    suns: Query<(Entity, Has<VolumetricLight>), With<Sun>>,
) {
    let want = settings.enabled && !fogs.is_empty();
    for (camera, fog) in &cameras {
        match (want, fog) {
            (true, Some(f)) if f.step_count == settings.step_count => {}
            (true, _) => {
                commands.entity(camera).insert(VolumetricFog {
                    ambient_intensity: 0.0,
                    step_count: settings.step_count,
                    // Metres: breaks the banding of thin layers into fine noise.
                    jitter: 300.0,
                    ..default()
                });
            }
            (false, Some(_)) => {
                commands.entity(camera).remove::<VolumetricFog>();
            }
            (false, None) => {}
        }
    }
    for (sun, has) in &suns {
        if want && !has {
            commands.entity(sun).insert(VolumetricLight);
        } else if !want && has {
            commands.entity(sun).remove::<VolumetricLight>();
        }
    }
}
