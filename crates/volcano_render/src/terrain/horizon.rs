//! A world without edges: [`TerrainHorizon`] on a [`Terrain`] entity adds a far ring of coarse
//! ground around its mesh, so the terrain's square edge is not the horizon of every shot.
//!
//! The ring's inner loop is the terrain mesh's own border vertices (same positions, normals
//! and colours: no gap, no seam). Further rings scale the border loop outward about the
//! terrain's centre, spaced quadratically (fine near the terrain, kilometres apart far out),
//! out to [`TerrainHorizon::width`] beyond the edge. Each vertex's height blends from the border
//! heights it extends to a base level over [`TerrainHorizon::blend`], plus low-frequency hills;
//! ground that ends below the sea level is drawn as sea, and sea at the border stays sea. Colours follow the land-cover rules of
//! the terrain (`cover`), with the border's class carried outward. Distance fog (the gradient
//! sky's, or the game's own) then fades the ring into the horizon.
//!
//! What a ring carries outward (border heights, sea or land, colours) is averaged along the
//! ring over a window as wide as the ring is far from the edge (`loop_mean`): carried
//! vertex by vertex, each border vertex's relief and land-cover class would run out as a
//! straight radial streak, tens of kilometres long, which every camera outside the terrain
//! would see converging on the volcano. Opt-in: nothing is added to
//! a terrain without the component (a game that draws its own surroundings leaves it off).

use bevy::asset::RenderAssetUsages;
use bevy::color::ColorToComponents;
use bevy::light::NotShadowCaster;
use bevy::mesh::{Indices, Mesh, Mesh3d, PrimitiveTopology};
use bevy::pbr::MeshMaterial3d;
use bevy::prelude::*;
use volcano_core::{LandCover, NodeRegion, Terrain, TerrainChanged};

use super::cover::{GroundSample, ground_color, smoothstep, value_noise};
use super::{MAX_VERTICES_PER_SIDE, MeshSamples, TerrainAssets, UnrenderedTerrain, stride_for};

/// On a [`Terrain`] entity: draw a far ring of ground around its mesh (see the module docs).
/// Edits rebuild the ring; removing the component removes it.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct TerrainHorizon {
    /// How far the ring reaches beyond the terrain's edge, metres (> 0).
    pub width: f32,
    /// Distance beyond the edge over which the border heights blend to the base level,
    /// metres (> 0).
    pub blend: f32,
    /// Altitude of the far land, metres; `None`: the median height of the terrain's border.
    pub base_altitude: Option<f32>,
    /// Amplitude of the far land's rolling hills, metres (≥ 0; wavelengths 3.5 and 9 km).
    pub hills: f32,
    /// Rings of vertices from the edge outward (2..=[`TerrainHorizon::MAX_RINGS`]).
    pub rings: u32,
}

impl Default for TerrainHorizon {
    /// 110 km of ground beyond the edge (past where the default fog has hidden it from a camera
    /// over the terrain), blended over 12 km, 120 m hills, 32 rings.
    fn default() -> Self {
        Self { width: 110_000.0, blend: 12_000.0, base_altitude: None, hills: 120.0, rings: 32 }
    }
}

/// An invalid [`TerrainHorizon`] field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("TerrainHorizon.{field} = {value}: expected {expected}")]
pub struct HorizonError {
    /// The field.
    pub field: &'static str,
    /// Its value.
    pub value: f32,
    /// What it should be.
    pub expected: &'static str,
}

impl TerrainHorizon {
    /// Most rings a ring mesh may have.
    pub const MAX_RINGS: u32 = 256;

    /// Checks every field.
    pub fn validate(&self) -> Result<(), HorizonError> {
        let bad = |field, value, expected| Err(HorizonError { field, value, expected });
        if !(self.width.is_finite() && self.width > 0.0) {
            return bad("width", self.width, "a finite length > 0 m");
        }
        if !(self.blend.is_finite() && self.blend > 0.0) {
            return bad("blend", self.blend, "a finite length > 0 m");
        }
        if !(self.hills.is_finite() && self.hills >= 0.0) {
            return bad("hills", self.hills, "a finite height ≥ 0 m");
        }
        if let Some(b) = self.base_altitude
            && !b.is_finite()
        {
            return bad("base_altitude", b, "a finite altitude");
        }
        if !(2..=Self::MAX_RINGS).contains(&self.rings) {
            return bad("rings", self.rings as f32, "2..=256");
        }
        Ok(())
    }
}

/// Marks the mesh child that draws a terrain's [`TerrainHorizon`].
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct TerrainHorizonMesh;

/// Mesh samples `(a, b)` around the border of an `na × nb` sample grid, each once, in the
/// order (z min edge, x increasing), (x max, z increasing), (z max, x decreasing), (x min, z
/// decreasing).
fn border_loop(na: usize, nb: usize) -> Vec<(usize, usize)> {
    let mut v: Vec<(usize, usize)> = (0..na).map(|a| (a, 0)).collect();
    v.extend((1..nb).map(|b| (na - 1, b)));
    v.extend((0..na - 1).rev().map(|a| (a, nb - 1)));
    v.extend((1..nb - 1).rev().map(|b| (0, b)));
    v
}

/// The ring mesh of `horizon` around `terrain`'s mesh built with `stride`, in world metres.
/// Vertices: the border loop of that mesh (`2·(na + nb) − 4` samples) times `rings + 1`.
pub fn horizon_mesh(
    terrain: &Terrain,
    horizon: &TerrainHorizon,
    stride: usize,
) -> Result<Mesh, HorizonError> {
    horizon.validate()?;
    let samples = MeshSamples::new(terrain, stride);
    let (na, nb) = (samples.xs.len(), samples.ys.len());
    let border = border_loop(na, nb);
    let inner: Vec<([f32; 3], [f32; 3], [f32; 4])> =
        border.iter().map(|&(a, b)| samples.vertex(a, b)).collect();
    // The sea continues as sea; snow gives way to bare ground.
    let covers: Vec<LandCover> = border
        .iter()
        .map(|&(a, b)| match terrain.cover().get(samples.xs[a], samples.ys[b]) {
            LandCover::Snow => LandCover::Ground,
            c => c,
        })
        .collect();
    let (lo, hi) = (Vec2::new(inner[0].0[0], inner[0].0[2]), {
        let p = samples.vertex(na - 1, nb - 1).0;
        Vec2::new(p[0], p[2])
    });
    let centre = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).max(Vec2::splat(1.0));
    let base = horizon.base_altitude.unwrap_or_else(|| {
        let mut h: Vec<f32> = inner.iter().map(|v| v.0[1]).collect();
        h.sort_by(f32::total_cmp);
        h[h.len() / 2]
    });
    let sea = terrain.sea_level();
    let (p_len, rings) = (border.len(), horizon.rings as usize);
    // Outward distance of ring k along the axes: quadratic spacing.
    let distance = |k: usize| horizon.width * (k.min(rings) as f32 / rings as f32).powi(2);
    // Mean spacing of the border loop, and ring k's window along the ring in loop vertices:
    // as wide as the ring is far from the edge.
    let perimeter: f32 = (0..p_len)
        .map(|e| {
            let (a, b) = (inner[e].0, inner[(e + 1) % p_len].0);
            Vec2::new(a[0] - b[0], a[2] - b[2]).length()
        })
        .sum();
    let spacing_along = (perimeter / p_len as f32).max(1e-3);
    let window = |k: usize| (distance(k) / spacing_along).round() as usize;
    // What the border carries outward: sea or land, and its heights (the sea at the sea level).
    let wet: Vec<[f32; 1]> = covers.iter().map(|c| [f32::from(u8::from(*c == LandCover::Water))]).collect();
    let border_heights: Vec<[f32; 1]> =
        inner.iter().zip(&covers).map(|(v, c)| [if *c == LandCover::Water { sea } else { v.0[1] }]).collect();

    let mut positions = Vec::with_capacity(p_len * (rings + 1));
    let mut water = Vec::with_capacity(p_len * (rings + 1));
    positions.extend(inner.iter().map(|v| v.0));
    water.extend(border.iter().map(|_| false));
    for k in 1..=rings {
        let d = distance(k);
        let scale = Vec2::new(1.0 + d / half.x, 1.0 + d / half.y);
        let (wet_k, heights_k) =
            (loop_mean(&wet, |_| true, window(k)), loop_mean(&border_heights, |_| true, window(k)));
        for (e, v) in inner.iter().enumerate() {
            let p = centre + (Vec2::new(v.0[0], v.0[2]) - centre) * scale;
            if wet_k[e][0] > 0.5 {
                water.push(true);
                positions.push([p.x, sea, p.y]);
                continue;
            }
            let beyond = ((p - centre).abs() - half).max(Vec2::ZERO).length();
            let t = smoothstep(0.0, horizon.blend, beyond);
            let hills = 0.6 * value_noise(p, 9_000.0, 11) + 0.4 * value_noise(p, 3_500.0, 12);
            let h0 = heights_k[e][0];
            let h = h0 + (base - h0) * t + horizon.hills * 2.0 * (hills - 0.5) * t;
            water.push(h < sea);
            positions.push([p.x, h.max(sea), p.y]);
        }
    }

    let mut indices = Vec::with_capacity(rings * p_len * 6);
    for k in 0..rings {
        for e in 0..p_len {
            let e1 = (e + 1) % p_len;
            let (i0, i1) = ((k * p_len + e) as u32, (k * p_len + e1) as u32);
            let (o0, o1) = (i0 + p_len as u32, i1 + p_len as u32);
            // Counter-clockwise seen from above for this loop order.
            indices.extend_from_slice(&[i0, i1, o0, i1, o1, o0]);
        }
    }

    // Area-weighted face normals; the inner loop keeps the terrain mesh's own.
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(positions[i as usize]));
        let n = (b - a).cross(c - a);
        for &i in t {
            normals[i as usize] += n;
        }
    }
    let mut normal_out: Vec<[f32; 3]> = normals.iter().map(|n| n.normalize_or(Vec3::Y).to_array()).collect();
    let relief = samples.relief();
    // Radial distance between ring k and its outer neighbour (the coarser of the two spacings).
    let spacing: Vec<f32> = (0..=rings)
        .map(|k| (distance(k + 1) - distance(k)).max(distance(k) - distance(k.saturating_sub(1))))
        .collect();
    let mut colors = Vec::with_capacity(positions.len());
    for (v, p) in positions.iter().enumerate() {
        let e = v % p_len;
        if v < p_len {
            normal_out[v] = inner[v].1;
            colors.push(inner[v].2);
            continue;
        }
        let sample = GroundSample {
            cover: if water[v] { LandCover::Water } else { covers[e] },
            position: Vec2::new(p[0], p[2]),
            altitude: p[1],
            normal: Vec3::from(normal_out[v]),
            footprint: spacing[v / p_len],
        };
        colors.push(ground_color(sample, relief).to_f32_array());
    }
    // Each ring's colours averaged along it, sea and land apart (see the module docs).
    for k in 1..=rings {
        let ring = k * p_len..(k + 1) * p_len;
        let (c, wet) = (&colors[ring.clone()], &water[ring.clone()]);
        let land = loop_mean(c, |e| !wet[e], window(k));
        let open_sea = loop_mean(c, |e| wet[e], window(k));
        for (e, v) in ring.enumerate() {
            colors[v] = if water[v] { open_sea[e] } else { land[e] };
        }
    }
    let uvs: Vec<[f32; 2]> = (0..positions.len())
        .map(|v| [(v % p_len) as f32 / p_len as f32, (v / p_len) as f32 / rings as f32])
        .collect();
    Ok(Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::RENDER_WORLD)
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normal_out)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, colors)
        .with_inserted_indices(Indices::U32(indices)))
}

/// Mean of a closed loop's values over the `2w + 1` neighbours around each (the whole loop when
/// the window covers it), counting only those `keep` selects; a value with none kept in its
/// window stays as it is. Prefix sums in f64, so the cost does not grow with `w`. (A circular
/// box filter: a few lines, not worth a crate.)
fn loop_mean<const N: usize>(values: &[[f32; N]], keep: impl Fn(usize) -> bool, w: usize) -> Vec<[f32; N]> {
    let n = values.len();
    if n == 0 || w == 0 {
        return values.to_vec();
    }
    // Wider than the loop is the whole loop (and `2w + 1` cannot overflow).
    let w = w.min(n);
    // Over the loop three times, so every window is one contiguous range.
    let mut sums = vec![([0f64; N], 0u32); 3 * n + 1];
    for i in 0..3 * n {
        let (mut s, mut m) = sums[i];
        if keep(i % n) {
            for (acc, v) in s.iter_mut().zip(&values[i % n]) {
                *acc += *v as f64;
            }
            m += 1;
        }
        sums[i + 1] = (s, m);
    }
    // A window as long as the loop or longer: the loop's mean everywhere.
    let range = |i: usize| if 2 * w + 1 >= n { (n, 2 * n) } else { (i + n - w, i + n + w + 1) };
    (0..n)
        .map(|i| {
            let (a, b) = range(i);
            let ((hi, m_hi), (lo, m_lo)) = (sums[b], sums[a]);
            let m = m_hi - m_lo;
            if m == 0 {
                return values[i];
            }
            std::array::from_fn(|c| ((hi[c] - lo[c]) / m as f64) as f32)
        })
        .collect()
}

/// Whether a change over `region` can move the border vertices of a mesh built with `stride`
/// (their heights, or their normals, which read one mesh sample inward).
fn touches_border(terrain: &Terrain, region: NodeRegion, stride: usize) -> bool {
    let (nx, ny) = (terrain.heights().nx(), terrain.heights().ny());
    let m = 2 * stride.max(1);
    region.i0 <= m || region.j0 <= m || region.i0 + region.ni + m >= nx || region.j0 + region.nj + m >= ny
}

/// What [`build_horizons`] reads of a terrain.
type HorizonTerrain =
    (Entity, Ref<'static, Terrain>, Ref<'static, TerrainHorizon>, Option<&'static Children>);

/// Builds or replaces the ring child of every terrain whose [`TerrainHorizon`] or heights
/// changed (a [`TerrainChanged`] near the border counts). An invalid horizon is logged and
/// drawn without a ring.
pub(super) fn build_horizons(
    mut commands: Commands,
    mut changes: MessageReader<TerrainChanged>,
    terrains: Query<HorizonTerrain, Without<UnrenderedTerrain>>,
    rings: Query<&Mesh3d, With<TerrainHorizonMesh>>,
    mut meshes: ResMut<Assets<Mesh>>,
    assets: Option<Res<TerrainAssets>>,
) {
    let Some(assets) = assets else { return };
    let mut edited: Vec<Entity> = Vec::new();
    for change in changes.read() {
        if let Ok((_, terrain, ..)) = terrains.get(change.terrain) {
            let h = terrain.heights();
            if touches_border(&terrain, change.region, stride_for(h.nx().max(h.ny()), MAX_VERTICES_PER_SIDE))
            {
                edited.push(change.terrain);
            }
        }
    }
    for (entity, terrain, horizon, children) in &terrains {
        if !(terrain.is_changed() || horizon.is_changed() || edited.contains(&entity)) {
            continue;
        }
        let existing = children.and_then(|c| c.iter().find(|c| rings.contains(*c)));
        let h = terrain.heights();
        let stride = stride_for(h.nx().max(h.ny()), MAX_VERTICES_PER_SIDE);
        let mesh = match horizon_mesh(&terrain, &horizon, stride) {
            Ok(m) => m,
            Err(e) => {
                warn!("{e}; no far ring drawn for terrain {entity}");
                if let Some(child) = existing {
                    commands.entity(child).despawn();
                }
                continue;
            }
        };
        if let Some(child) = existing
            && let Ok(handle) = rings.get(child)
            && meshes.insert(handle.id(), mesh.clone()).is_ok()
        {
            continue;
        }
        commands.entity(entity).insert_if_new((Transform::IDENTITY, Visibility::default()));
        commands.spawn((
            Name::new("Terrain horizon"),
            TerrainHorizonMesh,
            Mesh3d(meshes.add(mesh)),
            MeshMaterial3d(assets.terrain_material.clone()),
            // Kilometre-sized far triangles add nothing to the shadow maps but cost.
            NotShadowCaster,
            Transform::IDENTITY,
            ChildOf(entity),
        ));
    }
}

/// Removes the ring of terrains that lost their [`TerrainHorizon`].
pub(super) fn drop_horizons(
    mut commands: Commands,
    mut removed: RemovedComponents<TerrainHorizon>,
    children: Query<&Children>,
    rings: Query<(), With<TerrainHorizonMesh>>,
) {
    for entity in removed.read() {
        for child in children.get(entity).into_iter().flatten() {
            if rings.contains(*child) {
                commands.entity(*child).despawn();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::terrain::terrain_mesh;
    use volcano_core::StratovolcanoParams;

    fn volcano(resolution: u32) -> Terrain {
        StratovolcanoParams { resolution, cell: 300.0, ..Default::default() }.generate().unwrap()
    }

    fn positions(mesh: &Mesh) -> Vec<[f32; 3]> {
        mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap().to_vec()
    }

    /// The ring's inner loop is exactly the terrain mesh's border (heights included): no gap.
    #[test]
    fn the_ring_starts_on_the_terrain_border() {
        let terrain = volcano(65);
        for cap in [65, 33] {
            let (mesh, stride) = terrain_mesh(&terrain, cap);
            let ring = horizon_mesh(&terrain, &TerrainHorizon::default(), stride).unwrap();
            let (tp, rp) = (positions(&mesh), positions(&ring));
            let n = if stride == 1 { 65 } else { 33 };
            let border = border_loop(n, n);
            assert_eq!(border.len(), 4 * n - 4);
            for (e, &(a, b)) in border.iter().enumerate() {
                assert_eq!(rp[e], tp[b * n + a], "border vertex {e} at ({a}, {b}), stride {stride}");
            }
            // Every border vertex of the terrain mesh is on the loop.
            let on_edge = tp.iter().enumerate().filter(|(v, _)| {
                let (a, b) = (v % n, v / n);
                a == 0 || b == 0 || a == n - 1 || b == n - 1
            });
            assert_eq!(on_edge.count(), border.len());
        }
    }

    #[test]
    fn the_ring_reaches_out_faces_up_and_blends_to_the_base() {
        let terrain = volcano(33);
        let horizon =
            TerrainHorizon { width: 50_000.0, hills: 0.0, base_altitude: Some(150.0), rings: 8, ..default() };
        let ring = horizon_mesh(&terrain, &horizon, 1).unwrap();
        let p = positions(&ring);
        let p_len = 4 * 33 - 4;
        assert_eq!(p.len(), p_len * 9, "vertex count");
        let half = 0.5 * 32.0 * 300.0;
        for v in &p[8 * p_len..] {
            let beyond = (v[0].abs() - half).max(v[2].abs() - half);
            assert!((beyond - 50_000.0).abs() < 1.0, "outer ring {beyond} m beyond the edge");
            assert!((v[1] - 150.0).abs() < 1e-3, "outer ring at {} m, not the base", v[1]);
        }
        let Some(Indices::U32(idx)) = ring.indices() else { panic!("u32 indices") };
        assert_eq!(idx.len(), 8 * p_len * 6);
        for t in idx.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(p[i as usize]));
            assert!((b - a).cross(c - a).y > 0.0, "a triangle faces down");
        }
    }

    /// Hills vary the far land; below the sea it is drawn flat at the sea level, as water.
    #[test]
    fn hills_and_sea() {
        let terrain = volcano(33);
        let hilly = TerrainHorizon { hills: 300.0, base_altitude: Some(1000.0), rings: 16, ..default() };
        let p = positions(&horizon_mesh(&terrain, &hilly, 1).unwrap());
        let far: Vec<f32> = p[12 * 128..].iter().map(|v| v[1]).collect();
        let (lo, hi) = far.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &h| (a.min(h), b.max(h)));
        assert!(hi - lo > 100.0 && lo > 650.0 && hi < 1350.0, "far land {lo}..{hi} m");
        let sunk = TerrainHorizon { hills: 0.0, base_altitude: Some(-500.0), ..default() };
        let mesh = horizon_mesh(&terrain, &sunk, 1).unwrap();
        let p = positions(&mesh);
        let outer = p.last().unwrap();
        assert_eq!(outer[1], terrain.sea_level());
        let Some(bevy::mesh::VertexAttributeValues::Float32x4(c)) = mesh.attribute(Mesh::ATTRIBUTE_COLOR)
        else {
            panic!("colours")
        };
        let c = c.last().unwrap();
        assert!(c[2] > c[0] && c[2] > c[1], "sea is blue: {c:?}");
    }

    /// Mean |difference| between neighbours along ring `k` (a loop of `p_len` values).
    fn along(values: &[f32], k: usize, p_len: usize) -> f32 {
        let ring = &values[k * p_len..(k + 1) * p_len];
        (0..p_len).map(|e| (ring[(e + 1) % p_len] - ring[e]).abs()).sum::<f32>() / p_len as f32
    }

    /// Nothing on the border runs out as a radial streak: 4 and 7 km beyond the edge,
    /// neighbouring vertices of a ring differ in height and in colour by a small part of what
    /// neighbours on the border do. Carried vertex by vertex, ring 6 would keep 0.74 of the
    /// border's height differences and 1.03 of its luminance differences; averaged along the
    /// ring, it keeps 0.13 and 0.04.
    #[test]
    fn nothing_runs_out_as_a_streak() {
        let hilly = StratovolcanoParams {
            resolution: 129,
            cell: 150.0,
            hills_amplitude: 250.0,
            ..Default::default()
        }
        .generate()
        .unwrap();
        // Land cover in patches of 3 × 3 nodes, vegetation and bare ground by turns, so the
        // border changes class every 450 m.
        let mut cover = hilly.cover().clone();
        for j in 0..129 {
            for i in 0..129 {
                let veg = (i / 3 + j / 3) % 2 == 0;
                cover.set(i, j, if veg { LandCover::Vegetation } else { LandCover::Ground });
            }
        }
        let terrain = Terrain::new(hilly.heights().clone(), cover, hilly.sea_level()).unwrap();
        let mesh = horizon_mesh(&terrain, &TerrainHorizon::default(), 1).unwrap();
        let p_len = 4 * 129 - 4;
        let heights: Vec<f32> = positions(&mesh).iter().map(|v| v[1]).collect();
        let Some(bevy::mesh::VertexAttributeValues::Float32x4(c)) = mesh.attribute(Mesh::ATTRIBUTE_COLOR)
        else {
            panic!("colours")
        };
        let luminance: Vec<f32> = c.iter().map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]).collect();
        let (h0, l0) = (along(&heights, 0, p_len), along(&luminance, 0, p_len));
        assert!(h0 > 1.0 && l0 > 1e-5, "the border has relief ({h0} m) and colour changes ({l0})");
        // Rings 6 and 8 of 32 over 110 km: 3.9 and 6.9 km beyond the edge.
        for k in [6, 8] {
            let (h, l) = (along(&heights, k, p_len), along(&luminance, k, p_len));
            assert!(h < 0.2 * h0, "ring {k}: neighbours {h} m apart in height, the border's {h0} m");
            assert!(l < 0.2 * l0, "ring {k}: neighbours {l} apart in luminance, the border's {l0}");
        }
    }

    /// Averaging along a loop: a window wraps round, counts only what it keeps, and a window
    /// wider than the loop gives the loop's mean.
    #[test]
    fn loop_mean_wraps_and_keeps() {
        let v: Vec<[f32; 1]> = (0..6).map(|i| [i as f32]).collect();
        let m = loop_mean(&v, |_| true, 1);
        assert_eq!(m[0][0], (5.0 + 0.0 + 1.0) / 3.0);
        assert_eq!(m[3][0], 3.0);
        let wide = loop_mean(&v, |_| true, 100);
        assert!(wide.iter().all(|x| (x[0] - 2.5).abs() < 1e-6), "{wide:?}");
        let even = loop_mean(&v, |i| i % 2 == 0, 1);
        assert_eq!((even[1][0], even[0][0]), (1.0, 0.0));
        assert_eq!(loop_mean(&v, |_| false, 2), v);
        assert_eq!(loop_mean(&v, |_| true, 0), v);
        assert_eq!(loop_mean(&v, |_| true, usize::MAX), wide);
    }

    /// An island's sea stays sea out to the ring's edge, whatever the hills.
    #[test]
    fn sea_at_the_border_stays_sea() {
        let island =
            StratovolcanoParams { resolution: 33, cell: 300.0, sea_level: 1000.0, ..Default::default() }
                .generate()
                .unwrap();
        let ring = horizon_mesh(&island, &TerrainHorizon { hills: 2_000.0, ..default() }, 1).unwrap();
        let p = positions(&ring);
        assert!(p[128..].iter().all(|v| v[1] == 1000.0), "land rose out of the sea");
    }

    #[test]
    fn invalid_horizons_are_errors() {
        let terrain = volcano(33);
        for (h, field) in [
            (TerrainHorizon { width: f32::NAN, ..default() }, "width"),
            (TerrainHorizon { blend: 0.0, ..default() }, "blend"),
            (TerrainHorizon { hills: -1.0, ..default() }, "hills"),
            (TerrainHorizon { base_altitude: Some(f32::INFINITY), ..default() }, "base_altitude"),
            (TerrainHorizon { rings: 1, ..default() }, "rings"),
            (TerrainHorizon { rings: 10_000, ..default() }, "rings"),
        ] {
            assert_eq!(horizon_mesh(&terrain, &h, 1).unwrap_err().field, field);
        }
    }
}
