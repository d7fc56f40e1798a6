//! Keeping a terrain mesh in step with local height changes ([`TerrainChanged`]: only the
//! vertices over the changed nodes are rewritten) and the altitude of the drawn triangles, for
//! placing things on the mesh.

use bevy::color::{ColorToComponents, LinearRgba};
use bevy::mesh::{Mesh, Mesh3d};
use bevy::prelude::*;
use volcano_core::{NodeRegion, Terrain, TerrainChanged};
use volcano_plume::DepositMap;

use super::deposit::{DepositTint, deposit_tint};
use super::{MeshSamples, TerrainMesh};

/// Rewrites, in a mesh built by [`terrain_mesh`](super::terrain_mesh) with `stride`, the vertices that depend on the
/// nodes of `region` (positions, normals and colours; `tint` recolours a vertex from its node
/// and base colour, e.g. the ash deposit). Returns how many vertices were rewritten (0 if the
/// mesh does not have the expected shape).
pub fn update_terrain_mesh(
    mesh: &mut Mesh,
    terrain: &Terrain,
    stride: usize,
    region: NodeRegion,
    tint: impl Fn(usize, usize, [f32; 4]) -> [f32; 4],
) -> usize {
    if region.is_empty() {
        return 0;
    }
    let samples = MeshSamples::new(terrain, stride);
    let (xs, ys) = (&samples.xs, &samples.ys);
    let n = xs.len() * ys.len();
    let (Some((a0, a1)), Some((b0, b1))) = (
        MeshSamples::affected(xs, region.i0, region.i0 + region.ni - 1),
        MeshSamples::affected(ys, region.j0, region.j0 + region.nj - 1),
    ) else {
        return 0;
    };
    let mut fresh = Vec::with_capacity((a1 + 1 - a0) * (b1 + 1 - b0));
    for (b, &j) in ys.iter().enumerate().take(b1 + 1).skip(b0) {
        for (a, &i) in xs.iter().enumerate().take(a1 + 1).skip(a0) {
            let (p, nrm, c) = samples.vertex(a, b);
            fresh.push((b * xs.len() + a, p, nrm, tint(i, j, c)));
        }
    }
    use bevy::mesh::VertexAttributeValues as V;
    let mut count = 0;
    if let Ok(Some(V::Float32x3(pos))) = mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_POSITION)
        && pos.len() == n
    {
        for (v, p, _, _) in &fresh {
            pos[*v] = *p;
        }
        count = fresh.len();
    }
    if let Ok(Some(V::Float32x3(nor))) = mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_NORMAL)
        && nor.len() == n
    {
        for (v, _, q, _) in &fresh {
            nor[*v] = *q;
        }
    }
    if let Ok(Some(V::Float32x4(col))) = mesh.try_attribute_mut_option(Mesh::ATTRIBUTE_COLOR)
        && col.len() == n
    {
        for (v, _, _, c) in &fresh {
            col[*v] = *c;
        }
    }
    count
}

/// The drawn surface of a terrain mesh built with some stride, for placing things on it.
pub struct MeshSurface<'a>(MeshSamples<'a>);

impl<'a> MeshSurface<'a> {
    /// The surface of `terrain`'s mesh built with `stride` (see [`TerrainMesh::stride`]).
    pub fn new(terrain: &'a Terrain, stride: usize) -> Self {
        Self(MeshSamples::new(terrain, stride))
    }

    /// Altitude of the mesh at world `(x, z)`: its own triangles, not the bilinear surface of
    /// [`Terrain::height_at`], which can differ by decimetres on a 40 m grid. Clamped at the
    /// mesh's edges.
    pub fn height_at(&self, x: f32, z: f32) -> f32 {
        let s = &self.0;
        let (xs, ys) = (&s.xs, &s.ys);
        let (gx, gy) = s.terrain.heights().to_grid(Vec2::new(x, z));
        // Mesh column (row) holding the point and the fraction across it.
        let locate = |axis: &[usize], g: f64| -> (usize, usize, f32) {
            let last = axis.len() - 1;
            let g = if g.is_finite() { g.clamp(0.0, axis[last] as f64) } else { 0.0 };
            let a = axis.partition_point(|&n| (n as f64) <= g).saturating_sub(1).min(last.saturating_sub(1));
            let a1 = (a + 1).min(last);
            let span = (axis[a1] - axis[a]) as f64;
            let t = if span > 0.0 { ((g - axis[a] as f64) / span).clamp(0.0, 1.0) } else { 0.0 };
            (a, a1, t as f32)
        };
        let ((a, a1, tx), (b, b1, ty)) = (locate(xs, gx), locate(ys, gy));
        let y = |a: usize, b: usize| s.surface(xs[a], ys[b]);
        let (h00, h10, h01, h11) = (y(a, b), y(a1, b), y(a, b1), y(a1, b1));
        // Triangles (v00, v01, v10) and (v10, v01, v11), as in `terrain_mesh`.
        if tx + ty <= 1.0 {
            h00 + tx * (h10 - h00) + ty * (h01 - h00)
        } else {
            h11 + (1.0 - tx) * (h01 - h11) + (1.0 - ty) * (h10 - h11)
        }
    }
}

/// Updates the mesh vertices over the nodes each [`TerrainChanged`] names (frozen lava), with
/// the ash deposit tint when it is shown.
pub(super) fn update_changed_regions(
    mut changes: MessageReader<TerrainChanged>,
    terrains: Query<(&Terrain, &Children, Option<&DepositMap>)>,
    mesh_children: Query<(&Mesh3d, &TerrainMesh)>,
    mut meshes: ResMut<Assets<Mesh>>,
    tint: Option<Res<DepositTint>>,
) {
    for change in changes.read() {
        let Ok((terrain, children, deposit)) = terrains.get(change.terrain) else { continue };
        let ash = tint.as_deref().filter(|t| t.enabled).map(|t| LinearRgba::from(t.ash));
        let deposit = deposit.filter(|d| d.revision > 0);
        let recolour = |i: usize, j: usize, c: [f32; 4]| match (ash, deposit) {
            (Some(ash), Some(d)) => {
                deposit_tint(LinearRgba::from_f32_array(c), ash, d.thickness_at_node(i, j)).to_f32_array()
            }
            _ => c,
        };
        for child in children.iter() {
            let Ok((handle, marker)) = mesh_children.get(child) else { continue };
            if let Some(mut mesh) = meshes.get_mut(&handle.0) {
                update_terrain_mesh(&mut mesh, terrain, marker.stride, change.region, recolour);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::terrain_mesh;
    use volcano_core::StratovolcanoParams;

    #[test]
    fn a_region_update_matches_a_full_rebuild() {
        for cap in [65, 33] {
            let mut terrain =
                StratovolcanoParams { resolution: 65, cell: 300.0, ..Default::default() }.generate().unwrap();
            let (mut mesh, stride) = terrain_mesh(&terrain, cap);
            let region = NodeRegion { i0: 20, j0: 30, ni: 5, nj: 3 };
            let dh: Vec<f64> = (0..15).map(|k| 5.0 + k as f64).collect();
            assert_eq!(terrain.add_thickness(region, &dh).unwrap(), region);
            let (full, _) = terrain_mesh(&terrain, cap);
            let attrs = [Mesh::ATTRIBUTE_POSITION, Mesh::ATTRIBUTE_NORMAL, Mesh::ATTRIBUTE_COLOR];
            assert_ne!(mesh.attribute(Mesh::ATTRIBUTE_POSITION), full.attribute(Mesh::ATTRIBUTE_POSITION));
            let n = update_terrain_mesh(&mut mesh, &terrain, stride, region, |_, _, c| c);
            // Stride 1: nodes 19..=25 × 29..=33 (one more each side for the normals).
            assert_eq!(n, if stride == 1 { 7 * 5 } else { 5 * 4 }, "stride {stride}");
            for a in attrs {
                assert_eq!(mesh.attribute(a), full.attribute(a), "stride {stride}");
            }
        }
    }

    #[test]
    fn mesh_surface_follows_the_drawn_triangles() {
        // A saddle h = x·z / 10 on 10 m cells: over the cell [0, 10]² the bilinear surface is
        // 2.5 m at the centre and 5.625 m at (7.5, 7.5); the triangles (diagonal from (10, 0)
        // to (0, 10), both at 0 m) give 0 m and 5 m.
        let mut t = Terrain::flat(3, 10.0, 0.0).unwrap();
        {
            let mut g = t.heights_mut();
            for j in 0..3 {
                for i in 0..3 {
                    let p = g.position(i, j);
                    g.set(i, j, p.x * p.y / 10.0);
                }
            }
        }
        let drawn = MeshSurface::new(&t, 1);
        assert!((t.height_at(5.0, 5.0) - 2.5).abs() < 1e-4);
        assert!(drawn.height_at(5.0, 5.0).abs() < 1e-4, "{}", drawn.height_at(5.0, 5.0));
        assert!((t.height_at(7.5, 7.5) - 5.625).abs() < 1e-4);
        assert!((drawn.height_at(7.5, 7.5) - 5.0).abs() < 1e-4, "{}", drawn.height_at(7.5, 7.5));
        // At nodes and along edges the two agree.
        assert_eq!(drawn.height_at(0.0, 0.0), 0.0);
        assert!((drawn.height_at(10.0, -10.0) - t.height_at(10.0, -10.0)).abs() < 1e-4);
        assert!((drawn.height_at(-5.0, 10.0) - t.height_at(-5.0, 10.0)).abs() < 1e-4);
    }
}
