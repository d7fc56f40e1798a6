//! Sun, ambient light and sky.
//!
//! The sky is Bevy's physically based [`Atmosphere`] (Hillaire 2020 scattering LUTs): one earth
//! atmosphere entity with its ground at `y = 0` (our altitudes are metres above sea level) and
//! [`AtmosphereSettings`] on the camera (see [`sky_camera_components`]). Lighting is in physical
//! units: the sun is raw sunlight (130 klx) filtered by the atmosphere, the camera exposure is
//! set for daylight.

use bevy::camera::Exposure;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::light::atmosphere::ScatteringMedium;
use bevy::light::light_consts::lux;
use bevy::light::{Atmosphere, CascadeShadowConfig, CascadeShadowConfigBuilder, GlobalAmbientLight};
use bevy::pbr::AtmosphereSettings;
use bevy::prelude::*;

/// The sun: a shadow-casting [`DirectionalLight`] placed from azimuth and elevation. Spawn it
/// with [`sun_bundle`]; edit it live (reflection, panels) and the light follows.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct Sun {
    /// Compass direction of the sun, degrees clockwise from north (north = −z, east = +x).
    pub azimuth_deg: f32,
    /// Height of the sun above the horizon, degrees (negative: below the horizon).
    pub elevation_deg: f32,
    /// Illuminance before atmospheric filtering, lux.
    pub illuminance: f32,
}

impl Default for Sun {
    /// Mid-afternoon sun from the south-west, 35° high, raw sunlight.
    fn default() -> Self {
        Self { azimuth_deg: 225.0, elevation_deg: 35.0, illuminance: lux::RAW_SUNLIGHT }
    }
}

impl Sun {
    /// Unit vector from the ground towards the sun (world, y-up).
    pub fn direction(&self) -> Vec3 {
        let (az, el) = (self.azimuth_deg.to_radians(), self.elevation_deg.to_radians());
        Vec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos()).normalize_or(Vec3::Y)
    }

    /// Transform of the light: its forward (−z) points along the sunlight, away from the sun.
    pub fn transform(&self) -> Transform {
        Transform::from_rotation(Quat::from_rotation_arc(Vec3::NEG_Z, -self.direction()))
    }
}

/// Shadow cascades sized for a volcano seen from tens of kilometres.
pub fn sun_cascades() -> CascadeShadowConfig {
    CascadeShadowConfigBuilder {
        num_cascades: 3,
        minimum_distance: 10.0,
        first_cascade_far_bound: 4_000.0,
        maximum_distance: 80_000.0,
        overlap_proportion: 0.2,
    }
    .build()
}

/// The components of a sun entity: [`Sun`], a shadow-casting [`DirectionalLight`], cascades
/// sized for kilometre scenes and the matching transform.
pub fn sun_bundle(sun: Sun) -> impl Bundle {
    let light = DirectionalLight {
        illuminance: sun.illuminance,
        shadow_maps_enabled: true,
        ..default()
    };
    (Name::new("Sun"), sun.transform(), light, sun_cascades(), sun)
}

/// Sky and ambient light settings.
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Default, Debug)]
pub struct SkySettings {
    /// Spawn a default [`Sun`] at startup when the scene has none.
    pub spawn_default_sun: bool,
    /// Spawn Bevy's earth [`Atmosphere`] at startup (cameras need [`AtmosphereSettings`], which
    /// [`crate::camera_bundle`] adds).
    pub atmosphere: bool,
    /// Ambient (sky fill) light colour.
    pub ambient_color: Color,
    /// Ambient brightness (cd/m², physical units like the sun).
    pub ambient_brightness: f32,
    /// Camera exposure (EV100) used by [`sky_camera_components`].
    pub exposure_ev100: f32,
}

impl Default for SkySettings {
    fn default() -> Self {
        Self {
            spawn_default_sun: true,
            atmosphere: true,
            ambient_color: Color::srgb(0.62, 0.74, 1.0),
            ambient_brightness: 6_000.0,
            exposure_ev100: 13.0,
        }
    }
}

/// Marks the atmosphere entity spawned by [`SkyPlugin`].
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct VolcanoSky;

/// Sun placement, ambient light and the atmosphere.
#[derive(Debug, Default, Clone)]
pub struct SkyPlugin;

impl Plugin for SkyPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<Sun>()
            .register_type::<SkySettings>()
            .register_type::<VolcanoSky>()
            .init_resource::<SkySettings>()
            .add_systems(PostStartup, (spawn_sky, spawn_default_sun))
            .add_systems(Update, (apply_sun, apply_ambient));
    }
}

/// Camera components for the sky: HDR with the atmosphere's LUT settings, ACES tonemapping and
/// a daylight exposure of `exposure_ev100`.
pub fn sky_camera_components(exposure_ev100: f32) -> impl Bundle {
    (
        AtmosphereSettings {
            // Aerial perspective over the whole scene (metres).
            aerial_view_lut_max_distance: 60_000.0,
            ..default()
        },
        Exposure { ev100: exposure_ev100 },
        Tonemapping::AcesFitted,
    )
}

fn spawn_sky(
    mut commands: Commands,
    settings: Res<SkySettings>,
    existing: Query<(), With<Atmosphere>>,
    mut media: ResMut<Assets<ScatteringMedium>>,
) {
    if settings.atmosphere && existing.is_empty() {
        let medium = media.add(ScatteringMedium::default());
        commands.spawn((Name::new("Atmosphere"), VolcanoSky, Atmosphere::earth(medium)));
    }
}

fn spawn_default_sun(mut commands: Commands, settings: Res<SkySettings>, suns: Query<(), With<Sun>>) {
    if settings.spawn_default_sun && suns.is_empty() {
        commands.spawn(sun_bundle(Sun::default()));
    }
}

fn apply_sun(mut suns: Query<(&Sun, &mut Transform, &mut DirectionalLight), Changed<Sun>>) {
    for (sun, mut transform, mut light) in &mut suns {
        *transform = sun.transform();
        light.illuminance = sun.illuminance.max(0.0);
    }
}

fn apply_ambient(settings: Res<SkySettings>, ambient: Option<ResMut<GlobalAmbientLight>>) {
    if let Some(mut ambient) = ambient
        && settings.is_changed()
    {
        ambient.color = settings.ambient_color;
        ambient.brightness = settings.ambient_brightness;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sun_direction_follows_azimuth_and_elevation() {
        let east = Sun { azimuth_deg: 90.0, elevation_deg: 0.0, ..default() }.direction();
        assert!((east - Vec3::X).length() < 1e-5, "{east}");
        let north = Sun { azimuth_deg: 0.0, elevation_deg: 30.0, ..default() }.direction();
        assert!(north.z < 0.0 && (north.y - 0.5).abs() < 1e-5, "{north}");
        let sun = Sun::default();
        // The light shines away from the sun.
        let fwd = sun.transform().forward();
        assert!((fwd.as_vec3() + sun.direction()).length() < 1e-5);
        let zenith = Sun { elevation_deg: 90.0, ..default() };
        assert!((zenith.transform().forward().as_vec3() + Vec3::Y).length() < 1e-5);
    }
}
