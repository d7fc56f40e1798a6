//! Lava fountains ([`LavaFountainState`]) drawn every frame: each clot in flight is a small
//! glowing spindle along its velocity, as long as the path it covers in a 30 fps exposure (a
//! fountain is seen as streaks, not points), emissive at its black body; the clots are
//! grouped by temperature into 25 K bins, one mesh and material per bin. One point light per
//! fountain at its clots' luminous centre stands for the light they throw on the ground and
//! the gas above, with the luminous power of their glowing surface (each drawn clot is a
//! sample of many real ones: `mass / (ρ π d³ / 6)` clots of area `π d²`).

use std::collections::BTreeMap;

use bevy::asset::RenderAssetUsages;
use bevy::light::NotShadowCaster;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use volcano_lava::{Clot, FountainParams, LavaFountainState};

use super::crust::incandescent;
use super::light::{Emitter, GlowLight, luminance, luminous_mix, point_light};
use super::{LavaRenderMode, LavaRenderSettings};

/// Width of a temperature bin (K): clots within it share a material.
const BIN_K: f64 = 25.0;
/// Exposure whose motion a clot's streak shows (s).
const STREAK_S: f32 = 1.0 / 30.0;
/// Smallest drawn radius of a clot (m): a clot of decimetres would vanish beyond a few hundred
/// metres; its glow (bloom) is what the eye sees of it.
const MIN_DRAWN_RADIUS: f32 = 0.4;

/// The clots of one temperature bin of one fountain (a top-level entity in world space).
#[derive(Component, Debug, Clone)]
pub struct FountainClots {
    /// The volcano whose [`LavaFountainState`] it draws.
    pub volcano: Entity,
    /// The temperature bin (its lower bound is `bin × 25 K`).
    pub bin: u32,
    material: Handle<StandardMaterial>,
}

/// A fountain's glow light (a top-level entity in world space).
#[derive(Component, Debug, Clone, Copy, PartialEq, Reflect)]
#[reflect(Component)]
pub struct FountainGlow {
    /// The volcano whose fountain it lights.
    pub volcano: Entity,
}

/// The spindle mesh of `clots` (6 vertices, 8 triangles each).
fn clot_mesh(clots: &[&Clot], radius: f32) -> Mesh {
    let mut positions = Vec::with_capacity(6 * clots.len());
    let mut normals = Vec::with_capacity(6 * clots.len());
    let mut indices = Vec::with_capacity(24 * clots.len());
    for c in clots {
        let centre = c.position.as_vec3();
        let v = c.velocity.as_vec3();
        let axis = v.try_normalize().unwrap_or(Vec3::Y);
        let half = (0.5 * v.length() * STREAK_S).max(radius);
        let side = axis.any_orthonormal_vector();
        let other = axis.cross(side);
        let base = positions.len() as u32;
        for (offset, normal) in [
            (axis * half, axis),
            (-axis * half, -axis),
            (side * radius, side),
            (other * radius, other),
            (-side * radius, -side),
            (-other * radius, -other),
        ] {
            positions.push(centre + offset);
            normals.push(normal);
        }
        for (a, b) in [(2, 3), (3, 4), (4, 5), (5, 2)] {
            indices.extend_from_slice(&[base, base + a, base + b, base + 1, base + b, base + a]);
        }
    }
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::RENDER_WORLD);
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    mesh.insert_attribute(Mesh::ATTRIBUTE_NORMAL, normals);
    mesh.insert_indices(Indices::U32(indices));
    mesh
}

/// The light of a fountain's `clots`: at their luminous centre, the luminous power of the
/// real clots' glowing surface (`π L A`, `L` the emissive luminance at `nits`).
pub fn fountain_glow(clots: &[Clot], params: &FountainParams, nits: f32) -> Option<GlowLight> {
    let d = params.clot_diameter;
    let clot_mass = params.clot_density * std::f64::consts::PI * d * d * d / 6.0;
    let mut area = 0.0;
    let emitters: Vec<Emitter> = clots
        .iter()
        .map(|c| {
            let a = c.mass / clot_mass * std::f64::consts::PI * d * d;
            area += a;
            let glow = incandescent(c.temperature);
            Emitter {
                position: c.position,
                lumens: std::f64::consts::PI * (nits * luminance(glow)) as f64 * a,
                colour: [glow.red, glow.green, glow.blue].map(|v| v as f64),
            }
        })
        .collect();
    let power: f64 = emitters.iter().map(|e| e.lumens).sum();
    (power > 0.0 && power.is_finite()).then(|| {
        let (power, centre, colour) = luminous_mix(&emitters);
        GlowLight { position: centre.as_vec3(), lumens: power as f32, colour, area: area as f32 }
    })
}

/// Rebuilds every fountain's clot meshes (one per occupied temperature bin) and moves its light;
/// removes what belongs to fountains gone or bins emptied.
#[allow(clippy::too_many_arguments)]
pub(crate) fn update_fountains(
    mut commands: Commands,
    mode: Res<LavaRenderMode>,
    settings: Res<LavaRenderSettings>,
    fountains: Query<(Entity, &LavaFountainState)>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    drawn: Query<(Entity, &FountainClots, &Mesh3d)>,
    mut lights: Query<(Entity, &FountainGlow, &mut PointLight, &mut Transform)>,
) {
    let lit = *mode == LavaRenderMode::Lit;
    let mut existing: BTreeMap<(Entity, u32), (Entity, &FountainClots, &Mesh3d)> =
        drawn.iter().map(|(e, c, m)| ((c.volcano, c.bin), (e, c, m))).collect();
    let mut lit_fountains: BTreeMap<Entity, GlowLight> = BTreeMap::new();
    for (volcano, state) in &fountains {
        let Some(f) = &state.fountain else { continue };
        let radius = (0.5 * f.params().clot_diameter as f32).max(MIN_DRAWN_RADIUS);
        let mut bins: BTreeMap<u32, Vec<&Clot>> = BTreeMap::new();
        for c in f.clots().iter().filter(|c| c.position.is_finite() && c.temperature.is_finite()) {
            bins.entry((c.temperature.max(0.0) / BIN_K) as u32).or_default().push(c);
        }
        for (bin, clots) in bins {
            let mesh = clot_mesh(&clots, radius);
            let t = (bin as f64 + 0.5) * BIN_K;
            let s = if lit { settings.emissive_nits.max(0.0) } else { 1.0 };
            let glow = incandescent(t) * s;
            match existing.remove(&(volcano, bin)) {
                Some((_, clots_of, mesh3d)) => {
                    let _ = meshes.insert(mesh3d.id(), mesh);
                    if let Some(mut m) = materials.get_mut(&clots_of.material)
                        && (m.emissive != glow || m.unlit == lit)
                    {
                        m.emissive = glow;
                        m.unlit = !lit;
                    }
                }
                None => {
                    let material = materials.add(StandardMaterial {
                        base_color: Color::BLACK,
                        emissive: glow,
                        // In nits, under the camera's exposure like the lava surfaces.
                        emissive_exposure_weight: 1.0,
                        unlit: !lit,
                        ..default()
                    });
                    commands.spawn((
                        Name::new("Lava fountain clots"),
                        FountainClots { volcano, bin, material: material.clone() },
                        Mesh3d(meshes.add(mesh)),
                        MeshMaterial3d(material),
                        Transform::IDENTITY,
                        Visibility::Inherited,
                        NotShadowCaster,
                    ));
                }
            }
        }
        if lit
            && settings.glow_light
            && let Some(g) = fountain_glow(f.clots(), f.params(), settings.emissive_nits)
        {
            lit_fountains.insert(volcano, g);
        }
    }
    for (e, ..) in existing.into_values() {
        commands.entity(e).despawn();
    }
    for (e, glow, mut light, mut transform) in &mut lights {
        match lit_fountains.remove(&glow.volcano) {
            Some(g) => {
                *light = point_light(&g);
                transform.set_if_neq(Transform::from_translation(g.position));
            }
            None => commands.entity(e).despawn(),
        }
    }
    for (volcano, g) in lit_fountains {
        commands.spawn((
            Name::new("Lava fountain glow"),
            FountainGlow { volcano },
            point_light(&g),
            Transform::from_translation(g.position),
            Visibility::Inherited,
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::DVec3;

    fn clot(y: f64, vy: f64, t: f64) -> Clot {
        Clot {
            position: DVec3::new(0.0, y, 0.0),
            velocity: DVec3::new(0.0, vy, 0.0),
            temperature: t,
            mass: 60.0,
        }
    }

    #[test]
    fn a_clot_is_a_streak_as_long_as_its_motion_in_a_frame() {
        let (fast, slow) = (clot(10.0, 60.0, 1400.0), clot(20.0, 0.0, 1400.0));
        let mesh = clot_mesh(&[&fast, &slow], 0.4);
        let Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION)
        else {
            panic!("positions")
        };
        assert_eq!(p.len(), 12);
        assert_eq!(mesh.indices().unwrap().len(), 48);
        // 60 m/s over 1/30 s: a 2 m streak; at rest, a 0.8 m spindle.
        assert!((p[0][1] - p[1][1] - 2.0).abs() < 1e-4, "{p:?}");
        assert!((p[6][1] - p[7][1] - 0.8).abs() < 1e-4, "{p:?}");
    }

    #[test]
    fn a_fountains_light_is_its_clots_glowing_surface() {
        let params = FountainParams::default();
        let hot = [clot(10.0, 0.0, 1400.0), clot(30.0, 0.0, 1400.0)];
        let g = fountain_glow(&hot, &params, 1000.0).unwrap();
        assert!((g.position.y - 20.0).abs() < 1e-4);
        // Each 60 kg sample is 60 / (1500 π 0.2³ / 6) = 9.5 clots of 0.126 m².
        let area = 2.0 * 60.0 / (1_500.0 * std::f64::consts::PI * 0.008 / 6.0) * std::f64::consts::PI * 0.04;
        assert!((g.area as f64 / area - 1.0).abs() < 1e-5, "{} vs {area}", g.area);
        let cooler = [clot(10.0, 0.0, 1200.0), clot(30.0, 0.0, 1200.0)];
        assert!(fountain_glow(&cooler, &params, 1000.0).unwrap().lumens < 0.5 * g.lumens);
        assert!(fountain_glow(&[], &params, 1000.0).is_none());
    }
}
