//! Pyroclastic deposit on the terrain: the terrain mesh's vertex colours darken toward ash
//! grey with the deposit thickness read from [`DepositMap`] (log scale: 1 mm barely shows,
//! 10 m is fully ash-covered). Recoloured when the deposit changes, at most every
//! [`DepositTint::every_frames`] frames.

use bevy::color::{ColorToComponents, LinearRgba, Srgba};
use bevy::mesh::{Mesh, Mesh3d, VertexAttributeValues};
use bevy::prelude::*;
use volcano_core::Terrain;
use volcano_plume::DepositMap;

use crate::terrain::{TerrainMesh, mix, sample_axis, smoothstep, terrain_color};

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
        Self { enabled: true, ash: Srgba::rgb(0.17, 0.16, 0.15), every_frames: 10 }
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

/// Recolours terrain meshes from the deposit.
#[derive(Debug, Default, Clone)]
pub struct DepositRenderPlugin;

impl Plugin for DepositRenderPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<DepositTint>()
            .init_resource::<DepositMap>()
            .register_type::<DepositTint>()
            .add_systems(Update, tint_terrain);
    }
}

fn tint_terrain(
    tint: Res<DepositTint>,
    deposit: Res<DepositMap>,
    terrains: Query<(&Terrain, &Children)>,
    mesh_children: Query<(&Mesh3d, &TerrainMesh)>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut last: Local<(u64, u32, bool)>,
) {
    let (revision, frames, shown) = &mut *last;
    *frames = frames.saturating_add(1);
    let wanted = tint.enabled && deposit.revision > 0;
    let changed = (wanted && deposit.revision != *revision) || wanted != *shown || tint.is_changed();
    if !changed || *frames < tint.every_frames.max(1) {
        return;
    }
    *frames = 0;
    *revision = deposit.revision;
    *shown = wanted;
    let ash = LinearRgba::from(tint.ash);
    for (terrain, children) in &terrains {
        for child in children.iter() {
            let Ok((handle, marker)) = mesh_children.get(child) else { continue };
            let Some(mut mesh) = meshes.get_mut(&handle.0) else { continue };
            let Ok(normals) =
                mesh.try_attribute(Mesh::ATTRIBUTE_NORMAL).map(|n| n.as_float3().map(<[_]>::to_vec))
            else {
                continue;
            };
            let Some(normals) = normals else { continue };
            let h = terrain.heights();
            let xs = sample_axis(h.nx(), marker.stride);
            let ys = sample_axis(h.ny(), marker.stride);
            if normals.len() != xs.len() * ys.len() {
                continue;
            }
            let colors: Vec<[f32; 4]> = ys
                .iter()
                .flat_map(|&j| xs.iter().map(move |&i| (i, j)))
                .zip(&normals)
                .map(|((i, j), n)| {
                    let base = terrain_color(terrain, i, j, Vec3::from(*n));
                    let t = if wanted { deposit.thickness_at_node(i, j) } else { 0.0 };
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::TerrainRenderPlugin;
    use volcano_core::{Grid2, StratovolcanoParams};

    /// Headless app (no renderer): a deposit on one corner of the map darkens the mesh there
    /// and nowhere else.
    #[test]
    fn a_deposit_darkens_the_terrain_mesh_under_it() {
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
        app.world_mut().spawn(terrain);
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
        {
            let mut map = app.world_mut().resource_mut::<DepositMap>();
            map.mass = Some(mass);
            map.bulk_density = 1000.0;
            map.revision = 1;
        }
        for _ in 0..12 {
            app.update();
        }
        let after = colours(&mut app);
        let lum = |c: [f32; 4]| c[0] + c[1] + c[2];
        let corner = 2 * 33 + 2;
        assert!(lum(after[corner]) < 0.7 * lum(before[corner]), "{:?} → {:?}", before[corner], after[corner]);
        let far = 30 * 33 + 30;
        assert_eq!(after[far], before[far]);
    }

    #[test]
    fn thicker_deposits_are_darker_and_none_changes_nothing() {
        let base = LinearRgba::rgb(0.3, 0.36, 0.19);
        let ash = LinearRgba::from(DepositTint::default().ash);
        assert_eq!(deposit_tint(base, ash, 0.0), base);
        assert_eq!(deposit_tint(base, ash, f64::NAN), base);
        let mut last = f32::INFINITY;
        for t in [0.002, 0.01, 0.1, 1.0, 5.0] {
            let c = deposit_tint(base, ash, t);
            let lum = c.red + c.green + c.blue;
            assert!(lum < last, "{t} m: {lum} not darker than {last}");
            last = lum;
        }
        assert!((deposit_cover(10.0) - 1.0).abs() < 1e-6 && deposit_cover(100.0) == 1.0);
        assert!(deposit_cover(0.1) > 0.3 && deposit_cover(0.1) < 0.7);
    }
}
