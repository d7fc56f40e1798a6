//! A volcano's own lava ([`TerrainLava`], a runout over the whole terrain) drawn tile by tile:
//! one mesh per stored tile holding liquid lava, vertices at the cell centres on the lava
//! surface (one row and column more from the neighbour tiles, so tiles join without gaps),
//! dry corners of a wet quad sunk under the ground so the flow's edge meets the terrain. In
//! the lit view an emissive texture of one texel per cell carries the black body of the
//! crust top (the crust a law of the lava's age, as the model cools it), over an albedo that
//! darkens with the crust; frozen lava is the terrain's. The debug views colour by crust and
//! thickness, like a field's.

use std::collections::BTreeMap;

use bevy::asset::RenderAssetUsages;
use bevy::light::NotShadowCaster;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use volcano_lava::view::{RUNOUT_TILE as TILE, crust_from_contact, surface_temperature};
use volcano_lava::{LavaParams, Runout, TerrainLava, VentLavaSettings};

use bevy::math::DVec3;

use super::crust::{f16_bits, incandescent};
use super::light::{Emitter, GlowLight, light_of, luminance, point_light};
use super::surface::{LIFT, crust_albedo, debug_crust};
use super::{LavaRenderMode, LavaRenderSettings, emissive_image, style_material};
use crate::terrain::{MeshSurface, TerrainMesh};

/// How far (m) a dry corner of a wet quad sinks under the ground.
const SINK: f32 = 0.5;

/// Share of a cell's surface where the crust is open (cracks, torn plates at a channel's
/// shearing margins) and the core shows: a cell is metres across, so the cracks a field draws
/// texel by texel are averaged into its one texel.
const OPEN_CRUST: f32 = 0.08;

/// The mesh of one runout tile (a top-level entity in world space).
#[derive(Component, Debug, Clone)]
pub struct RunoutTileSurface {
    /// The terrain whose [`TerrainLava`] it draws.
    pub terrain: Entity,
    /// The tile.
    pub key: (i32, i32),
    material: Handle<StandardMaterial>,
    image: Handle<Image>,
}

/// The surfaces by (terrain, tile), and the frame counter of the rebuild cadence.
#[derive(Default)]
pub(crate) struct Drawn {
    surfaces: BTreeMap<(Entity, (i32, i32)), Entity>,
    frames: u32,
}

/// A cell's lava: thickness, temperature, ground and age; dry outside the stored tiles.
fn cell(runout: &Runout, a: i64, b: i64) -> (f64, f64, f64, f64) {
    runout.cell_state(a, b).unwrap_or((0.0, 0.0, f64::NAN, 0.0))
}

/// A tile's cells: thickness, temperature, ground and age (its own arrays, row-major).
type TileCells<'a> = [&'a [f64]; 4];

/// The mesh and emissive texels of tile `key` (its `cells`), or `None` if it holds no liquid
/// lava. The extra row and column of vertices come from the neighbour tiles.
fn tile_mesh(
    runout: &Runout,
    (key, cells): ((i32, i32), TileCells),
    params: &LavaParams,
    mode: LavaRenderMode,
    drawn: Option<&MeshSurface>,
) -> Option<(Mesh, Vec<u8>)> {
    let n = TILE + 1;
    let min_h = params.min_thickness;
    let kappa = params.kappa();
    let (a0, b0) = (key.0 as i64 * TILE as i64, key.1 as i64 * TILE as i64);
    let [h, t, ground, age] = cells;
    let states: Vec<(f64, f64, f64, f64)> = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .map(|(i, j)| match j * TILE + i {
            k if i < TILE && j < TILE => (h[k], t[k], ground[k], age[k]),
            _ => cell(runout, a0 + i as i64, b0 + j as i64),
        })
        .collect();
    let wet = |k: usize| states[k].0 > min_h;
    if !(0..TILE).any(|j| (0..TILE).any(|i| wet(j * n + i))) {
        return None;
    }
    let grid = runout.grid();
    let max_h = states.iter().map(|s| s.0).fold(0.0f64, f64::max).max(1e-6);
    let mut positions = Vec::with_capacity(n * n);
    let mut colours = Vec::with_capacity(n * n);
    let mut uvs = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let k = j * n + i;
            let (h, _, g, age) = states[k];
            let c = grid.centre(a0 + i as i64, b0 + j as i64);
            let g = if g.is_finite() { g } else { neighbour_ground(&states, n, i, j) };
            let (x, z) = (c.x as f32, c.y as f32);
            // On the drawn terrain (triangles, not the model's bilinear ground): a wet vertex
            // at least `LIFT` above it, a dry one `SINK` under it.
            let y = match (h > min_h, drawn) {
                (true, Some(d)) => ((g + h) as f32).max(d.height_at(x, z) + LIFT),
                (true, None) => (g + h) as f32,
                (false, Some(d)) => d.height_at(x, z).min(g as f32) - SINK,
                (false, None) => g as f32 - SINK,
            };
            positions.push([x, y, z]);
            let crust = crust_from_contact(kappa, age);
            let colour = match mode {
                LavaRenderMode::Lit => crust_albedo(crust, params.rigid_crust),
                LavaRenderMode::DebugCrust => debug_crust(crust),
                LavaRenderMode::DebugThickness => {
                    let x = (h / max_h) as f32;
                    LinearRgba::rgb(x.min(1.0), (x - 0.5).max(0.0) * 2.0, 0.0)
                }
            };
            colours.push(colour.to_f32_array());
            uvs.push([(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..TILE {
        for i in 0..TILE {
            let k = j * n + i;
            let quad = [k, k + 1, k + n, k + n + 1];
            if !quad.iter().any(|&q| wet(q)) {
                continue;
            }
            let [v00, v10, v01, v11] = quad.map(|q| q as u32);
            indices.extend_from_slice(&[v00, v01, v10, v10, v01, v11]);
        }
    }
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::RENDER_WORLD);
    mesh.insert_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    mesh.insert_attribute(Mesh::ATTRIBUTE_COLOR, colours);
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_0, uvs);
    mesh.insert_indices(Indices::U32(indices));
    mesh.compute_smooth_normals();
    // One texel per vertex: the crust top's black body where lava is.
    let mut texels = Vec::with_capacity(8 * n * n);
    for &(h, t, _, age) in &states {
        let c =
            if h > min_h { cell_glow(params, t, crust_from_contact(kappa, age)) } else { LinearRgba::BLACK };
        for v in [c.red.min(8.0), c.green.min(8.0), c.blue.min(8.0), 1.0] {
            texels.extend_from_slice(&f16_bits(v).to_le_bytes());
        }
    }
    Some((mesh, texels))
}

/// Ground of a vertex beyond the stored tiles: the nearest stored neighbour's in its row or
/// column (such a vertex is dry and only closes the tile's last quads).
fn neighbour_ground(states: &[(f64, f64, f64, f64)], n: usize, i: usize, j: usize) -> f64 {
    let at = |i: usize, j: usize| states[j * n + i].2;
    [(i.saturating_sub(1), j), (i, j.saturating_sub(1)), (i.saturating_sub(1), j.saturating_sub(1))]
        .into_iter()
        .map(|(i, j)| at(i, j))
        .find(|g| g.is_finite())
        .unwrap_or(0.0)
}

/// The assets a tile surface is made of.
#[derive(bevy::ecs::system::SystemParam)]
pub(crate) struct TileAssets<'w> {
    meshes: ResMut<'w, Assets<Mesh>>,
    materials: ResMut<'w, Assets<StandardMaterial>>,
    images: ResMut<'w, Assets<Image>>,
}

/// The light a vent lava's glow casts: per stored tile, its wet cells' emission (the colour
/// the texture draws, as a Lambertian emitter `Φ = π L A`) as one point light over their
/// luminous centroid ([`super::light`]); the `max` brightest tiles. Empty when nothing glows.
pub fn runout_glow(runout: &Runout, params: &LavaParams, emissive_nits: f32, max: usize) -> Vec<GlowLight> {
    let kappa = params.kappa();
    let area = runout.grid().cell() * runout.grid().cell();
    let mut lights: Vec<GlowLight> = runout
        .tiles()
        .iter()
        .filter_map(|tile| {
            let (a0, b0) = (tile.key().0 as i64 * TILE as i64, tile.key().1 as i64 * TILE as i64);
            let blocks: Vec<Emitter> = (0..TILE * TILE)
                .filter_map(|k| {
                    let (h, t, g) = (tile.thickness()[k], tile.temperature()[k], tile.ground()[k]);
                    // NaN counts as dry.
                    if h.is_nan() || h <= params.min_thickness {
                        return None;
                    }
                    let (a, b) = (a0 + (k % TILE) as i64, b0 + (k / TILE) as i64);
                    let c = cell_glow(params, t, crust_from_contact(kappa, tile.age()[k]));
                    let lumens = std::f64::consts::PI * (emissive_nits * luminance(c)) as f64 * area;
                    let p = runout.grid().centre(a, b);
                    (lumens.is_finite() && lumens > 0.0).then(|| Emitter {
                        position: DVec3::new(p.x, g + h, p.y),
                        lumens,
                        colour: [c.red, c.green, c.blue].map(|v| v as f64),
                    })
                })
                .collect();
            let power: f64 = blocks.iter().map(|e| e.lumens).sum();
            (power >= 1.0).then(|| light_of(&blocks, area))
        })
        .collect();
    lights.sort_by(|a, b| b.lumens.total_cmp(&a.lumens));
    lights.truncate(max);
    lights
}

/// The colour a wet cell glows (its texel): the crust top's black body with [`OPEN_CRUST`]
/// of the core's.
fn cell_glow(params: &LavaParams, t: f64, crust: f64) -> LinearRgba {
    incandescent(surface_temperature(params, t, crust)).mix(&incandescent(t), OPEN_CRUST)
}

/// A vent lava glow light (a top-level entity in world space).
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct RunoutGlow;

/// Creates, rebuilds and removes the runout tile surfaces every
/// [`LavaRenderSettings::rebuild_every_frames`] frames.
#[allow(clippy::too_many_arguments)]
pub(crate) fn update_runout_tiles(
    mut commands: Commands,
    mut drawn: Local<Drawn>,
    mode: Res<LavaRenderMode>,
    settings: Res<LavaRenderSettings>,
    vent_settings: Option<Res<VentLavaSettings>>,
    lavas: Query<(Entity, &TerrainLava, &volcano_core::Terrain, Option<&Children>)>,
    terrain_meshes: Query<&TerrainMesh>,
    assets: TileAssets,
    surfaces: Query<(&RunoutTileSurface, &Mesh3d)>,
    mut glows: Query<(Entity, &mut PointLight, &mut Transform, &mut Visibility), With<RunoutGlow>>,
) {
    let TileAssets { mut meshes, mut materials, mut images } = assets;
    drawn.frames += 1;
    if drawn.frames < settings.rebuild_every_frames.max(1) {
        return;
    }
    drawn.frames = 0;
    let params = vent_settings.map(|s| s.params.clone()).unwrap_or_default();
    let mut keep = BTreeMap::new();
    for (terrain, lava, ground, children) in &lavas {
        let stride =
            children.and_then(|c| c.iter().find_map(|c| terrain_meshes.get(c).ok())).map(|m| m.stride);
        let drawn_ground = stride.map(|s| MeshSurface::new(ground, s));
        for tile in lava.runout.tiles() {
            let id = (terrain, tile.key());
            let cells = [tile.thickness(), tile.temperature(), tile.ground(), tile.age()];
            let Some((mesh, texels)) =
                tile_mesh(&lava.runout, (tile.key(), cells), &params, *mode, drawn_ground.as_ref())
            else {
                continue;
            };
            let n = TILE + 1;
            let entity = match drawn.surfaces.get(&id).copied().filter(|e| surfaces.get(*e).is_ok()) {
                Some(e) => {
                    let (s, mesh3d) = surfaces.get(e).expect("checked above");
                    // The same handles with new contents: a tile whose `Mesh3d` got a new handle
                    // at each rebuild was never drawn (headless stills).
                    let _ = meshes.insert(mesh3d.id(), mesh);
                    let _ = images.insert(s.image.id(), emissive_image(n, n, texels));
                    // `into_inner` marks the material modified, so its bind group takes the
                    // new texture.
                    if let Some(m) = materials.get_mut(&s.material) {
                        style(m.into_inner(), *mode, &settings);
                    }
                    e
                }
                None => {
                    let image = images.add(emissive_image(n, n, texels));
                    let material = materials.add(tile_material(image.clone(), *mode, &settings));
                    commands
                        .spawn((
                            Name::new("Vent lava tile"),
                            RunoutTileSurface { terrain, key: tile.key(), material: material.clone(), image },
                            Mesh3d(meshes.add(mesh)),
                            MeshMaterial3d(material),
                            Transform::IDENTITY,
                            Visibility::Inherited,
                            NotShadowCaster,
                        ))
                        .id()
                }
            };
            keep.insert(id, entity);
        }
    }
    for (id, e) in std::mem::take(&mut drawn.surfaces) {
        if !keep.contains_key(&id)
            && let Ok(mut ec) = commands.get_entity(e)
        {
            ec.despawn();
        }
    }
    drawn.surfaces = keep;
    // The glow lights of every terrain's vent lava, reusing the lights already spawned.
    let on = settings.glow_light && *mode == LavaRenderMode::Lit;
    let wanted: Vec<GlowLight> = if on {
        let max = settings.glow_light_count as usize;
        lavas
            .iter()
            .flat_map(|(_, lava, ..)| runout_glow(&lava.runout, &params, settings.emissive_nits, max))
            .collect()
    } else {
        Vec::new()
    };
    let mut spare = glows.iter_mut();
    for g in &wanted {
        let at = Transform::from_translation(g.position);
        match spare.next() {
            Some((_, mut light, mut transform, mut visibility)) => {
                *light = point_light(g);
                transform.set_if_neq(at);
                visibility.set_if_neq(Visibility::Inherited);
            }
            None => {
                commands.spawn((
                    Name::new("Vent lava glow"),
                    RunoutGlow,
                    point_light(g),
                    at,
                    Visibility::Inherited,
                ));
            }
        }
    }
    for (_, _, _, mut visibility) in spare {
        visibility.set_if_neq(Visibility::Hidden);
    }
}

/// A tile's material: emissive through `image` in nits, scaled by the camera's exposure like a
/// field's (Bevy leaves emission unexposed by default, which shows any glow above a nit as
/// white), styled for `mode`.
fn tile_material(
    image: Handle<Image>,
    mode: LavaRenderMode,
    settings: &LavaRenderSettings,
) -> StandardMaterial {
    let mut m =
        StandardMaterial { emissive_texture: Some(image), emissive_exposure_weight: 1.0, ..default() };
    style(&mut m, mode, settings);
    m
}

/// The lit view glows by the texture; the debug views are unlit vertex colours: a field's
/// style without its detail textures ([`style_material`]), a little rougher.
fn style(material: &mut StandardMaterial, mode: LavaRenderMode, settings: &LavaRenderSettings) {
    style_material(material, mode, settings, None);
    material.perceptual_roughness = 0.6;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tiles_glow_follows_the_cameras_exposure() {
        let settings = LavaRenderSettings::default();
        let lit = tile_material(Handle::default(), LavaRenderMode::Lit, &settings);
        assert_eq!(lit.emissive_exposure_weight, 1.0);
        assert_eq!(lit.emissive.red, settings.emissive_nits);
        // A wet cell of the channel glows a few thousand nits: under a daylight exposure
        // (EV100 13: 1 / (1.2 · 2¹³)) a fifth of white, so a crusted flow reads dark by day.
        let p = VentLavaSettings::default().params;
        let c = cell_glow(&p, 1_450.0, crust_from_contact(p.kappa(), 600.0));
        let shown = c.red * settings.emissive_nits / (1.2 * 8192.0);
        assert!(shown > 0.1 && shown < 0.3, "{shown}");
    }
}
