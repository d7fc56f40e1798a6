//! Pyroclastic deposit on the terrain: the terrain mesh's vertex colours turn toward ash
//! grey with the deposit thickness read from [`DepositMap`] (log scale: 1 mm barely shows,
//! 10 m is fully ash-covered). Recoloured when the deposit changes, at most every
//! [`DepositTint::every_frames`] frames.

use bevy::color::{ColorToComponents, LinearRgba, Srgba};
use bevy::ecs::entity::EntityHashMap;
use bevy::mesh::{Mesh, Mesh3d, VertexAttributeValues};
use bevy::prelude::*;
use volcano_core::Terrain;
use volcano_plume::DepositMap;

use super::cover::{mix, smoothstep};
use super::{MeshSamples, TerrainMesh};

/// How the deposit tints the terrain.
#[derive(Resource, Debug, Clone, Copy, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct DepositTint {
    /// Show the deposit at all.
    pub enabled: bool,
    /// Colour of a thick deposit (sRGB).
    pub ash: Srgba,
    /// Recolour at most once per this many frames (the mesh is re-uploaded each time).
    pub every_frames: u32,
}

impl Default for DepositTint {
    fn default() -> Self {
        // Medium grey: reads as ash on vegetation (lighter, greyer), on rock and basalt
        // (lighter) and on scoria (greyer), rather than as a dark stain.
        Self { enabled: true, ash: Srgba::rgb(0.42, 0.41, 0.40), every_frames: 10 }
    }
}

/// How much of the ash colour a deposit of `thickness` metres shows: 0 below 1 mm, then
/// rising with log₁₀ of the thickness to 1 at 10 m.
pub fn deposit_cover(thickness: f64) -> f32 {
    // NaN counts as no deposit.
    if thickness.is_nan() || thickness <= 1e-3 {
        return 0.0;
    }
    let x = ((thickness.log10() + 3.0) / 4.0) as f32;
    smoothstep(0.0, 1.0, x)
}

/// Terrain colour `base` under a deposit of `thickness` metres of ash coloured `ash`.
pub fn deposit_tint(base: LinearRgba, ash: LinearRgba, thickness: f64) -> LinearRgba {
    mix(base, ash, deposit_cover(thickness))
}

/// Recolours terrain meshes from their deposit.
#[derive(Debug, Default, Clone)]
pub struct DepositRenderPlugin;

impl Plugin for DepositRenderPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<DepositTint>().register_type::<DepositTint>().add_systems(Update, tint_terrain);
    }
}

/// What a terrain's mesh colours last showed: the deposit revision, and whether the tint was on.
type Shown = EntityHashMap<(u64, bool)>;

fn tint_terrain(
    tint: Res<DepositTint>,
    terrains: Query<(Entity, &Terrain, &Children, Option<&DepositMap>)>,
    mesh_children: Query<(&Mesh3d, &TerrainMesh)>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut frames: Local<u32>,
    mut shown: Local<Shown>,
) {
    *frames = frames.saturating_add(1);
    if *frames < tint.every_frames.max(1) {
        return;
    }
    let ash = LinearRgba::from(tint.ash);
    let mut redrew = false;
    for (entity, terrain, children, deposit) in &terrains {
        let deposit = deposit.filter(|d| d.revision > 0);
        let wanted = tint.enabled && deposit.is_some();
        let revision = deposit.map_or(0, |d| d.revision);
        let last = shown.get(&entity).copied().unwrap_or((0, false));
        if last == (revision, wanted) && !tint.is_changed() {
            continue;
        }
        shown.insert(entity, (revision, wanted));
        redrew = true;
        for child in children.iter() {
            let Ok((handle, marker)) = mesh_children.get(child) else { continue };
            let Some(mut mesh) = meshes.get_mut(&handle.0) else { continue };
            let samples = MeshSamples::new(terrain, marker.stride);
            let (xs, ys) = (&samples.xs, &samples.ys);
            if mesh.count_vertices() != xs.len() * ys.len() {
                continue;
            }
            let colors: Vec<[f32; 4]> = (0..ys.len())
                .flat_map(|b| (0..xs.len()).map(move |a| (a, b)))
                .map(|(a, b)| {
                    let base = LinearRgba::from_f32_array(samples.vertex(a, b).2);
                    let t = match (wanted, deposit) {
                        (true, Some(d)) => d.thickness_at_node(xs[a], ys[b]),
                        _ => 0.0,
                    };
                    deposit_tint(base, ash, t).to_f32_array()
                })
                .collect();
            if let Ok(Some(VertexAttributeValues::Float32x4(c))) =
                mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_COLOR)
            {
                *c = colors;
            }
        }
    }
    if redrew {
        *frames = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::TerrainRenderPlugin;
    use volcano_core::{Grid2, StratovolcanoParams};

    /// Headless app (no renderer): a deposit on one corner of the map turns the mesh there ash
    /// grey, and nowhere else.
    #[test]
    fn a_deposit_greys_the_terrain_mesh_under_it() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, bevy::asset::AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_asset::<StandardMaterial>()
            .add_plugins((volcano_core::VolcanoCorePlugin, TerrainRenderPlugin, DepositRenderPlugin));
        app.finish();
        app.cleanup();
        let terrain =
            StratovolcanoParams { resolution: 33, cell: 500.0, ..Default::default() }.generate().unwrap();
        let h = terrain.heights().clone();
        let id = app.world_mut().spawn(terrain).id();
        for _ in 0..3 {
            app.update();
        }
        let colours = |app: &mut App| -> Vec<[f32; 4]> {
            let world = app.world_mut();
            let handle =
                world.query_filtered::<&Mesh3d, With<TerrainMesh>>().single(world).unwrap().0.clone();
            let mesh = world.resource::<Assets<Mesh>>().get(&handle).unwrap();
            match mesh.attribute(Mesh::ATTRIBUTE_COLOR) {
                Some(VertexAttributeValues::Float32x4(c)) => c.clone(),
                _ => panic!("vertex colours"),
            }
        };
        let before = colours(&mut app);
        // 2 m of ash on the 5×5 nodes of one corner.
        let mut mass = Grid2::new(h.nx(), h.ny(), h.cell(), h.origin(), 0.0).unwrap();
        for j in 0..5 {
            for i in 0..5 {
                mass.set(i, j, 2.0 * 1000.0 * h.cell() * h.cell());
            }
        }
        let mut map = DepositMap::default();
        map.mass = Some(mass);
        map.bulk_density = 1000.0;
        map.revision = 1;
        app.world_mut().entity_mut(id).insert(map);
        for _ in 0..12 {
            app.update();
        }
        let after = colours(&mut app);
        let ash = LinearRgba::from(DepositTint::default().ash).to_f32_array();
        let off = |c: [f32; 4]| (0..3).map(|k| (c[k] - ash[k]).abs()).sum::<f32>();
        let corner = 2 * 33 + 2;
        assert!(off(after[corner]) < 0.3 * off(before[corner]), "{:?} → {:?}", before[corner], after[corner]);
        let far = 30 * 33 + 30;
        assert_eq!(after[far], before[far]);
    }

    #[test]
    fn thicker_deposits_are_greyer_and_none_changes_nothing() {
        let base = LinearRgba::rgb(0.03, 0.08, 0.015);
        let ash = LinearRgba::from(DepositTint::default().ash);
        assert_eq!(deposit_tint(base, ash, 0.0), base);
        assert_eq!(deposit_tint(base, ash, f64::NAN), base);
        // Green vegetation loses its green cast: |g − r| shrinks with each thicker deposit.
        let mut last = f32::INFINITY;
        for t in [0.002, 0.01, 0.1, 1.0, 5.0] {
            let c = deposit_tint(base, ash, t);
            let cast = (c.green - c.red).abs() + (c.green - c.blue).abs();
            assert!(cast < last, "{t} m: green cast {cast} not below {last}");
            last = cast;
        }
        assert!((deposit_cover(10.0) - 1.0).abs() < 1e-6 && deposit_cover(100.0) == 1.0);
        assert!(deposit_cover(0.1) > 0.3 && deposit_cover(0.1) < 0.7);
    }
}
