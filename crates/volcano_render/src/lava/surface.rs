//! Pure parts of the lava look: the colour of the crust and the surface mesh of a lava field.
//! No ECS here, so all of it is unit-tested.

use bevy::asset::RenderAssetUsages;
use bevy::color::{ColorToComponents, LinearRgba, Mix, Srgba};
use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use volcano_lava::view::crust_colour;
use volcano_lava::{FlowField, LavaParams};

use super::LavaRenderMode;
use super::crust::{DETAIL_TILE, albedo_variation, dilate};
use super::margin::{EDGE, clip_grid, coverage};

/// Lava lifted this much (m) above the ground it covers, so a thin sheet does not z-fight the
/// terrain mesh.
pub const LIFT: f32 = 0.01;

/// Albedo (linear) of the lava surface under a crust `crust` (m): a glassy dark red-brown for
/// fresh lava darkening to black basalt once the crust reaches `rigid` (m).
pub fn crust_albedo(crust: f64, rigid: f64) -> LinearRgba {
    let fresh = LinearRgba::from(Srgba::rgb(0.30, 0.10, 0.06));
    let basalt = LinearRgba::from(Srgba::rgb(0.16, 0.15, 0.14));
    let t = if rigid > 0.0 { (crust / rigid).clamp(0.0, 1.0) as f32 } else { 1.0 };
    fresh.mix(&basalt, t)
}

/// Albedo of lava that froze into the ground.
pub fn frozen_albedo() -> LinearRgba {
    LinearRgba::from(Srgba::rgb(0.12, 0.115, 0.11))
}

/// Linear colour of a [`crust_colour`] (thesis Figs 5.11–5.13 debug colours).
pub fn debug_crust(crust: f64) -> LinearRgba {
    let [r, g, b] = crust_colour(crust);
    LinearRgba::from(Srgba::rgb_u8(r, g, b))
}

/// Black → red → yellow → white for `x` in [0, 1] (thickness debug view).
fn heat_ramp(x: f64) -> LinearRgba {
    let x = x.clamp(0.0, 1.0) as f32 * 3.0;
    LinearRgba::from(Srgba::rgb(x.clamp(0.0, 1.0), (x - 1.0).clamp(0.0, 1.0), (x - 2.0).clamp(0.0, 1.0)))
}

/// What one lava cell looks like.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Cover {
    /// Liquid lava thicker than the threshold.
    Lava,
    /// Only frozen lava.
    Frozen,
    /// Bare ground.
    Dry,
}

/// Mesh of the lava surface of `flow`. The first `nx · ny` vertices are the cell centres (world
/// `x`, altitude, world `z`; cell `(i, j)` at `j · nx + i`) at the lava surface (ground +
/// frozen + liquid lava, lifted by `LIFT`); the rest are quad centres and the outline
/// ([`margin`](super::margin)): the surface is clipped where the lava's [`coverage`] crosses
/// ½, inside the cells, and comes down to the ground (+ `LIFT`) there, or stays level with
/// the lava where the ground rises above it (a wall), so the outline is smooth instead of a
/// cell staircase. An empty field has no indices. Vertex colours: the
/// albedo (with [`albedo_variation`]) for [`LavaRenderMode::Lit`], the debug colours otherwise,
/// carried into the outline from the covered cells. UV 0 addresses the cell centres of an
/// `nx × ny` texture (see [`glow_texels`](super::crust::glow_texels)); UV 1 is world `(x, z)`
/// over [`DETAIL_TILE`], with tangents along +x for the detail normal map.
pub fn surface_mesh(flow: &FlowField, crust: &[f64], params: &LavaParams, mode: LavaRenderMode) -> Mesh {
    let (nx, ny) = (flow.nx(), flow.ny());
    let (h, ground, solid) = (flow.thickness(), flow.ground().data(), flow.solid().data());
    let hmax = h.data().iter().copied().fold(1e-6, f64::max);
    let cover = |k: usize| {
        if h.data()[k] > params.min_thickness {
            Cover::Lava
        } else if solid[k] > params.min_thickness {
            Cover::Frozen
        } else {
            Cover::Dry
        }
    };
    let n = nx * ny;
    let depth: Vec<f64> = (0..n).map(|k| h.data()[k].max(0.0) + solid[k].max(0.0)).collect();
    // Frozen lava counts by its depth like liquid lava: a chilled rim of millimetres beside a
    // sheet of decimetres is a sliver of the sheet (drawing it whole serrated the outline).
    let alpha = coverage(&depth, nx, ny, params.min_thickness);
    let grid = clip_grid(&alpha, nx, ny);
    let mut positions = Vec::with_capacity(n + grid.extra.len());
    let mut base = Vec::with_capacity(n + grid.extra.len());
    let mut colors = Vec::with_capacity(n + grid.extra.len());
    let mut uvs = Vec::with_capacity(n + grid.extra.len());
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            let p = h.position(i, j);
            positions.push([p.x, (ground[k] + h.data()[k].max(0.0)) as f32 + LIFT, p.y]);
            // The ground under the lava: where the outline comes down to.
            base.push([(ground[k] - solid[k].max(0.0)) as f32 + LIFT]);
            uvs.push([(i as f32 + 0.5) / nx as f32, (j as f32 + 0.5) / ny as f32]);
            let crust_k = crust.get(k).copied().unwrap_or(0.0);
            let shade = albedo_variation(p) / DETAIL_GRAIN;
            let colour = match (mode, cover(k)) {
                // Dry cells only lend colour where the outline cuts their quad; they get their
                // covered neighbours' colour below.
                (_, Cover::Dry) => frozen_albedo(),
                (LavaRenderMode::DebugCrust, Cover::Frozen) => LinearRgba::from(Srgba::rgb_u8(150, 150, 150)),
                (LavaRenderMode::Lit, Cover::Frozen) => scaled(frozen_albedo(), shade),
                (_, Cover::Frozen) => frozen_albedo(),
                (LavaRenderMode::DebugCrust, Cover::Lava) => debug_crust(crust_k),
                (LavaRenderMode::DebugThickness, Cover::Lava) => heat_ramp(h.data()[k] / hmax),
                (LavaRenderMode::Lit, Cover::Lava) => {
                    scaled(crust_albedo(crust_k, params.rigid_crust), shade)
                }
            };
            colors.push(colour.to_f32_array());
        }
    }
    let inside: Vec<bool> = alpha.iter().map(|&a| a >= EDGE).collect();
    dilate(&mut colors, &inside, nx, ny);
    // Smooth normals from central differences of the surface heights.
    let dx = flow.cell() as f32;
    let mut normals = Vec::with_capacity(n + grid.extra.len());
    for j in 0..ny {
        for i in 0..nx {
            let y = |a: usize, b: usize| positions[b * nx + a][1];
            let (i0, i1) = (i.saturating_sub(1), (i + 1).min(nx - 1));
            let (j0, j1) = (j.saturating_sub(1), (j + 1).min(ny - 1));
            let dydx = if i1 > i0 { (y(i1, j) - y(i0, j)) / ((i1 - i0) as f32 * dx) } else { 0.0 };
            let dydz = if j1 > j0 { (y(i, j1) - y(i, j0)) / ((j1 - j0) as f32 * dx) } else { 0.0 };
            normals.push(Vec3::new(-dydx, 1.0, -dydz).normalize_or(Vec3::Y).to_array());
        }
    }
    let mut cover: Vec<[f32; 1]> = alpha.iter().map(|&a| [a]).collect();
    grid.extend(&mut positions);
    grid.extend(&mut base);
    grid.extend(&mut cover);
    grid.extend(&mut colors);
    grid.extend(&mut uvs);
    grid.extend(&mut normals);
    for (v, a, b, _) in grid.outline(n) {
        // Down to the ground, but not above the lava's own surface: against a wall the lava
        // ponds flat instead of climbing it.
        let inside = if cover[a as usize][0] >= cover[b as usize][0] { a } else { b };
        positions[v][1] = base[v][0].min(positions[inside as usize][1]);
    }
    for nrm in normals.iter_mut().skip(n) {
        *nrm = Vec3::from(*nrm).normalize_or(Vec3::Y).to_array();
    }
    let detail: Vec<[f32; 2]> = positions.iter().map(|p| [p[0] / DETAIL_TILE, p[2] / DETAIL_TILE]).collect();
    // Tangent along +x (UV 1's u); the bitangent −(n × t) is +z, UV 1's v.
    let tangents: Vec<[f32; 4]> = normals
        .iter()
        .map(|&nrm| {
            let nrm = Vec3::from(nrm);
            let t = (Vec3::X - nrm * nrm.x).normalize_or(Vec3::X);
            [t.x, t.y, t.z, -1.0]
        })
        .collect();
    Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::RENDER_WORLD)
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_1, detail)
        .with_inserted_attribute(Mesh::ATTRIBUTE_TANGENT, tangents)
        .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, colors)
        .with_inserted_indices(Indices::U32(grid.indices))
}

/// `c` with its colour (not its alpha) times `s`.
fn scaled(c: LinearRgba, s: f32) -> LinearRgba {
    LinearRgba::rgb(c.red * s, c.green * s, c.blue * s)
}

/// Mean of the detail albedo grain ([`detail_images`](super::crust::detail_images)), divided
/// out of the vertex colours so the surface keeps its albedo on average.
const DETAIL_GRAIN: f32 = 0.85;

/// Keeps a [`surface_mesh`] on the right side of the drawn terrain, whose altitude at world
/// `(x, z)` is `terrain(x, z)`: every vertex at least `LIFT` above it. The field's ground is
/// the terrain's bilinear surface, while the terrain mesh is made of triangles; on a 40 m grid
/// the two differ by decimetres, enough to hide a lava sheet. Returns how many vertices moved.
pub fn keep_over_terrain(mesh: &mut Mesh, terrain: impl Fn(f32, f32) -> f32) -> usize {
    let Some(VertexAttributeValues::Float32x3(pos)) = mesh.attribute_mut(Mesh::ATTRIBUTE_POSITION) else {
        return 0;
    };
    let mut moved = 0;
    for p in pos.iter_mut() {
        let y = p[1].max(terrain(p[0], p[2]) + LIFT);
        if y != p[1] {
            p[1] = y;
            moved += 1;
        }
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Vec2;
    use volcano_core::Grid2;
    use volcano_lava::view::surface_temperature;

    use crate::lava::crust::{REFERENCE_TEMPERATURE, incandescent};
    use volcano_lava::Edges;

    #[test]
    fn incandescence_rises_with_temperature_and_shifts_to_yellow() {
        let mut last = incandescent(600.0);
        for t in (650..=2500).step_by(50) {
            let c = incandescent(t as f64);
            assert!(c.red > last.red && c.green > last.green && c.blue > last.blue, "{t} K: {c:?}");
            last = c;
        }
        let (dull, hot) = (incandescent(1000.0), incandescent(1473.0));
        assert!(dull.green / dull.red < 0.15, "1000 K is deep red: {dull:?}");
        assert!(hot.green / hot.red > 0.2, "liquidus is orange: {hot:?}");
        assert!(hot.red > 50.0 * dull.red, "cooling by 470 K dims by orders of magnitude");
        assert!((incandescent(REFERENCE_TEMPERATURE).red - 1.0).abs() < 1e-5);
        assert_eq!(incandescent(f64::NAN), LinearRgba::BLACK);
        assert_eq!(incandescent(-5.0), LinearRgba::BLACK);
    }

    #[test]
    fn crust_darkens_the_surface() {
        let p = LavaParams::default();
        let lum = |c: LinearRgba| c.red + c.green + c.blue;
        let glow = |crust: f64| lum(incandescent(surface_temperature(&p, 1400.0, crust)));
        assert!(glow(0.0) > glow(0.002) && glow(0.002) > glow(0.01) && glow(0.01) > glow(0.03));
        assert!(glow(0.03) < 1e-3 * glow(0.0), "a rigid crust hardly glows");
        assert!(lum(crust_albedo(0.05, p.rigid_crust)) < lum(crust_albedo(0.0, p.rigid_crust)));
        assert!(crust_albedo(0.0, p.rigid_crust).red > crust_albedo(0.0, p.rigid_crust).blue);
        // Debug colours of Figs 5.11–5.13.
        let (r, g, b) = (debug_crust(0.005), debug_crust(0.01), debug_crust(0.03));
        assert!(r.red > r.green && r.red > r.blue);
        assert!(g.green > g.red && g.green > g.blue);
        assert!(b.blue > b.red && b.blue > b.green);
    }

    /// A 4×3 field on a plane tilted along x: one wet cell, one frozen cell.
    fn field() -> FlowField {
        let mut g = Grid2::new(4, 3, 0.5, Vec2::new(10.0, 20.0), 0.0).unwrap();
        for j in 0..3 {
            for i in 0..4 {
                g.set(i, j, 100.0 + i as f64);
            }
        }
        let mut f = FlowField::new(g, Edges::default(), 300.0).unwrap();
        f.place_volume(Vec2::new(10.5, 20.5), 0.0, 0.25, 1400.0).unwrap(); // cell (1, 1): 1 m
        f
    }

    #[test]
    fn mesh_vertices_sit_on_the_lava_and_the_outline_on_the_ground() {
        let f = field();
        let p = LavaParams::default();
        let crust = vec![0.0; 12];
        let mesh = surface_mesh(&f, &crust, &p, LavaRenderMode::Lit);
        // 12 cells, 4 quad centres, 8 outline vertices (4 on the cell edges, 4 to the centres).
        assert_eq!(mesh.count_vertices(), 24);
        let pos = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        // Cell (1, 1) = vertex 5: x = 10.5, z = 20.5, y = ground 101 + lava 1 + lift.
        assert_eq!((pos[5][0], pos[5][2]), (10.5, 20.5));
        assert!((pos[5][1] - (102.0 + LIFT)).abs() < 1e-4, "{:?}", pos[5]);
        // Two clipped triangles in each of the 4 quads around vertex 5; every other vertex
        // they use is on the outline, on the ground (100 m + 2 m per metre of x) + lift.
        let Some(Indices::U32(idx)) = mesh.indices() else { panic!("u32 indices") };
        assert_eq!(idx.len(), 24);
        assert!(idx.chunks(3).all(|t| t.contains(&5)));
        for &v in idx.iter().filter(|&&v| v != 5) {
            let [x, y, _] = pos[v as usize];
            assert!(v >= 12, "a dry cell centre is drawn: {v}");
            assert!((y - (100.0 + 2.0 * (x - 10.0) + LIFT)).abs() < 1e-4, "{:?}", pos[v as usize]);
            // Inside the four quads, between the cell centre and its neighbours.
            assert!((x - 10.5).abs() < 0.5 && (pos[v as usize][2] - 20.5).abs() < 0.5);
        }
        // Detail UVs and tangents for the normal map.
        assert!(mesh.attribute(Mesh::ATTRIBUTE_UV_1).is_some());
        assert!(mesh.attribute(Mesh::ATTRIBUTE_TANGENT).is_some());
        // Empty field: no triangles.
        let empty = FlowField::flat(4, 3, 0.5).unwrap();
        let m = surface_mesh(&empty, &crust, &p, LavaRenderMode::Lit);
        assert_eq!(m.indices().map(|i| i.len()), Some(0));
    }

    #[test]
    fn lava_against_a_wall_stays_level() {
        // Flat ground at 100 m with a 5 m wall in column 2; 1 m of lava in cell (1, 1).
        let mut g = Grid2::new(4, 3, 0.5, Vec2::ZERO, 0.0).unwrap();
        for j in 0..3 {
            for i in 0..4 {
                g.set(i, j, if i == 2 { 105.0 } else { 100.0 });
            }
        }
        let mut f = FlowField::new(g, Edges::default(), 300.0).unwrap();
        f.place_volume(Vec2::new(0.5, 0.5), 0.0, 0.25, 1400.0).unwrap();
        let mesh = surface_mesh(&f, &[0.0; 12], &LavaParams::default(), LavaRenderMode::Lit);
        let pos = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        let Some(Indices::U32(idx)) = mesh.indices() else { panic!("u32 indices") };
        assert!(!idx.is_empty());
        for &v in idx {
            assert!(pos[v as usize][1] <= 101.0 + LIFT + 1e-4, "climbs the wall: {:?}", pos[v as usize]);
        }
    }

    #[test]
    fn the_terrain_lifts_the_surface() {
        let f = field();
        let mut mesh = surface_mesh(&f, &[0.0; 12], &LavaParams::default(), LavaRenderMode::Lit);
        let moved = keep_over_terrain(&mut mesh, |_, _| 101.5);
        let pos = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        assert!(moved > 0 && pos.iter().all(|p| p[1] >= 101.5 + LIFT - 1e-4));
        assert!((pos[5][1] - (102.0 + LIFT)).abs() < 1e-4, "the lava above it stays");
    }
}
