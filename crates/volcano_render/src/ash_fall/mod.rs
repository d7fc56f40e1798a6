//! Ash fall (issue 13 item 4, thesis §4.3: ash carried by the layers): each [`Atmosphere`]
//! holding ash gets one dark [`FogVolume`] over its footprint whose 3D density image is the
//! layers' ash concentration ([`volume`]): curtains falling from the umbrella and the column,
//! bent by the layer winds, denser where the field is denser, broken into shafts. Rebuilt when
//! the weather steps (that is when the ash field changes), not every frame; no volume exists
//! while the layers hold no ash, so an atmosphere without an eruption pays nothing.
//!
//! Ash absorbs far more than cloud droplets (single-scattering albedo of volcanic ash ≈ 0.6–0.8
//! in the visible; cloud water ≈ 1): the fog's absorption is high, its colour a brown grey.
//! The texel follows the concentration (`1 − exp(−c / density_scale)`), but the extinction is
//! not physical: fine ash has a mass extinction of ≈ 0.5 m²/g, so 0.05 g/m³ is opaque within
//! 40 m, and Bevy 0.19's fog shader attenuates the light reaching a sample by the whole volume's
//! bounding radius (tens of km), which turns any such fog black. As for the clouds, the peak
//! extinction is chosen from that radius ([`AshFallSettings::light_depth`]); a renderer that
//! marches toward the sun is the look issue's work.
//! The ground tint of the fall deposit is [`crate::terrain::deposit`]'s (the coupling writes the fall
//! into the same `DepositMap` as the pyroclastic flows).

pub mod volume;

use bevy::light::FogVolume;
use bevy::prelude::*;
use volcano_atmosphere::plugin::AtmosphereGround;
use volcano_atmosphere::view::GridSpec;
use volcano_atmosphere::{AirLayer, Atmosphere, LayerFields};
use volcano_core::ConfigError;
use volcano_core::error::in_range;

use crate::fog_volume::{VolcanoFogVolume, bounding_radius, density_factor, density_image, volume_transform};
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
    /// Ash concentration (g/m³) at which a texel reaches 1 − 1/e; concentrations far above it
    /// saturate (they are opaque anyway).
    pub density_scale: f32,
    /// Optical depth of the light path at full density over the volume's bounding radius
    /// (see the module docs): peak extinction = `light_depth / bounding_radius`.
    pub light_depth: f32,
    /// Colour of the ash (sRGB).
    pub colour: Srgba,
    /// Multiplier of the in-scattered sunlight.
    pub light_intensity: f32,
    /// Strength of the fall streaks (0 smooth – 1 shafts and gaps).
    pub streaks: f32,
    /// Size of a streak (m).
    pub streak_m: f32,
    /// Ash (g) below which a layer stack counts as empty (no volume is kept).
    pub min_grams: f64,
}

impl Default for AshFallSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            voxels_xy: 128,
            voxels_z: 64,
            density_scale: 0.02,
            light_depth: 6.0,
            colour: Srgba::rgb(0.33, 0.30, 0.27),
            light_intensity: 6.0,
            streaks: 0.6,
            streak_m: 350.0,
            min_grams: 1.0,
        }
    }
}

impl AshFallSettings {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("voxels_xy", self.voxels_xy as f64, 8.0, 512.0)?;
        in_range("voxels_z", self.voxels_z as f64, 4.0, 256.0)?;
        in_range("density_scale", self.density_scale as f64, 1e-6, 1e3)?;
        in_range("light_depth", self.light_depth as f64, 1e-3, 50.0)?;
        in_range("light_intensity", self.light_intensity as f64, 0.0, 1e4)?;
        in_range("streaks", self.streaks as f64, 0.0, 1.0)?;
        in_range("streak_m", self.streak_m as f64, 1.0, 1e6)?;
        in_range("min_grams", self.min_grams, 0.0, 1e30)?;
        Ok(())
    }

    /// The fog's absorption and scattering fractions (sum 1): ash single-scattering albedo 0.7.
    pub const ABSORPTION_SCATTERING: (f32, f32) = (0.3, 0.7);
}

/// On an [`Atmosphere`] entity: the fog volume drawing its ash and what it was built from.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(Component, Debug)]
pub struct AshFallVolume {
    /// The [`FogVolume`] entity.
    pub fog: Entity,
    /// The 3D density image.
    pub image: Handle<Image>,
    /// Weather time (s) the image was built for.
    pub built_at_s: f64,
    /// Ash in the layers at that time (g).
    pub airborne_g: f64,
    /// Fraction of non-empty texels (diagnostics, tests).
    pub filled_fraction: f32,
}

/// Marks the fog volume entity of an atmosphere's ash.
#[derive(Component, Debug, Clone, Copy, Reflect)]
#[reflect(Component, Debug)]
#[require(VolcanoFogVolume)]
pub struct AshFallFog {
    /// The atmosphere it shows.
    pub atmosphere: Entity,
}

/// Ash-fall fog volumes for every [`Atmosphere`] whose layers hold ash.
#[derive(Debug, Default, Clone)]
pub struct AshFallRenderPlugin;

impl Plugin for AshFallRenderPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<AshFallSettings>()
            .register_type::<AshFallVolume>()
            .register_type::<AshFallFog>()
            .init_resource::<AshFallSettings>()
            .add_systems(PostUpdate, update_ash_volumes);
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

/// Density image, fog transform and filled fraction of an atmosphere's ash.
pub fn build_ash_image(
    layers: &[&LayerFields],
    grid: GridSpec,
    ground: Option<&volcano_core::Grid2<f32>>,
    settings: &AshFallSettings,
) -> Result<(Image, Transform, f32), ConfigError> {
    settings.validate()?;
    let mut spec = AshVolumeSpec::over(layers, settings.voxels_xy as usize, settings.voxels_z as usize);
    spec.streaks = settings.streaks as f64;
    spec.streak_m = settings.streak_m as f64;
    let density = ash_density_volume(layers, grid, ground, &spec)?;
    let image = density_image(&density, spec.nxy, spec.nz, settings.density_scale)?;
    let filled = image
        .data
        .as_ref()
        .map_or(0.0, |d| d.iter().filter(|&&v| v > 0).count() as f32 / d.len().max(1) as f32);
    let transform = volume_transform(grid.extent() as f32, spec.z_min as f32, spec.z_max as f32);
    Ok((image, transform, filled))
}

/// The [`FogVolume`] drawing an ash density image in a volume of this transform.
pub fn ash_fog(image: Handle<Image>, transform: &Transform, settings: &AshFallSettings) -> FogVolume {
    let (absorption, scattering) = AshFallSettings::ABSORPTION_SCATTERING;
    let sigma_max = settings.light_depth / bounding_radius(transform).max(1.0);
    FogVolume {
        fog_color: settings.colour.into(),
        density_factor: density_factor(sigma_max, absorption, scattering).unwrap_or(0.0),
        density_texture: Some(image),
        absorption,
        scattering,
        // Ash scatters forward less than cloud droplets.
        scattering_asymmetry: 0.3,
        light_intensity: settings.light_intensity,
        ..default()
    }
}

#[expect(clippy::too_many_arguments, reason = "one system keeping every atmosphere's ash fog in step")]
fn update_ash_volumes(
    mut commands: Commands,
    settings: Res<AshFallSettings>,
    atmospheres: Query<(Entity, &Atmosphere, Option<&AtmosphereGround>, Option<&AshFallVolume>)>,
    layers: Query<&AirLayer>,
    mut fogs: Query<(&mut FogVolume, &mut Transform, &mut Visibility), With<AshFallFog>>,
    mut images: ResMut<Assets<Image>>,
    mut removed: RemovedComponents<Atmosphere>,
    orphans: Query<(Entity, &AshFallFog)>,
) {
    for gone in removed.read() {
        for (fog, owner) in &orphans {
            if owner.atmosphere == gone {
                commands.entity(fog).despawn();
            }
        }
    }
    for (entity, atmo, ground, volume) in &atmospheres {
        if let Some(v) = volume
            && v.built_at_s == atmo.time_s
            && !settings.is_changed()
        {
            continue;
        }
        let fields = volcano_atmosphere::atmosphere_fields(layers.iter(), entity);
        let grams = airborne_grams(&fields, atmo.dx);
        let show = settings.enabled && grams >= settings.min_grams;
        if let Some(v) = volume
            && let Ok((_, _, mut vis)) = fogs.get_mut(v.fog)
        {
            vis.set_if_neq(if show { Visibility::Inherited } else { Visibility::Hidden });
        }
        if !show {
            continue;
        }
        let built = GridSpec::new(atmo.n, atmo.dx)
            .and_then(|grid| build_ash_image(&fields, grid, ground.map(|g| &g.0.height), &settings));
        let (image, transform, filled) = match built {
            Ok(b) => b,
            Err(e) => {
                warn_once!("ash fall of {entity} not rendered: {e}");
                continue;
            }
        };
        match volume {
            Some(v) => {
                if images.insert(v.image.id(), image).is_err() {
                    warn_once!("ash density image of {entity} could not be replaced");
                }
                if let Ok((mut fog, mut t, _)) = fogs.get_mut(v.fog) {
                    *fog = ash_fog(v.image.clone(), &transform, &settings);
                    *t = transform;
                }
                commands.entity(entity).insert(AshFallVolume {
                    built_at_s: atmo.time_s,
                    airborne_g: grams,
                    filled_fraction: filled,
                    ..v.clone()
                });
            }
            None => {
                let handle = images.add(image);
                let fog = commands
                    .spawn((
                        Name::new("Ash fall"),
                        AshFallFog { atmosphere: entity },
                        ash_fog(handle.clone(), &transform, &settings),
                        transform,
                    ))
                    .id();
                commands.entity(entity).insert(AshFallVolume {
                    fog,
                    image: handle,
                    built_at_s: atmo.time_s,
                    airborne_g: grams,
                    filled_fraction: filled,
                });
            }
        }
    }
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
