//! The terrain and the lava as glTF meshes (world metres, y up, as glTF itself): the terrain
//! heightfield (decimated to a vertex budget), each lava field's surface over the cells its
//! lava covers with the top of the crust's temperature per vertex (`_TEMPERATURE`, K, the
//! emission a renderer gives it: thesis §5.3's crust over the core), and its fold ropes
//! (§5.4) as line strips along each fold's chain.

use bevy::prelude::*;
use volcano_core::{Boundary, Grid2, Terrain};
use volcano_export::gltf::{LineData, MeshData};
use volcano_lava::view::surface_temperature;
use volcano_lava::{FlowField, FoldSystem, LavaField, LavaState};

/// Linear albedo of the terrain (a dry volcanic grey-brown) and of lava surfaces (basalt; the
/// glow is the temperature's).
const TERRAIN_ALBEDO: [f32; 4] = [0.18, 0.16, 0.14, 1.0];
const LAVA_ALBEDO: [f32; 4] = [0.16, 0.15, 0.14, 1.0];
/// Colour of the fold ropes.
const ROPE_COLOUR: [f32; 4] = [0.1, 0.09, 0.08, 1.0];

/// Unit normals of a heightfield, sample by sample in row order, from its central-difference
/// gradient (one-sided at the edges, [`Grid2::gradient`]).
fn normals(heights: &Grid2<f32>) -> Vec<[f32; 3]> {
    (0..heights.ny())
        .flat_map(|j| (0..heights.nx()).map(move |i| (i, j)))
        .map(|(i, j)| {
            let d = heights.gradient(i, j, Boundary::Clamp);
            Vec3::new(-d.x, 1.0, -d.y).normalize_or(Vec3::Y).to_array()
        })
        .collect()
}

/// Two triangles per quad of samples `(i, j)–(i+1, j+1)` for which `keep(k)` holds at all four
/// corners; counter-clockwise seen from above (+y), glTF's front face.
fn quads(nx: usize, ny: usize, keep: impl Fn(usize) -> bool) -> Vec<u32> {
    let mut idx = Vec::new();
    for j in 0..ny.saturating_sub(1) {
        for i in 0..nx.saturating_sub(1) {
            let (a, b, c, d) = (j * nx + i, j * nx + i + 1, (j + 1) * nx + i, (j + 1) * nx + i + 1);
            if [a, b, c, d].into_iter().all(&keep) {
                idx.extend([a, c, b, b, c, d].map(|v| v as u32));
            }
        }
    }
    idx
}

/// The terrain's heightfield, every `stride`-th sample with `stride` the smallest that keeps
/// each side at most `max_side` samples.
pub fn terrain_mesh(terrain: &Terrain, max_side: usize) -> MeshData {
    let h = terrain.heights();
    let (nx, ny) = (h.nx(), h.ny());
    let stride = nx.max(ny).div_ceil(max_side.max(2)).max(1);
    let (mx, my) = ((nx - 1) / stride + 1, (ny - 1) / stride + 1);
    let mut positions = Vec::with_capacity(mx * my);
    let mut heights = Vec::with_capacity(mx * my);
    for j in 0..my {
        for i in 0..mx {
            let (si, sj) = (i * stride, j * stride);
            let p = h.position(si, sj);
            let y = h.get(si, sj);
            positions.push([p.x, y, p.y]);
            heights.push(y);
        }
    }
    // The sampled heights as a grid of `stride` cells (its dimensions are the terrain's, cut).
    let normals = Grid2::from_vec(mx, my, h.cell() * stride as f64, h.origin(), heights)
        .map_or_else(|_| vec![[0.0, 1.0, 0.0]; mx * my], |g| normals(&g));
    MeshData {
        name: "terrain".into(),
        normals: Some(normals),
        indices: quads(mx, my, |_| true),
        positions,
        colors: None,
        temperature: None,
        emissive: None,
        base_color: TERRAIN_ALBEDO,
    }
}

/// A lava field's surface (ground + frozen + liquid lava at each cell centre) over the quads
/// whose four cells hold more than `min_thickness` of lava, liquid or frozen, with a vertex
/// for each cell those quads use; `None` if no quad does. `_TEMPERATURE` is the top of the crust's ([`surface_temperature`]) where the
/// lava is liquid, the air's where it froze.
pub fn lava_mesh(name: &str, field: &LavaField, state: &LavaState) -> Option<MeshData> {
    let flow = &state.flow;
    let (nx, ny) = (flow.nx(), flow.ny());
    let (h, ground, solid, temp) =
        (flow.thickness(), flow.ground().data(), flow.solid().data(), flow.temperature().data());
    let p = &field.params;
    let covered = |k: usize| h.data()[k].max(0.0) + solid[k].max(0.0) > p.min_thickness;
    let indices = quads(nx, ny, covered);
    if indices.is_empty() {
        return None;
    }
    let surface: Vec<f32> = ground.iter().zip(h.data()).map(|(g, d)| (g + d.max(0.0)) as f32).collect();
    // The lava grid's own dimensions, so a grid of them always builds.
    let Ok(surface) = Grid2::from_vec(nx, ny, flow.cell(), h.origin(), surface) else { return None };
    let all_normals = normals(&surface);
    // Only the cells a covered quad uses become vertices (a flow covers a small part of its
    // grid), renumbered in grid order.
    let mut vertex = vec![u32::MAX; nx * ny];
    for &k in &indices {
        vertex[k as usize] = 0;
    }
    let (mut positions, mut normals_out, mut temperature) = (Vec::new(), Vec::new(), Vec::new());
    for (k, v) in vertex.iter_mut().enumerate() {
        if *v == u32::MAX {
            continue;
        }
        *v = positions.len() as u32;
        let xz = h.position(k % nx, k / nx);
        positions.push([xz.x, surface.data()[k], xz.y]);
        normals_out.push(all_normals[k]);
        let liquid = h.data()[k] > p.min_thickness;
        let crust = state.surface.crust.get(k).copied().unwrap_or(0.0);
        let t = if liquid { surface_temperature(p, temp[k], crust) } else { p.air_temperature };
        temperature.push(t as f32);
    }
    Some(MeshData {
        name: name.into(),
        normals: Some(normals_out),
        indices: indices.iter().map(|&k| vertex[k as usize]).collect(),
        positions,
        colors: None,
        temperature: Some(temperature),
        emissive: None,
        base_color: LAVA_ALBEDO,
    })
}

/// A lava field's fold ropes: each fold's chain as segments between consecutive particles, at
/// the lava surface of the particle's cell plus its offset and roll height, lifted by half its
/// diameter (the rope's axis). `None` without folds.
pub fn fold_lines(name: &str, flow: &FlowField, folds: &FoldSystem) -> Option<LineData> {
    let (h, ground) = (flow.thickness(), flow.ground().data());
    let particles = &folds.particles;
    let mut positions = Vec::with_capacity(particles.len());
    for f in particles {
        let xz = Vec2::new(f.pos.x as f32, f.pos.y as f32);
        let surface = flow.cell_at(xz).map_or(0.0, |(i, j)| {
            let k = j * flow.nx() + i;
            ground[k] + h.data()[k].max(0.0)
        });
        let y = surface + f.offset + f.roll_height + 0.5 * f.thickness;
        positions.push([xz.x, y as f32, xz.y]);
    }
    let n = positions.len() as u32;
    let mut indices = Vec::new();
    for fold in &folds.folds {
        for w in fold.chain.windows(2) {
            if w[0] < n && w[1] < n {
                indices.extend([w[0], w[1]]);
            }
        }
    }
    if indices.is_empty() {
        return None;
    }
    Some(LineData { name: name.into(), positions, indices, color: ROPE_COLOUR })
}

/// Every lava field's surface and ropes, named `lava_N` / `folds_N` in entity order.
pub fn lava_meshes(world: &mut World) -> (Vec<MeshData>, Vec<LineData>) {
    let mut fields: Vec<(Entity, &LavaField, &LavaState)> =
        world.query::<(Entity, &LavaField, &LavaState)>().iter(world).collect();
    fields.sort_by_key(|(e, ..)| *e);
    let (mut meshes, mut lines) = (Vec::new(), Vec::new());
    for (n, (_, field, state)) in fields.iter().enumerate() {
        meshes.extend(lava_mesh(&format!("lava_{n}"), field, state));
        lines.extend(fold_lines(&format!("folds_{n}"), &state.flow, &state.folds));
    }
    (meshes, lines)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quads_face_up_and_skip_uncovered_corners() {
        let idx = quads(3, 3, |k| k != 8);
        assert_eq!(idx.len(), 3 * 6, "the quad touching sample 8 is dropped");
        // Counter-clockwise from above: (a → c → b) has a +y normal for x right, z down-grid.
        let p = |v: u32| Vec3::new((v % 3) as f32, 0.0, (v / 3) as f32);
        let n = (p(idx[1]) - p(idx[0])).cross(p(idx[2]) - p(idx[0]));
        assert!(n.y > 0.0, "{n}");
    }

    /// Two folds over a 1 m sheet on ground at 10 m: one segment per pair of chain neighbours,
    /// each particle at the lava surface plus its offset, roll height and half its diameter.
    #[test]
    fn fold_ropes_follow_their_chains_on_the_surface() {
        use volcano_core::grid::Grid2;
        use volcano_lava::Edges;
        use volcano_lava::view::{Fold, FoldParticle};
        let ground = Grid2::new(8, 8, 1.0, Vec2::ZERO, 10.0).unwrap();
        let mut flow = FlowField::new(ground, Edges::default(), 300.0).unwrap();
        flow.place_volume(Vec2::splat(3.5), 10.0, 64.0, 1_400.0).unwrap();
        let particle = |x: f64, fold: u32| FoldParticle {
            pos: bevy::math::DVec2::new(x, 3.0),
            spring_vel: Default::default(),
            vel: Default::default(),
            tangent: bevy::math::DVec2::Y,
            thickness: 0.2,
            age: 0.0,
            offset: -0.05,
            roll_height: 0.02,
            roll_angle: 0.0,
            fold,
            blocked_by: None,
        };
        let mut folds = FoldSystem::new(0);
        folds.particles =
            vec![particle(1.0, 0), particle(2.0, 0), particle(3.0, 0), particle(5.0, 1), particle(6.0, 1)];
        folds.folds = vec![
            Fold { chain: vec![0, 1, 2], follower: None, first: true },
            Fold { chain: vec![3, 4], follower: None, first: true },
        ];
        let lines = fold_lines("folds_0", &flow, &folds).unwrap();
        assert_eq!(lines.indices, [0, 1, 1, 2, 3, 4]);
        for p in &lines.positions {
            assert!((p[1] - (11.0 - 0.05 + 0.02 + 0.1)).abs() < 1e-5, "{p:?}");
        }
        assert_eq!(lines.positions[4][0], 6.0);
        assert_eq!(lines.positions[4][2], 3.0);
    }

    #[test]
    fn a_slope_tilts_the_normals_downhill() {
        // y = x / 2 on a 4 × 2 grid of 1 m: the normal leans towards −x.
        let y: Vec<f32> = (0..8).map(|k| (k % 4) as f32 * 0.5).collect();
        let n = normals(&Grid2::from_vec(4, 2, 1.0, Vec2::ZERO, y).unwrap());
        assert_eq!(n.len(), 8);
        for v in n {
            assert!((v[0] + 0.5 / 1.25f32.sqrt()).abs() < 1e-6 && v[2] == 0.0, "{v:?}");
        }
    }
}
