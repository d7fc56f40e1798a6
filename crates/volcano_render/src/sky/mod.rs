//! Sun, ambient light and sky, in physical light units (the sun is raw sunlight, 130 klx;
//! cameras use a daylight exposure): [`VolcanoSkyPlugin`], opt-in, for scenes that have no
//! lighting of their own (the examples and the CLI's scenes). A game with its own sun, ambient
//! light, fog or exposure leaves it out; nothing else in the volcano touches them.
//!
//! What the plugin changes, and only while it is added: `GlobalAmbientLight` (from
//! [`SkySettings`]); each [`Sun`] entity's transform and light; cameras tagged
//! [`VolcanoSkyCamera`] get `Exposure`, and a gradient `Skybox` with `DistanceFog` or Bevy's
//! `AtmosphereSettings`. It spawns a default [`Sun`] at startup when no `DirectionalLight` exists
//! ([`SkySettings::spawn_default_sun`]).
//!
//! Two skies, chosen by [`SkySettings::mode`]:
//! - [`SkyMode::Gradient`] (default): a procedural gradient [`bevy::light::Skybox`] with a sun
//!   glow, [`bevy::pbr::DistanceFog`] for aerial perspective, and the sun tinted by a clear-sky
//!   transmittance. Renders everywhere, including llvmpipe.
//! - [`SkyMode::Atmosphere`]: Bevy's physically based [`Atmosphere`] (Hillaire 2020 scattering
//!   LUTs) with its ground at `y = 0` (our altitudes are metres above sea level); sky cameras
//!   get [`AtmosphereSettings`], which makes them HDR (bevy_egui 0.40 panels then do not show on
//!   them). On a software (CPU) adapter this falls back to the gradient: the atmosphere's
//!   compute passes crash Mesa 22.3's lavapipe. Untested on hardware GPUs here.
//!
//! The mode in use is published as [`ActiveSky`].

pub mod gradient;

use bevy::camera::{Exposure, Hdr};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::light::atmosphere::ScatteringMedium;
use bevy::light::light_consts::lux;
use bevy::light::{Atmosphere, CascadeShadowConfig, CascadeShadowConfigBuilder, GlobalAmbientLight, Skybox};
use bevy::pbr::{AtmosphereSettings, DistanceFog};
use bevy::prelude::*;
use bevy::render::renderer::RenderAdapterInfo;

pub use gradient::{GradientSky, clear_sky_transmittance};

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
    /// Afternoon sun from the south-west, 35° high, raw sunlight.
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
    sun_cascades_for(f32::INFINITY)
}

/// Shadow cascades for a camera about `view_distance` metres from what it looks at: the first
/// cascade ends at 4 × that distance (at least 100 m, at most 4 km), so a close-up of a lava
/// patch gets decimetre shadow texels (fold ropes shadow the crust) and a volcano seen from
/// kilometres the same cascades as [`sun_cascades`].
pub fn sun_cascades_for(view_distance: f32) -> CascadeShadowConfig {
    let first = if view_distance.is_nan() { 4_000.0 } else { (4.0 * view_distance).clamp(100.0, 4_000.0) };
    CascadeShadowConfigBuilder {
        num_cascades: 3,
        minimum_distance: (0.1 * first).min(10.0),
        first_cascade_far_bound: first,
        maximum_distance: 80_000.0,
        overlap_proportion: 0.2,
    }
    .build()
}

/// The components of a sun entity: [`Sun`], a shadow-casting [`DirectionalLight`], cascades
/// sized for kilometre scenes and the matching transform.
pub fn sun_bundle(sun: Sun) -> impl Bundle {
    // Depth bias in metres: the default (2 cm) streaks kilometre-scale slopes with acne.
    let light = DirectionalLight {
        illuminance: sun.illuminance,
        shadow_maps_enabled: true,
        shadow_depth_bias: 4.0,
        ..default()
    };
    (Name::new("Sun"), sun.transform(), light, sun_cascades(), sun)
}

/// Which sky to draw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Reflect)]
#[reflect(Debug, Default)]
pub enum SkyMode {
    /// Procedural gradient skybox, distance fog and a tinted sun.
    #[default]
    Gradient,
    /// Bevy's physically based atmosphere (hardware adapters only; see the module docs).
    Atmosphere,
}

/// Sky and ambient light settings; edits apply live.
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Default, Debug)]
pub struct SkySettings {
    /// Requested sky (see [`ActiveSky`] for the one in use).
    pub mode: SkyMode,
    /// Spawn a default [`Sun`] at startup when the scene has no `DirectionalLight`.
    pub spawn_default_sun: bool,
    /// Ambient (sky fill) light colour.
    pub ambient_color: Color,
    /// Ambient brightness (cd/m², physical units like the sun).
    pub ambient_brightness: f32,
    /// Exposure (EV100) of [`VolcanoSkyCamera`]s.
    pub exposure_ev100: f32,
    /// Colours and visibility of the gradient sky.
    pub gradient: GradientSky,
}

impl Default for SkySettings {
    fn default() -> Self {
        Self {
            mode: SkyMode::default(),
            spawn_default_sun: true,
            ambient_color: Color::srgb(0.85, 0.9, 1.0),
            ambient_brightness: 4_000.0,
            exposure_ev100: 13.0,
            gradient: GradientSky::default(),
        }
    }
}

/// The sky actually drawn (the requested one unless unsupported by the adapter).
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource, Default, Debug)]
pub struct ActiveSky(pub SkyMode);

/// Marks the atmosphere entity spawned in [`SkyMode::Atmosphere`].
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct VolcanoSky;

/// Marks a camera [`VolcanoSkyPlugin`] dresses: exposure, and the skybox with distance fog (or
/// the physical atmosphere). `camera_bundle` cameras carry it.
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct VolcanoSkyCamera;

/// Sun placement, ambient light and the sky (opt-in; see the module docs for what it changes).
/// Adding it more than once is harmless (a scene plugin and the game may both add it, in either
/// order): later copies do nothing.
#[derive(Debug, Default, Clone)]
pub struct VolcanoSkyPlugin;

/// Present once [`VolcanoSkyPlugin`] has been built.
#[derive(Resource)]
struct SkyPluginBuilt;

impl Plugin for VolcanoSkyPlugin {
    fn is_unique(&self) -> bool {
        false
    }

    fn build(&self, app: &mut App) {
        if app.world().contains_resource::<SkyPluginBuilt>() {
            return;
        }
        app.insert_resource(SkyPluginBuilt)
            .register_type::<Sun>()
            .register_type::<VolcanoSkyCamera>()
            .register_type::<SkySettings>()
            .register_type::<ActiveSky>()
            .register_type::<VolcanoSky>()
            .init_resource::<SkySettings>()
            .init_resource::<ActiveSky>()
            .add_systems(PostStartup, spawn_default_sun)
            .add_systems(Update, (resolve_sky, apply_sun, update_sky_cameras, apply_ambient).chain());
    }
}

/// Camera components for the sky: ACES tonemapping and a daylight exposure of `exposure_ev100`.
/// The camera stays LDR (no `Hdr`): bevy_egui 0.40 draws nothing on an HDR camera here. The
/// sky-specific parts (gradient skybox and fog, or [`AtmosphereSettings`], which brings `Hdr`)
/// are added to [`VolcanoSkyCamera`]s by [`VolcanoSkyPlugin`].
pub fn sky_camera_components(exposure_ev100: f32) -> impl Bundle {
    (Exposure { ev100: exposure_ev100 }, Tonemapping::AcesFitted)
}

/// Whether the renderer runs on a software rasterizer (llvmpipe and the like).
pub fn is_software_adapter(info: &RenderAdapterInfo) -> bool {
    format!("{:?}", info.device_type) == "Cpu"
}

/// The sky drawn for a requested mode: the atmosphere only on hardware adapters.
pub fn effective_mode(requested: SkyMode, software_adapter: bool) -> SkyMode {
    match requested {
        SkyMode::Atmosphere if software_adapter => SkyMode::Gradient,
        m => m,
    }
}

fn resolve_sky(
    mut commands: Commands,
    settings: Res<SkySettings>,
    adapter: Option<Res<RenderAdapterInfo>>,
    mut active: ResMut<ActiveSky>,
    atmospheres: Query<Entity, With<VolcanoSky>>,
    mut media: ResMut<Assets<ScatteringMedium>>,
) {
    if !settings.is_changed() {
        return;
    }
    let software = adapter.as_deref().is_some_and(is_software_adapter);
    let mode = effective_mode(settings.mode, software);
    if mode != settings.mode {
        warn!("Atmosphere sky disabled on a software adapter (lavapipe crashes); using the gradient sky");
    }
    if mode == SkyMode::Atmosphere && atmospheres.is_empty() {
        let medium = media.add(ScatteringMedium::default());
        commands.spawn((Name::new("Atmosphere"), VolcanoSky, Atmosphere::earth(medium)));
    } else if mode != SkyMode::Atmosphere {
        for e in &atmospheres {
            commands.entity(e).despawn();
        }
    }
    active.set_if_neq(ActiveSky(mode));
}

fn spawn_default_sun(
    mut commands: Commands,
    settings: Res<SkySettings>,
    suns: Query<(), With<Sun>>,
    lights: Query<(), With<DirectionalLight>>,
) {
    if settings.spawn_default_sun && suns.is_empty() && lights.is_empty() {
        commands.spawn(sun_bundle(Sun::default()));
    }
}

fn apply_sun(active: Res<ActiveSky>, mut suns: Query<(Ref<Sun>, &mut Transform, &mut DirectionalLight)>) {
    for (sun, mut transform, mut light) in &mut suns {
        if !(sun.is_changed() || active.is_changed()) {
            continue;
        }
        *transform = sun.transform();
        let e = sun.illuminance.max(0.0);
        if active.0 == SkyMode::Atmosphere {
            // The atmosphere filters the light itself.
            light.illuminance = e;
            light.color = Color::WHITE;
        } else {
            let t = clear_sky_transmittance(sun.elevation_deg);
            let peak = t.max_element().max(1e-6);
            light.illuminance = e * peak;
            light.color = Color::linear_rgb(t.x / peak, t.y / peak, t.z / peak);
        }
    }
}

/// Gradient sky image, regenerated when the sun or the colours change.
#[derive(Default)]
struct SkyImage(Option<Handle<Image>>);

/// Sky cameras that are new or just became HDR (their fog colour depends on it).
type NewSkyCameras<'w, 's> = Query<'w, 's, (), Or<(Added<VolcanoSkyCamera>, Added<Hdr>)>>;
/// Every sky camera, with its exposure and whether it is HDR.
type SkyCameras<'w, 's> =
    Query<'w, 's, (Entity, Option<&'static mut Exposure>, Has<Hdr>), With<VolcanoSkyCamera>>;

#[expect(clippy::too_many_arguments, reason = "one system keeping every camera's sky in step")]
fn update_sky_cameras(
    mut commands: Commands,
    settings: Res<SkySettings>,
    active: Res<ActiveSky>,
    suns: Query<Ref<Sun>>,
    new_cameras: NewSkyCameras,
    mut removed_hdr: RemovedComponents<Hdr>,
    mut cameras: SkyCameras,
    mut images: ResMut<Assets<Image>>,
    mut sky_image: Local<SkyImage>,
) {
    let sun_changed = suns.iter().any(|s| s.is_changed());
    let hdr_removed = removed_hdr.read().count() > 0;
    if !(settings.is_changed()
        || active.is_changed()
        || sun_changed
        || hdr_removed
        || !new_cameras.is_empty())
    {
        return;
    }
    let gradient = active.0 == SkyMode::Gradient;
    let handle = if gradient {
        let sun = suns.iter().next().map_or(Vec3::Y, |s| s.direction());
        let image = settings.gradient.cubemap(sun);
        match &sky_image.0 {
            Some(h) if images.insert(h.id(), image.clone()).is_ok() => Some(h.clone()),
            _ => {
                let h = images.add(image);
                sky_image.0 = Some(h.clone());
                Some(h)
            }
        }
    } else {
        None
    };
    for (entity, exposure, hdr) in &mut cameras {
        let mut e = commands.entity(entity);
        match exposure {
            Some(mut x) if x.ev100 != settings.exposure_ev100 => x.ev100 = settings.exposure_ev100,
            Some(_) => {}
            None => {
                e.insert(Exposure { ev100: settings.exposure_ev100 });
            }
        }
        match &handle {
            Some(h) => {
                e.remove::<AtmosphereSettings>().insert((
                    GradientSky::skybox(h.clone(), settings.exposure_ev100),
                    settings.gradient.fog(hdr),
                ));
            }
            None => {
                e.remove::<(Skybox, DistanceFog)>().insert(AtmosphereSettings {
                    // Aerial perspective over the whole scene (metres).
                    aerial_view_lut_max_distance: 60_000.0,
                    ..default()
                });
            }
        }
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
    fn atmosphere_only_on_hardware() {
        assert_eq!(effective_mode(SkyMode::Atmosphere, true), SkyMode::Gradient);
        assert_eq!(effective_mode(SkyMode::Atmosphere, false), SkyMode::Atmosphere);
        assert_eq!(effective_mode(SkyMode::Gradient, false), SkyMode::Gradient);
    }

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
