//! The light incandescent lava casts on what is around it: by night
//! the ground, the folds and the obstacles beside a flow are lit orange; by day the same light
//! is lost beside the sun's.
//!
//! The lava surface already emits its black-body colour ([`incandescent`]) at
//! [`LavaRenderSettings::emissive_nits`](super::LavaRenderSettings) in its material, which
//! lights nothing else. [`glow_light`] sums what that emission gives out, as a Lambertian
//! emitter (`Φ = π L A` lumens for luminance `L` in nits over area `A`), and
//! `update_glow_lights` puts point lights of that power and mean colour, without shadows,
//! along the flow ([`glow_lights`]: one per stretch about twice as long as the flow is wide, up
//! to [`LavaRenderSettings::glow_light_count`](super::LavaRenderSettings)). An extended flow
//! is not a point, so each light sits above its stretch's centroid by half the radius of the
//! stretch's glowing area, which keeps grazing ground beside the flow from going dark.

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
pub(super) fn luminance(c: LinearRgba) -> f32 {
    0.2126 * c.red + 0.7152 * c.green + 0.0722 * c.blue
}

/// One sampled block of glowing lava: where it is, what it gives out, its colour.
#[derive(Debug, Clone, Copy)]
pub(super) struct Emitter {
    pub position: DVec3,
    pub lumens: f64,
    pub colour: [f64; 3],
}

/// The glowing blocks of a field: per sampled wet cell the black-body colour of its crust-top
/// temperature ([`surface_temperature`], as the emissive texture draws it) at `emissive_nits`,
/// as a Lambertian emitter (`Φ = π L A`), with the area each sample stands for (m²).
fn emitters(flow: &FlowField, crust: &[f64], params: &LavaParams, emissive_nits: f32) -> (Vec<Emitter>, f64) {
    let (nx, ny) = (flow.nx(), flow.ny());
    let (h, temp, ground) = (flow.thickness(), flow.temperature().data(), flow.ground().data());
    let cell = h.cell() as f32;
    let block = (cell * SAMPLE_STRIDE as f32).powi(2);
    let mut out = Vec::new();
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
            let lumens = (std::f32::consts::PI * emissive_nits * luminance(c) * block) as f64;
            if !(lumens.is_finite() && lumens > 0.0) {
                continue;
            }
            let p = h.position(i, j);
            let colour = [c.red, c.green, c.blue].map(|v| v as f64);
            out.push(Emitter {
                position: DVec3::new(p.x as f64, ground[k] + depth, p.y as f64),
                lumens,
                colour,
            });
        }
    }
    (out, block as f64)
}

/// The blocks' total power (lumens), their luminous centroid and their mean colour, brightest
/// channel 1. The power must be positive.
pub(super) fn luminous_mix(blocks: &[Emitter]) -> (f64, DVec3, LinearRgba) {
    let power: f64 = blocks.iter().map(|e| e.lumens).sum();
    let centre = blocks.iter().map(|e| e.position * e.lumens).sum::<DVec3>() / power;
    let mut colour = [0.0f64; 3];
    for e in blocks {
        for (sum, c) in colour.iter_mut().zip(e.colour) {
            *sum += e.lumens * c;
        }
    }
    let brightest = colour.iter().copied().fold(0.0, f64::max);
    let [r, g, b] = colour.map(|c| (c / brightest) as f32);
    (power, centre, LinearRgba::rgb(r, g, b))
}

/// One light for a set of blocks: their power at their luminous centroid, lifted by half the
/// radius of their area (at least 2 m), in their mean colour.
pub(super) fn light_of(blocks: &[Emitter], block_area: f64) -> GlowLight {
    let (power, centre, colour) = luminous_mix(blocks);
    let area = block_area * blocks.len() as f64;
    let lift = (0.5 * (area / std::f64::consts::PI).sqrt()).max(2.0);
    GlowLight {
        position: (centre + DVec3::Y * lift).as_vec3(),
        lumens: power as f32,
        colour,
        area: area as f32,
    }
}

/// What the lava's surface gives out as light, as one point light (see [`glow_lights`] for
/// several along a long flow). `None` when nothing glows (no lava, all of it cold: under a
/// lumen in all, or non-finite state).
pub fn glow_light(
    flow: &FlowField,
    crust: &[f64],
    params: &LavaParams,
    emissive_nits: f32,
) -> Option<GlowLight> {
    glow_lights(flow, crust, params, emissive_nits, 1).pop()
}

/// What the lava's surface gives out as light, as up to `max_lights` point lights strung
/// along the flow: the glowing blocks (`emitters`) are ordered along the principal axis of
/// their power-weighted positions and cut into runs of equal power, as many as the glowing
/// area is about twice as long as wide (a compact lobe gets one light, a 250 × 15 m tongue
/// eight), each run one light (`light_of`). The lights' powers add up to the whole
/// emission. One light at the centroid of a long tongue would leave the ground beside its ends
/// nearly dark: the ground there is lit by the lava next to it, not by the lava 100 m away.
/// Empty when nothing glows (under a lumen in all) or `max_lights` is 0.
pub fn glow_lights(
    flow: &FlowField,
    crust: &[f64],
    params: &LavaParams,
    emissive_nits: f32,
    max_lights: u32,
) -> Vec<GlowLight> {
    let (mut blocks, block_area) = emitters(flow, crust, params, emissive_nits);
    let power: f64 = blocks.iter().map(|e| e.lumens).sum();
    // Below a lumen (a candle gives 12) the lava is dark: no light.
    if !(power.is_finite() && power > 1.0) || max_lights == 0 {
        return Vec::new();
    }
    // Power-weighted covariance of the horizontal positions.
    let mean = blocks.iter().map(|e| e.position * e.lumens).sum::<DVec3>() / power;
    let (mut cxx, mut cxz, mut czz) = (0.0, 0.0, 0.0);
    for e in &blocks {
        let (dx, dz) = (e.position.x - mean.x, e.position.z - mean.z);
        cxx += e.lumens * dx * dx;
        cxz += e.lumens * dx * dz;
        czz += e.lumens * dz * dz;
    }
    let (cxx, cxz, czz) = (cxx / power, cxz / power, czz / power);
    let angle = 0.5 * (2.0 * cxz).atan2(cxx - czz);
    let (ax, az) = (angle.cos(), angle.sin());
    // Variances along and across the axis; a uniform strip of length l has variance l² / 12.
    let along_var = cxx * ax * ax + 2.0 * cxz * ax * az + czz * az * az;
    let across_var = (cxx + czz - along_var).max(0.0);
    let length = (12.0 * along_var.max(0.0)).sqrt();
    let width = (12.0 * across_var).sqrt().max(block_area.sqrt());
    let pieces = ((length / (2.0 * width)).ceil() as usize).clamp(1, (max_lights as usize).min(blocks.len()));
    let key = |e: &Emitter| (e.position.x - mean.x) * ax + (e.position.z - mean.z) * az;
    blocks.sort_by(|a, b| key(a).total_cmp(&key(b)));
    // Cut where the running power passes each k / pieces of the total.
    let mut lights = Vec::with_capacity(pieces);
    let (mut start, mut running) = (0, 0.0);
    for (i, e) in blocks.iter().enumerate() {
        running += e.lumens;
        let cut = power * (lights.len() + 1) as f64 / pieces as f64;
        if (running >= cut && lights.len() + 1 < pieces) || i + 1 == blocks.len() {
            lights.push(light_of(&blocks[start..=i], block_area));
            start = i + 1;
        }
    }
    lights
}

/// Distance (m) at which a point of `lumens` gives `RANGE_LUX`: `√(Φ / (4π E))`.
pub fn glow_range(lumens: f32) -> f32 {
    (lumens.max(0.0) / (4.0 * std::f32::consts::PI * RANGE_LUX)).sqrt()
}

/// The glow light child of a lava field.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct LavaGlow;

/// What [`update_glow_lights`] writes of a glow light.
type GlowLightItem = (&'static mut PointLight, &'static mut Transform, &'static mut Visibility);

/// Keeps the [`LavaGlow`] point lights ([`glow_lights`], at most
/// [`LavaRenderSettings::glow_light_count`]) under every lava field whose surface glows (lit
/// view, [`LavaRenderSettings::glow_light`] on), moved and re-powered on the frames its
/// surface was rebuilt ([`LavaSurface::rebuilt_this_frame`]: after the lava or the look
/// changed, at most every `rebuild_every_frames` frames), so the lights follow the drawn
/// surface. Lights a field no longer needs are hidden, not despawned.
pub(super) fn update_glow_lights(
    mut commands: Commands,
    mode: Res<LavaRenderMode>,
    settings: Res<LavaRenderSettings>,
    fields: Query<(Entity, &LavaState, &volcano_lava::LavaField, Option<&Transform>, &Children)>,
    surfaces: Query<&LavaSurface>,
    mut lights: Query<GlowLightItem, (With<LavaGlow>, Without<LavaState>)>,
) {
    let on = settings.glow_light && *mode == LavaRenderMode::Lit;
    for (entity, state, field, frame, children) in &fields {
        let rebuilt =
            children.iter().filter_map(|c| surfaces.get(c).ok()).any(LavaSurface::rebuilt_this_frame);
        let existing: Vec<Entity> = children.iter().filter(|c| lights.contains(*c)).collect();
        if !on {
            for &child in &existing {
                if let Ok((_, _, mut visibility)) = lights.get_mut(child) {
                    visibility.set_if_neq(Visibility::Hidden);
                }
            }
            continue;
        }
        if !rebuilt {
            continue;
        }
        let glow = glow_lights(
            &state.flow,
            &state.surface.crust,
            &field.params,
            settings.emissive_nits,
            settings.glow_light_count,
        );
        debug!(
            "lava glow of {entity}: {} lights, {:.3e} lm in all, first at {:?}",
            glow.len(),
            glow.iter().map(|g| g.lumens).sum::<f32>(),
            glow.first().map(|g| g.position)
        );
        for (i, g) in glow.iter().enumerate() {
            match existing.get(i).and_then(|&c| lights.get_mut(c).ok()) {
                Some((mut light, mut transform, mut visibility)) => {
                    *light = point_light(g);
                    transform
                        .set_if_neq(super::in_world_space(frame, Transform::from_translation(g.position)));
                    visibility.set_if_neq(Visibility::Inherited);
                }
                None => {
                    commands.spawn((
                        Name::new("Lava glow"),
                        LavaGlow,
                        point_light(g),
                        super::in_world_space(frame, Transform::from_translation(g.position)),
                        Visibility::Inherited,
                        ChildOf(entity),
                    ));
                }
            }
        }
        for &child in existing.iter().skip(glow.len()) {
            if let Ok((_, _, mut visibility)) = lights.get_mut(child) {
                visibility.set_if_neq(Visibility::Hidden);
            }
        }
    }
}

pub(super) fn point_light(g: &GlowLight) -> PointLight {
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

    /// A tongue of hot lava 120 m long and about 6 m wide along x.
    fn tongue() -> (FlowField, LavaParams) {
        let g = Grid2::new(136, 24, 1.0, Vec2::new(100.0, -30.0), 0.0).unwrap();
        let mut f = FlowField::new(g, Edges::default(), 300.0).unwrap();
        for k in 0..=30 {
            f.place_volume(Vec2::new(104.0 + 4.0 * k as f32, -18.0), 3.0, 5.0, 1400.0).unwrap();
        }
        (f, LavaParams::isothermal(1000.0).unwrap())
    }

    /// Fluence rate (lm/m² over a sphere, the light arriving from every direction) at `q` from
    /// isotropic points.
    fn fluence(q: DVec3, points: impl Iterator<Item = (DVec3, f64)>) -> f64 {
        points.map(|(p, lumens)| lumens / (4.0 * std::f64::consts::PI * p.distance_squared(q))).sum()
    }

    /// Along a long tongue the lights are strung out, carry the whole emission between them,
    /// and light the ground beside the tongue's ends about as the lava next to it does: each
    /// sampled block an isotropic emitter where it lies is the reference. One light at the
    /// centroid would leave the ends at a few tenths of it.
    #[test]
    fn a_long_tongue_gets_lights_along_it_that_light_its_ends() {
        let (f, p) = tongue();
        let crust = vec![0.0; f.nx() * f.ny()];
        let (blocks, _) = emitters(&f, &crust, &p, 40_000.0);
        let xs = blocks.iter().map(|e| e.position.x);
        let (x0, x1) = xs.clone().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
        assert!(x1 - x0 > 100.0, "the tongue is {} m long", x1 - x0);
        let one = glow_light(&f, &crust, &p, 40_000.0).unwrap();
        let lights = glow_lights(&f, &crust, &p, 40_000.0, 8);
        assert_eq!(lights.len(), 8, "{lights:?}");
        let sum: f32 = lights.iter().map(|l| l.lumens).sum();
        assert!((sum / one.lumens - 1.0).abs() < 1e-4, "{sum} vs {}", one.lumens);
        for pair in lights.windows(2) {
            assert!(pair[1].position.x > pair[0].position.x + 5.0, "not strung along x: {lights:?}");
        }
        let at = |l: &GlowLight| (l.position.as_dvec3(), l.lumens as f64);
        for x in [x0, 0.5 * (x0 + x1), x1] {
            // 6 m beside the tongue's axis, 1.5 m above the ground.
            let q = DVec3::new(x, 1.5, -12.0);
            let reference = fluence(q, blocks.iter().map(|e| (e.position, e.lumens)));
            let strung = fluence(q, lights.iter().map(at)) / reference;
            let single = fluence(q, std::iter::once(at(&one))) / reference;
            eprintln!("x {x:.0}: strung {strung:.2}, one light {single:.2} of the reference");
            assert!((0.5..2.0).contains(&strung), "x {x:.0}: {strung:.2} of the reference");
            if x != 0.5 * (x0 + x1) {
                assert!(single < 0.3, "x {x:.0}: one light gives {single:.2} of the reference");
            }
        }
        // A cap of one is the single light; of none, no light.
        assert_eq!(glow_lights(&f, &crust, &p, 40_000.0, 1), vec![one]);
        assert!(glow_lights(&f, &crust, &p, 40_000.0, 0).is_empty());
    }

    /// A round lobe is one light, whatever the cap.
    #[test]
    fn a_compact_lobe_is_one_light() {
        let (f, p) = field(1400.0);
        let crust = vec![0.0; 64 * 64];
        assert_eq!(
            glow_lights(&f, &crust, &p, 40_000.0, 8),
            vec![glow_light(&f, &crust, &p, 40_000.0).unwrap()]
        );
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
