//! Ash fall (thesis §4.3: ash carried by the layers): each [`Atmosphere`](volcano_atmosphere::Atmosphere)
//! holding ash gets one box over its footprint drawn by the lit ray-marching pass of the clouds
//! ([`CloudMaterial`], `clouds.wgsl`: a march toward the sun per sample, ambient sky light,
//! the shadow on the ground behind) whose 3D density image is the layers' ash concentration
//! ([`volume`]): curtains falling from the umbrella and the column, bent by the layer winds,
//! denser where the field is denser, broken into shafts. Rebuilt when the weather steps (that
//! is when the ash field changes), not every frame, and off the main thread ([`rebuild`]); no
//! box exists while the layers hold no ash, so an atmosphere without an eruption pays nothing.
//!
//! Ash absorbs far more than cloud droplets: its single-scattering albedo is ≈ 0.6–0.8 in the
//! visible (cloud water ≈ 1), its colour a brown grey (the pass's `tint`), and it scatters
//! forward less. Its mass extinction is ≈ 0.5 m²/g for fine ash, so 0.05 g/m³ would be opaque
//! within 40 m; [`AshFallSettings::extinction_per_gram`] is far lower than that so that the
//! curtain, drawn from voxels of a few hundred metres, shows its shafts and thins at its edges
//! instead of standing as a wall. At 0.005, darker and browner (albedo 0.6, less sky light
//! under the umbrella), the column shows through it; at 0.03 a ray along the `eruption`
//! scene's curtain, through kilometres of ash, is opaque: seen across the wind it hides the
//! column behind it as one pale, smooth, straight-sided wall. The ash is not a Bevy
//! `FogVolume`: that shader attenuates the light reaching a sample by the whole volume's
//! bounding radius (tens of km), so any fog dense enough to see turns black, the curtain a
//! dark box.
//! The ground tint of the fall deposit is [`crate::terrain::deposit`]'s (the coupling writes the fall
//! into the same `DepositMap` as the pyroclastic flows).

pub mod rebuild;
pub mod volume;

use bevy::prelude::*;
use volcano_atmosphere::LayerFields;
use volcano_atmosphere::view::GridSpec;
use volcano_core::ConfigError;
use volcano_core::error::in_range;

use crate::clouds::{CloudMaterial, CloudUniform, volume_bounds};
use crate::density_volume::{density_image, filled_fraction, volume_transform};
pub use rebuild::{AshFallBuild, AshFallBuildStatus, AshSnapshot, BuiltAsh, build_ash};
use volume::{AshVolumeSpec, ash_density_volume};

/// How the layers' ash is drawn (a resource; edits rebuild the volumes).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct AshFallSettings {
    /// Draw the ash fall at all.
    pub enabled: bool,
    /// Voxels per side horizontally (8–512).
    pub voxels_xy: u32,
    /// Voxels vertically (4–256).
    pub voxels_z: u32,
    /// Ash concentration (g/m³) at which a texel reaches 1 − 1/e (the image's encoding; the
    /// pass decodes texels back to g/m³); concentrations far above it saturate.
    pub density_scale: f32,
    /// Extinction (1/m) per g/m³ of ash (physical ≈ 0.5 for fine ash; lower keeps the
    /// curtain's shafts and edges visible at the voxel size, see the module docs).
    pub extinction_per_gram: f32,
    /// Single-scattering albedo of ash (0.6–0.8 in the visible).
    pub albedo: f32,
    /// Colour of the ash (sRGB): the tint of the light it scatters.
    pub colour: Srgba,
    /// Multiplier of the sun's light in the ash (multiple scattering the march misses).
    pub sun_gain: f32,
    /// Multiplier of the view's ambient light as sky light in the ash.
    pub ambient_gain: f32,
    /// Henyey–Greenstein asymmetry of the ash's forward lobe (0–0.99).
    pub forward_g: f32,
    /// Ray-march steps per pixel along the view ray (8–1024).
    pub step_count: u32,
    /// Density samples per view step (1–8; [`crate::CloudRenderSettings::substeps`]).
    pub substeps: u32,
    /// Steps of the march toward the sun per sample (1–32).
    pub sun_steps: u32,
    /// Length (m) of the march toward the sun.
    pub sun_distance_m: f32,
    /// How much of the ground's sunlight a fully shadowing curtain removes (0–1).
    pub shadow_strength: f32,
    /// Strength of the fall streaks (0 smooth – 1 shafts and gaps).
    pub streaks: f32,
    /// Size of a streak (m).
    pub streak_m: f32,
    /// Fraction of the footprint's side over which the ash fades out toward its sides (0–0.5;
    /// [`volume::edge_fade`]).
    pub edge_fraction: f32,
    /// Horizontal blur of the volume's levels (m, half-width; 0–20,000; [`volume::blur_level`]).
    pub blur_m: f32,
    /// How ragged the curtain's top and sides are (0 straight – 1; [`volume::relief_factors`]).
    pub relief: f32,
    /// Size of the raggedness' features (m).
    pub relief_m: f32,
    /// How far (m, 0–20,000) each level of the curtain reads the ash to the side, so its sides
    /// wander with altitude ([`volume::meander_offsets`]); 0 for straight sides.
    pub meander_m: f32,
    /// Ash (g) below which a layer stack counts as empty (no volume is kept).
    pub min_grams: f64,
    /// Rebuild the volume on Bevy's `AsyncComputeTaskPool` ([`rebuild`]); off, it is built on
    /// the main thread in the frame the weather moved (the reference, and for captures that
    /// must show the ash of a given frame).
    pub off_thread: bool,
}

impl Default for AshFallSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            voxels_xy: 128,
            voxels_z: 64,
            density_scale: 0.02,
            extinction_per_gram: 0.005,
            albedo: 0.6,
            colour: Srgba::rgb(0.40, 0.36, 0.31),
            sun_gain: 1.5,
            ambient_gain: 0.7,
            forward_g: 0.5,
            step_count: 128,
            substeps: 8,
            sun_steps: 6,
            sun_distance_m: 4_000.0,
            shadow_strength: 0.5,
            streaks: 1.0,
            streak_m: 2_000.0,
            edge_fraction: 0.12,
            blur_m: 1_200.0,
            relief: 0.8,
            relief_m: 6_000.0,
            meander_m: 800.0,
            min_grams: 1.0,
            off_thread: true,
        }
    }
}

impl AshFallSettings {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("voxels_xy", self.voxels_xy as f64, 8.0, 512.0)?;
        in_range("voxels_z", self.voxels_z as f64, 4.0, 256.0)?;
        in_range("density_scale", self.density_scale as f64, 1e-6, 1e3)?;
        in_range("extinction_per_gram", self.extinction_per_gram as f64, 1e-6, 10.0)?;
        in_range("albedo", self.albedo as f64, 0.0, 1.0)?;
        let c = self.colour;
        for (name, v) in [("colour.red", c.red), ("colour.green", c.green), ("colour.blue", c.blue)] {
            in_range(name, v as f64, 0.0, 1.0)?;
        }
        in_range("sun_gain", self.sun_gain as f64, 0.0, 100.0)?;
        in_range("ambient_gain", self.ambient_gain as f64, 0.0, 100.0)?;
        in_range("forward_g", self.forward_g as f64, 0.0, 0.99)?;
        in_range("step_count", self.step_count as f64, 8.0, 1024.0)?;
        in_range("substeps", self.substeps as f64, 1.0, 8.0)?;
        in_range("sun_steps", self.sun_steps as f64, 1.0, 32.0)?;
        in_range("sun_distance_m", self.sun_distance_m as f64, 10.0, 100_000.0)?;
        in_range("shadow_strength", self.shadow_strength as f64, 0.0, 1.0)?;
        in_range("streaks", self.streaks as f64, 0.0, 1.0)?;
        in_range("streak_m", self.streak_m as f64, 1.0, 1e6)?;
        in_range("edge_fraction", self.edge_fraction as f64, 0.0, 0.5)?;
        in_range("blur_m", self.blur_m as f64, 0.0, 20_000.0)?;
        in_range("relief", self.relief as f64, 0.0, 1.0)?;
        in_range("relief_m", self.relief_m as f64, 1.0, 1e6)?;
        in_range("meander_m", self.meander_m as f64, 0.0, 20_000.0)?;
        in_range("min_grams", self.min_grams, 0.0, 1e30)?;
        Ok(())
    }
}

/// On an [`Atmosphere`](volcano_atmosphere::Atmosphere) entity: the box drawing its ash and what it was built from.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(Component, Debug)]
pub struct AshFallVolume {
    /// The drawn box ([`AshFallDraw`]).
    pub draw: Entity,
    /// The 3D density image: a new handle at every rebuild (see
    /// `density_volume::density_image` for why it is not replaced in place).
    pub image: Handle<Image>,
    /// The box's material.
    pub material: Handle<CloudMaterial>,
    /// Weather time (s) the image was built for.
    pub built_at_s: f64,
    /// Ash in the layers at that time (g).
    pub airborne_g: f64,
    /// Fraction of non-empty texels (diagnostics, tests).
    pub filled_fraction: f32,
}

/// Marks the box entity drawing an atmosphere's ash.
#[derive(Component, Debug, Clone, Copy, Reflect)]
#[reflect(Component, Debug)]
pub struct AshFallDraw {
    /// The atmosphere it shows.
    pub atmosphere: Entity,
}

/// Lit ash-fall volumes for every [`Atmosphere`](volcano_atmosphere::Atmosphere) whose layers hold ash (drawn by the pass of
/// [`crate::CloudRenderPlugin`]; without it nothing is drawn and a warning says so).
#[derive(Debug, Default, Clone)]
pub struct AshFallRenderPlugin;

impl Plugin for AshFallRenderPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<AshFallSettings>()
            .register_type::<AshFallVolume>()
            .register_type::<AshFallDraw>()
            .register_type::<AshFallBuildStatus>()
            .init_resource::<AshFallSettings>()
            .init_resource::<AshFallBuildStatus>()
            .add_systems(
                PostUpdate,
                (rebuild::start_ash_builds, rebuild::apply_ash_builds)
                    .chain()
                    .before(crate::clouds::split::split_cloud_draws),
            );
    }
}

/// Grams of ash in a stack of layers (concentration × free air volume).
pub fn airborne_grams(layers: &[&LayerFields], dx: f64) -> f64 {
    let area = dx * dx;
    layers
        .iter()
        .map(|l| {
            l.ash
                .data()
                .iter()
                .zip(l.sigma.data())
                .map(|(&c, &s)| c.max(0.0) * s as f64 * l.thickness * area)
                .sum::<f64>()
        })
        .sum()
}

/// Density image, volume transform and filled fraction of an atmosphere's ash.
pub fn build_ash_image(
    layers: &[&LayerFields],
    grid: GridSpec,
    ground: Option<&volcano_core::Grid2<f32>>,
    settings: &AshFallSettings,
) -> Result<(Image, Transform, f32), ConfigError> {
    settings.validate()?;
    let (z_min, z_max) = AshVolumeSpec::altitude_range(layers);
    let spec = AshVolumeSpec {
        nxy: settings.voxels_xy as usize,
        nz: settings.voxels_z as usize,
        z_min,
        z_max,
        streaks: settings.streaks as f64,
        streak_m: settings.streak_m as f64,
        seed: 11,
        edge_fraction: settings.edge_fraction as f64,
        blur_m: settings.blur_m as f64,
        relief: settings.relief as f64,
        relief_m: settings.relief_m as f64,
        meander_m: settings.meander_m as f64,
    };
    let density = ash_density_volume(layers, grid, ground, &spec)?;
    let image = density_image(&density, spec.nxy, spec.nz, settings.density_scale)?;
    let filled = filled_fraction(&image);
    let transform = volume_transform(grid.extent() as f32, spec.z_min as f32, spec.z_max as f32);
    Ok((image, transform, filled))
}

/// The lit pass's material for an ash density image in a volume of this transform.
pub fn ash_material(
    image: Handle<Image>,
    transform: &Transform,
    settings: &AshFallSettings,
) -> CloudMaterial {
    let (lo, hi) = volume_bounds(transform);
    let s = settings;
    let colour = LinearRgba::from(s.colour);
    let uniform = CloudUniform {
        volume_min: lo,
        extinction: s.extinction_per_gram,
        volume_max: hi,
        density_scale: s.density_scale,
        // Forward lobe, a weak backward one; no powder (ash is not a droplet cloud).
        phase: Vec4::new(s.forward_g, -0.2, 0.3, 0.0),
        march: Vec4::new(s.step_count as f32, s.sun_steps as f32, s.sun_distance_m, s.shadow_strength),
        light: Vec4::new(s.sun_gain, s.ambient_gain, s.albedo, 60.0),
        tint: Vec4::new(colour.red, colour.green, colour.blue, 0.0),
        // No noise. The pass's lumps (`CloudRenderSettings::detail`), stretched 4× vertically
        // as fall shafts, add next to nothing on the curtain: a view ray crosses kilometres of
        // thin ash and averages many features (mean horizontal luminance step 1.15 with them,
        // 1.13 without, in `headless_ash_fall`'s scene).
        detail: Vec4::ZERO,
        segment: CloudMaterial::BEHIND_ASH,
        substeps: s.substeps,
        skip_empty: 1,
    };
    CloudMaterial::new(uniform, image)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_validate_and_name_the_field() {
        AshFallSettings::default().validate().unwrap();
        let bad = AshFallSettings { streaks: 2.0, ..default() };
        assert!(bad.validate().unwrap_err().to_string().contains("streaks"));
        let bad = AshFallSettings { density_scale: f32::NAN, ..default() };
        assert!(bad.validate().unwrap_err().to_string().contains("density_scale"));
    }

    #[test]
    fn airborne_grams_counts_free_air_only() {
        let grid = GridSpec::new(16, 100.0).unwrap();
        let mut l = LayerFields::new(grid, 500.0, 0.0, 1000.0, 280.0);
        l.ash.data_mut().fill(1.0);
        // Half the cells are half blocked by terrain.
        for k in 0..128 {
            l.sigma.data_mut()[k] = 0.5;
        }
        let g = airborne_grams(&[&l], grid.dx);
        assert!((g - (128.0 + 64.0) * 1000.0 * 1e4).abs() < 1e-3, "{g}");
    }
}
