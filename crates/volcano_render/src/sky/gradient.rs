//! The gradient sky: a small procedural cubemap (zenith → horizon → ground haze, with a glow
//! around the sun) shown as a [`Skybox`], plus matching [`DistanceFog`] for aerial perspective
//! and a clear-sky transmittance that tints the sun. Cheap, and renders on software adapters.

use bevy::asset::RenderAssetUsages;
use bevy::color::{ColorToComponents, LinearRgba};
use bevy::image::Image;
use bevy::light::Skybox;
use bevy::pbr::{DistanceFog, FogFalloff};
use bevy::prelude::*;
use bevy::render::render_resource::{
    Extent3d, TextureDimension, TextureFormat, TextureViewDescriptor, TextureViewDimension,
};

/// Display brightness of a sky texel of 1.0 (after exposure), shared by the skybox and the fog.
pub const SKY_GAIN: f32 = 1.2;

/// Gains on the horizon colour for the fog colour of an LDR camera (see [`GradientSky::fog`]).
/// An HDR camera needs none: its skybox goes through the same tonemapping pass as the fog.
pub const FOG_MATCH: Vec3 = Vec3::new(1.20, 1.55, 2.7);

/// Texels per side of each cubemap face.
pub const FACE_SIZE: u32 = 64;

/// Colours of the gradient sky, in display-linear units (1.0 = white after exposure).
#[derive(Debug, Clone, PartialEq, Reflect)]
#[reflect(Debug, Default)]
pub struct GradientSky {
    /// Colour straight up.
    pub zenith: LinearRgba,
    /// Colour at the horizon (also the fog colour).
    pub horizon: LinearRgba,
    /// Colour below the horizon (distant land seen through haze, beyond the terrain and its
    /// far ring).
    pub ground: LinearRgba,
    /// Visibility for the distance fog (m): distance at which contrast drops to 5 %. The fog
    /// thickens with the square of the distance (clear nearby, dense towards the horizon).
    pub visibility: f32,
}

impl Default for GradientSky {
    fn default() -> Self {
        Self {
            zenith: LinearRgba::rgb(0.07, 0.19, 0.58),
            horizon: LinearRgba::rgb(0.46, 0.61, 0.86),
            // Haze over distant land: between the horizon colour and a grey-green.
            ground: LinearRgba::rgb(0.30, 0.37, 0.42),
            // Fog 1 − exp(−(1.73 d / V)²): a volcano 25 km away is seen through ≈ 21 % haze,
            // land 60 km away is ≈ 74 % hidden, 100 km ≈ 97 % (a `TerrainHorizon` ring fades
            // into the sky).
            visibility: 90_000.0,
        }
    }
}

impl GradientSky {
    /// Sky colour seen along the unit world direction `dir` with the sun towards `sun`.
    pub fn radiance(&self, dir: Vec3, sun: Vec3) -> Vec3 {
        let h = self.horizon.to_vec3();
        let y = dir.y;
        let base = if y >= 0.0 {
            h.lerp(self.zenith.to_vec3(), y.clamp(0.0, 1.0).powf(0.35))
        } else {
            let t = (-y / 0.25).clamp(0.0, 1.0);
            h.lerp(self.ground.to_vec3(), t * t * (3.0 - 2.0 * t))
        };
        let c = dir.dot(sun).max(0.0);
        let warm = Vec3::new(1.0, 0.86, 0.66);
        let glow = warm * (0.9 * c.powi(400) + 0.35 * c.powi(48) + 0.12 * c.powi(6));
        // Brighter haze near the horizon on the sun side.
        let haze = warm * 0.08 * c.powi(2) * (1.0 - y.abs()).clamp(0.0, 1.0);
        base + glow + haze
    }

    /// The cubemap image (six `FACE_SIZE²` sRGB faces in wgpu order +x −x +y −y +z −z).
    pub fn cubemap(&self, sun: Vec3) -> Image {
        let n = FACE_SIZE;
        let mut data = Vec::with_capacity((6 * n * n * 4) as usize);
        for face in 0..6 {
            for y in 0..n {
                for x in 0..n {
                    let u = 2.0 * (x as f32 + 0.5) / n as f32 - 1.0;
                    let v = 2.0 * (y as f32 + 0.5) / n as f32 - 1.0;
                    let d = face_direction(face, u, v);
                    // Bevy's skybox looks the cubemap up with z flipped.
                    let world = Vec3::new(d.x, d.y, -d.z).normalize();
                    let c = self.radiance(world, sun);
                    let srgb = Color::from(LinearRgba::rgb(c.x, c.y, c.z)).to_srgba();
                    data.extend(
                        [srgb.red, srgb.green, srgb.blue]
                            .map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
                            .into_iter()
                            .chain([255]),
                    );
                }
            }
        }
        let size = Extent3d { width: n, height: n, depth_or_array_layers: 6 };
        let mut image = Image::new(
            size,
            TextureDimension::D2,
            data,
            TextureFormat::Rgba8UnormSrgb,
            RenderAssetUsages::RENDER_WORLD,
        );
        image.texture_view_descriptor =
            Some(TextureViewDescriptor { dimension: Some(TextureViewDimension::Cube), ..default() });
        image
    }

    /// Skybox showing `image` so that a texel of 1.0 is displayed as [`SKY_GAIN`] at exposure
    /// `ev100`.
    pub fn skybox(image: Handle<Image>, ev100: f32) -> Skybox {
        Skybox { image: Some(image), brightness: SKY_GAIN * ev100.exp2(), rotation: Quat::IDENTITY }
    }

    /// Distance fog fading terrain into the horizon colour (squared exponential, so the near
    /// field stays clear and the far land meets the sky), with sun-side in-scattering, for a
    /// camera with (`hdr`) or without `Hdr`.
    pub fn fog(&self, hdr: bool) -> DistanceFog {
        let visibility = if self.visibility.is_finite() { self.visibility.max(100.0) } else { 90_000.0 };
        DistanceFog {
            // On an LDR camera the fog is mixed into the lit colour before the shader's
            // tonemapping, whose shoulder dims and desaturates it, while the skybox's horizon
            // is not tonemapped: per-channel gains measured so that fully fogged land meets
            // the default horizon on screen (llvmpipe, ACES fitted, EV100 13: fog at 1.0×
            // shows (162, 178, 197) against a sky of (177, 201, 233); the gains are set
            // with `tests/headless_horizon.rs`, where the far ring's edge shows (183, 203, 234)
            // against a sky of (179, 203, 236)). On an HDR camera both go through the
            // tonemapping pass and meet at 1.0× ((160, 175, 193) against (159, 175, 194); the
            // LDR gains there show (180, 200, 232), a bright band under the horizon).
            color: Color::from(LinearRgba::from_vec3(
                self.horizon.to_vec3() * if hdr { Vec3::ONE } else { FOG_MATCH },
            )),
            directional_light_color: Color::linear_rgba(1.0, 0.9, 0.7, 0.04),
            directional_light_exponent: 12.0,
            falloff: FogFalloff::from_visibility_squared(visibility),
        }
    }
}

/// Direction of cubemap texel `(u, v)` ∈ [−1, 1]² (v down) on `face` (Vulkan convention).
fn face_direction(face: u32, u: f32, v: f32) -> Vec3 {
    match face {
        0 => Vec3::new(1.0, -v, -u),
        1 => Vec3::new(-1.0, -v, u),
        2 => Vec3::new(u, 1.0, v),
        3 => Vec3::new(u, -1.0, -v),
        4 => Vec3::new(u, -v, 1.0),
        _ => Vec3::new(-u, -v, -1.0),
    }
}

/// Clear-sky transmittance of sunlight at `elevation_deg` (per RGB channel): Rayleigh optical
/// depths 0.042/0.098/0.245 at 680/550/440 nm plus 0.1 of aerosol, over the Kasten–Young air
/// mass. About (0.78, 0.71, 0.55) at 35°; zero below the horizon.
pub fn clear_sky_transmittance(elevation_deg: f32) -> Vec3 {
    if elevation_deg <= -0.5 {
        return Vec3::ZERO;
    }
    let e = elevation_deg.max(0.0);
    let air_mass = 1.0 / (e.to_radians().sin() + 0.50572 * (e + 6.07995).powf(-1.6364));
    let tau = Vec3::new(0.042, 0.098, 0.245) + Vec3::splat(0.1);
    Vec3::new((-tau.x * air_mass).exp(), (-tau.y * air_mass).exp(), (-tau.z * air_mass).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_cover_the_axes() {
        assert_eq!(face_direction(0, 0.0, 0.0), Vec3::X);
        assert_eq!(face_direction(2, 0.0, 0.0), Vec3::Y);
        assert_eq!(face_direction(5, 0.0, 0.0), Vec3::NEG_Z);
        let img = GradientSky::default().cubemap(Vec3::Y);
        assert_eq!(img.texture_descriptor.size.depth_or_array_layers, 6);
        assert_eq!(img.data.as_ref().unwrap().len(), (6 * FACE_SIZE * FACE_SIZE * 4) as usize);
    }

    #[test]
    fn sky_is_bluer_up_and_brighter_towards_the_sun() {
        let sky = GradientSky::default();
        let sun = Vec3::new(0.0, 0.5, -0.866);
        let zenith = sky.radiance(Vec3::Y, sun);
        let horizon = sky.radiance(Vec3::Z, sun);
        assert!(zenith.z > zenith.x && zenith.z / zenith.x > horizon.z / horizon.x);
        assert!(sky.radiance(sun, sun).x > sky.radiance(-sun, sun).x + 0.5);
    }

    #[test]
    fn transmittance_reddens_low_sun() {
        let high = clear_sky_transmittance(60.0);
        let low = clear_sky_transmittance(5.0);
        assert!(high.x > low.x && high.z > low.z);
        assert!(low.x / low.z > high.x / high.z, "low sun is redder");
        assert_eq!(clear_sky_transmittance(-10.0), Vec3::ZERO);
        let t35 = clear_sky_transmittance(35.0);
        assert!((t35.x - 0.78).abs() < 0.03 && (t35.z - 0.55).abs() < 0.03, "{t35}");
    }
}
