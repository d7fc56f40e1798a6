//! The light incandescent lava casts on what is around it (issue 18 items 4 and 6): by night
//! the ground, the folds and the obstacles beside a flow are lit orange; by day the same light
//! is lost beside the sun's.
//!
//! The lava surface already emits its black-body colour ([`incandescent`]) at
//! [`LavaRenderSettings::emissive_nits`](super::LavaRenderSettings) in its material, which
//! lights nothing else. [`glow_light`] sums what that emission gives out, as a Lambertian
//! emitter (`Φ = π L A` lumens for luminance `L` in nits over area `A`), and
//! [`update_glow_lights`] puts one point light of that power and mean colour above the
//! emission's centroid, without shadows. One light per field; an extended flow is not a point,
//! so the light sits above its centroid by half the radius of the glowing area, which keeps
//! grazing ground beside the flow from going dark.

use bevy::color::LinearRgba;
use bevy::math::DVec3;
use bevy::prelude::*;
use volcano_lava::view::surface_temperature;
use volcano_lava::{FlowField, LavaParams, LavaState};

use super::{LavaRenderMode, LavaRenderSettings, LavaSurface, incandescent};

/// Every `SAMPLE_STRIDE`-th cell along each axis is summed, standing for its block (a 256²
/// field: 4,096 samples; the light changes slowly over metres).
const SAMPLE_STRIDE: usize = 4;
/// Illuminance (lux) at which the light's range ends.
const RANGE_LUX: f32 = 1.0;

/// One field's glow as a point light, in the field's frame (world metres, y up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlowLight {
    /// Where the light sits: above the luminous centroid.
    pub position: Vec3,
    /// Luminous power (lumens).
    pub lumens: f32,
    /// Mean colour of the emission, brightest channel 1.
    pub colour: LinearRgba,
    /// Area of the glowing surface the sum covered (m²).
    pub area: f32,
}

/// Photometric luminance of a linear-RGB colour (Rec. 709 weights).
fn luminance(c: LinearRgba) -> f32 {
    0.2126 * c.red + 0.7152 * c.green + 0.0722 * c.blue
}

/// What the lava's surface gives out as light: per sampled wet cell the black-body colour of
/// its crust-top temperature ([`surface_temperature`], as the emissive texture draws it) at
/// `emissive_nits`, as a Lambertian emitter. `None` when nothing glows (no lava, all of it
/// cold: under a lumen in all, or non-finite state).
pub fn glow_light(
    flow: &FlowField,
    crust: &[f64],
    params: &LavaParams,
    emissive_nits: f32,
) -> Option<GlowLight> {
    let (nx, ny) = (flow.nx(), flow.ny());
    let (h, temp, ground) = (flow.thickness(), flow.temperature().data(), flow.ground().data());
    let cell = h.cell() as f32;
    let block = (cell * SAMPLE_STRIDE as f32).powi(2);
    let (mut power, mut centre, mut colour, mut area) = (0.0f64, DVec3::ZERO, [0.0f64; 3], 0.0f64);
    for j in (SAMPLE_STRIDE / 2..ny).step_by(SAMPLE_STRIDE) {
        for i in (SAMPLE_STRIDE / 2..nx).step_by(SAMPLE_STRIDE) {
            let k = j * nx + i;
            let depth = h.data()[k];
            // NaN counts as dry.
            let wet = depth > params.min_thickness;
            if !wet {
                continue;
            }
            let c = incandescent(surface_temperature(params, temp[k], crust.get(k).copied().unwrap_or(0.0)));
            // Lumens of this block: π L A.
            let phi = (std::f32::consts::PI * emissive_nits * luminance(c) * block) as f64;
            if !(phi.is_finite() && phi > 0.0) {
                continue;
            }
            let p = h.position(i, j);
            power += phi;
            centre += DVec3::new(p.x as f64, ground[k] + depth, p.y as f64) * phi;
            for (sum, channel) in colour.iter_mut().zip([c.red, c.green, c.blue]) {
                *sum += phi * channel as f64;
            }
            area += block as f64;
        }
    }
    // Below a lumen (a candle gives 12) the lava is dark: no light.
    if !(power.is_finite() && power > 1.0) {
        return None;
    }
    let brightest = colour.iter().copied().fold(0.0, f64::max);
    let [r, g, b] = colour.map(|c| (c / brightest) as f32);
    let radius = (area / std::f64::consts::PI).sqrt();
    let lift = (0.5 * radius).max(2.0);
    Some(GlowLight {
        position: (centre / power + DVec3::Y * lift).as_vec3(),
        lumens: power as f32,
        colour: LinearRgba::rgb(r, g, b),
        area: area as f32,
    })
}

/// Distance (m) at which a point of `lumens` gives [`RANGE_LUX`]: `√(Φ / (4π E))`.
pub fn glow_range(lumens: f32) -> f32 {
    (lumens.max(0.0) / (4.0 * std::f32::consts::PI * RANGE_LUX)).sqrt()
}

/// The glow light child of a lava field.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct LavaGlow;

/// Keeps one [`LavaGlow`] point light under every lava field whose surface glows (lit view,
/// [`LavaRenderSettings::glow_light`] on), moved and re-powered on the frames its surface was
/// rebuilt ([`LavaSurface::rebuilt_this_frame`]: after the lava or the look changed, at most
/// every `rebuild_every_frames` frames), so the light follows the drawn surface.
pub(super) fn update_glow_lights(
    mut commands: Commands,
    mode: Res<LavaRenderMode>,
    settings: Res<LavaRenderSettings>,
    fields: Query<(Entity, &LavaState, &volcano_lava::LavaField, &Children)>,
    surfaces: Query<&LavaSurface>,
    mut lights: Query<(&mut PointLight, &mut Transform, &mut Visibility), With<LavaGlow>>,
) {
    let on = settings.glow_light && *mode == LavaRenderMode::Lit;
    for (entity, state, field, children) in &fields {
        let rebuilt =
            children.iter().filter_map(|c| surfaces.get(c).ok()).any(LavaSurface::rebuilt_this_frame);
        let existing = children.iter().find(|c| lights.contains(*c));
        let glow = if on && rebuilt {
            Some(glow_light(&state.flow, &state.surface.crust, &field.params, settings.emissive_nits))
        } else {
            None
        };
        match (existing, glow) {
            (None, Some(Some(g))) => {
                commands.spawn((
                    Name::new("Lava glow"),
                    LavaGlow,
                    point_light(&g),
                    Transform::from_translation(g.position),
                    Visibility::Inherited,
                    ChildOf(entity),
                ));
            }
            (Some(child), glow) => {
                let Ok((mut light, mut transform, mut visibility)) = lights.get_mut(child) else { continue };
                let shown = match glow {
                    Some(Some(g)) => {
                        *light = point_light(&g);
                        transform.translation = g.position;
                        Visibility::Inherited
                    }
                    Some(None) => Visibility::Hidden,
                    None if !on => Visibility::Hidden,
                    None => *visibility,
                };
                if *visibility != shown {
                    *visibility = shown;
                }
            }
            _ => {}
        }
    }
}

fn point_light(g: &GlowLight) -> PointLight {
    PointLight {
        color: Color::LinearRgba(g.colour),
        intensity: g.lumens,
        range: glow_range(g.lumens),
        // The light stands for a sheet, not a bulb: a soft specular highlight.
        radius: (g.area / std::f32::consts::PI).sqrt() * 0.5,
        shadow_maps_enabled: false,
        ..default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_core::Grid2;
    use volcano_lava::Edges;

    fn field(t_core: f64) -> (FlowField, LavaParams) {
        let g = Grid2::new(64, 64, 1.0, Vec2::new(100.0, -50.0), 0.0).unwrap();
        let mut f = FlowField::new(g, Edges::default(), 300.0).unwrap();
        f.place_volume(Vec2::new(132.0, -18.0), 10.0, 50.0, t_core).unwrap();
        (f, LavaParams::isothermal(1000.0).unwrap())
    }

    #[test]
    fn hot_lava_lights_its_surroundings_from_above_its_centre() {
        let (f, p) = field(1400.0);
        let crust = vec![0.0; 64 * 64];
        let g = glow_light(&f, &crust, &p, 40_000.0).expect("hot lava glows");
        // Above the mound's centre, a few metres up.
        assert!((g.position.x - 132.0).abs() < 2.5 && (g.position.z + 18.0).abs() < 2.5, "{g:?}");
        assert!(g.position.y > 2.0, "{g:?}");
        // π L A: a ~300 m² disc at a luminance of the order of 10⁴ nits gives 10⁶–10⁸ lm.
        assert!((1e6..1e8).contains(&g.lumens), "{g:?}");
        // Orange: red brightest, green below it, little blue.
        assert!(g.colour.red == 1.0 && g.colour.green < 0.8 && g.colour.blue < g.colour.green, "{g:?}");
        // Its range reaches where it gives 1 lux.
        let d = glow_range(g.lumens);
        assert!((g.lumens / (4.0 * std::f32::consts::PI * d * d) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn a_crust_dims_the_glow_and_cold_lava_gives_none() {
        let (f, p) = field(1400.0);
        let bare = glow_light(&f, &vec![0.0; 64 * 64], &p, 40_000.0).unwrap();
        let crusted = glow_light(&f, &vec![0.02; 64 * 64], &p, 40_000.0).unwrap();
        assert!(crusted.lumens < 0.5 * bare.lumens, "{} vs {}", crusted.lumens, bare.lumens);
        // The same power scales with the emissive setting.
        let half = glow_light(&f, &vec![0.0; 64 * 64], &p, 20_000.0).unwrap();
        assert!((half.lumens / bare.lumens - 0.5).abs() < 1e-4);
        // At air temperature nothing glows; an empty field neither.
        let (cold, p) = field(300.0);
        assert_eq!(glow_light(&cold, &vec![0.0; 64 * 64], &p, 40_000.0), None);
        let (mut empty, p) = field(1400.0);
        empty = FlowField::new(empty.ground().clone(), Edges::default(), 300.0).unwrap();
        assert_eq!(glow_light(&empty, &[], &p, 40_000.0), None);
    }
}
