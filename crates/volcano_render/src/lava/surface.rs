//! Pure parts of the lava look: the incandescent colour of a surface temperature, the colour of
//! the crust, and the surface mesh and emissive texels of a lava field. No ECS here, so all of
//! it is unit-tested.

use bevy::asset::RenderAssetUsages;
use bevy::color::{ColorToComponents, ColorToPacked, LinearRgba, Mix, Srgba};
use bevy::math::Vec3;
use bevy::mesh::{Indices, Mesh, PrimitiveTopology, VertexAttributeValues};
use volcano_lava::view::{crust_colour, surface_temperature};
use volcano_lava::{FlowField, LavaParams};

use super::LavaRenderMode;

/// Second radiation constant `hc/k` (m·K) of Planck's law.
const C2: f64 = 1.438_777e-2;
/// Wavelengths (m) standing for the red, green and blue channels.
const WAVELENGTHS: [f64; 3] = [610e-9, 550e-9, 465e-9];
/// Temperature (K) whose red radiance maps to 1.0 in [`incandescent`]: hotter saturates.
pub const REFERENCE_TEMPERATURE: f64 = 1500.0;
/// Lava lifted this much (m) above the ground it covers, so a thin sheet does not z-fight the
/// terrain mesh.
pub const LIFT: f32 = 0.01;
/// Vertices of uncovered cells sink this far (m) below the ground: the edge quads of the lava
/// dive under the terrain, which then draws the flow's outline.
pub const SINK: f32 = 0.1;

/// Relative spectral radiance of a black body at temperature `t` (K) in the red, green and
/// blue channels (Planck's law at [`WAVELENGTHS`]), scaled so the red channel of a body at
/// [`REFERENCE_TEMPERATURE`] is 1. Linear RGB; 0 at or below 0 K or for non-finite input.
/// Each channel rises monotonically with temperature, and the colour shifts from deep red
/// (1000 K) to orange (1400 K) to yellow-white (well above 2000 K).
pub fn incandescent(t: f64) -> LinearRgba {
    if !(t.is_finite() && t > 0.0) {
        return LinearRgba::BLACK;
    }
    let radiance = |lambda: f64, temp: f64| 1.0 / (lambda.powi(5) * ((C2 / (lambda * temp)).exp_m1()));
    let reference = radiance(WAVELENGTHS[0], REFERENCE_TEMPERATURE);
    let [r, g, b] = WAVELENGTHS.map(|l| (radiance(l, t) / reference) as f32);
    LinearRgba::rgb(r, g, b)
}

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

/// Mesh of the lava surface of `flow`: one vertex per cell centre (world `x`, altitude, world
/// `z`; `nx · ny` vertices in row order, cell `(i, j)` at `j · nx + i`), at the lava surface
/// (ground + frozen + liquid lava, lifted by [`LIFT`]) where the cell holds liquid lava thicker
/// than `min_thickness` or frozen lava, and [`SINK`] below the ground elsewhere. Triangles only
/// for quads with at least one covered corner, so an empty field has no indices. Vertex
/// colours: the albedo for [`LavaRenderMode::Lit`], the debug colours otherwise. UVs address
/// the cell centres of an `nx × ny` texture (see [`emissive_texels`]).
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
    let mut positions = Vec::with_capacity(n);
    let mut colors = Vec::with_capacity(n);
    let mut uvs = Vec::with_capacity(n);
    let mut covered = Vec::with_capacity(n);
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            let p = h.position(i, j);
            let c = cover(k);
            let y = match c {
                Cover::Lava => (ground[k] + h.data()[k]) as f32 + LIFT,
                Cover::Frozen => ground[k] as f32 + LIFT,
                Cover::Dry => ground[k] as f32 - SINK,
            };
            positions.push([p.x, y, p.y]);
            uvs.push([(i as f32 + 0.5) / nx as f32, (j as f32 + 0.5) / ny as f32]);
            let crust_k = crust.get(k).copied().unwrap_or(0.0);
            let colour = match (mode, c) {
                // Dry vertices only show in the margin quads, dipping under the ground. In the
                // crust view they stay neutral (a red one next to blue crust would blend to a
                // misleading purple where lava ponds against an obstacle).
                (LavaRenderMode::DebugCrust, Cover::Dry) => frozen_albedo(),
                (LavaRenderMode::DebugThickness, Cover::Dry) => heat_ramp(0.0),
                (LavaRenderMode::Lit, Cover::Dry) => crust_albedo(0.0, params.rigid_crust),
                (LavaRenderMode::DebugCrust, Cover::Frozen) => LinearRgba::from(Srgba::rgb_u8(150, 150, 150)),
                (_, Cover::Frozen) => frozen_albedo(),
                (LavaRenderMode::DebugCrust, Cover::Lava) => debug_crust(crust_k),
                (LavaRenderMode::DebugThickness, Cover::Lava) => heat_ramp(h.data()[k] / hmax),
                (LavaRenderMode::Lit, Cover::Lava) => crust_albedo(crust_k, params.rigid_crust),
            };
            colors.push(colour.to_f32_array());
            covered.push(c != Cover::Dry);
        }
    }
    // Smooth normals from central differences of the vertex heights.
    let dx = flow.cell() as f32;
    let mut normals = Vec::with_capacity(n);
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
    let mut indices = Vec::new();
    for j in 0..ny.saturating_sub(1) {
        for i in 0..nx.saturating_sub(1) {
            let v00 = j * nx + i;
            let (v10, v01, v11) = (v00 + 1, v00 + nx, v00 + nx + 1);
            if covered[v00] || covered[v10] || covered[v01] || covered[v11] {
                // Counter-clockwise seen from above (+y), as the terrain mesh.
                indices.extend([v00, v01, v10, v10, v01, v11].map(|v| v as u32));
            }
        }
    }
    Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::RENDER_WORLD)
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, colors)
        .with_inserted_indices(Indices::U32(indices))
}

/// Keeps a [`surface_mesh`] of `flow` on the right side of the drawn terrain, whose altitude
/// at world `(x, z)` is `terrain(x, z)`: covered vertices at least [`LIFT`] above it, dry ones
/// at least [`SINK`] below. The field's ground is the terrain's bilinear surface, while the
/// terrain mesh is made of triangles; on a 40 m grid the two differ by decimetres, enough to
/// hide a lava sheet. Returns how many vertices moved.
pub fn keep_over_terrain(
    mesh: &mut Mesh,
    flow: &FlowField,
    params: &LavaParams,
    terrain: impl Fn(f32, f32) -> f32,
) -> usize {
    let (h, solid) = (flow.thickness().data(), flow.solid().data());
    let Some(VertexAttributeValues::Float32x3(pos)) = mesh.attribute_mut(Mesh::ATTRIBUTE_POSITION) else {
        return 0;
    };
    if pos.len() != h.len() {
        return 0;
    }
    let mut moved = 0;
    for (k, p) in pos.iter_mut().enumerate() {
        let ground = terrain(p[0], p[2]);
        let covered = h[k] > params.min_thickness || solid[k] > params.min_thickness;
        let y = if covered { p[1].max(ground + LIFT) } else { p[1].min(ground - SINK) };
        if y != p[1] {
            p[1] = y;
            moved += 1;
        }
    }
    moved
}

/// Emissive texels (`Rgba8UnormSrgb`, `nx × ny`, row `j` = cell row `j`) of the lit view: the
/// [`incandescent`] colour of each liquid cell's crust-top temperature
/// ([`surface_temperature`]: the thicker the crust, the cooler and darker the top), black
/// elsewhere. `out` is cleared and refilled.
pub fn emissive_texels(flow: &FlowField, crust: &[f64], params: &LavaParams, out: &mut Vec<u8>) {
    let (h, temp) = (flow.thickness().data(), flow.temperature().data());
    out.clear();
    out.reserve(4 * h.len());
    for k in 0..h.len() {
        let c = if h[k] > params.min_thickness {
            let ts = surface_temperature(params, temp[k], crust.get(k).copied().unwrap_or(0.0));
            incandescent(ts)
        } else {
            LinearRgba::BLACK
        };
        let s = Srgba::from(LinearRgba::rgb(c.red.min(1.0), c.green.min(1.0), c.blue.min(1.0)));
        out.extend_from_slice(&s.to_u8_array());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Vec2;
    use volcano_core::Grid2;
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
    fn mesh_vertices_sit_on_the_lava_and_cover_only_wet_quads() {
        let f = field();
        let p = LavaParams::default();
        let crust = vec![0.0; 12];
        let mesh = surface_mesh(&f, &crust, &p, LavaRenderMode::Lit);
        assert_eq!(mesh.count_vertices(), 12);
        let pos = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        // Cell (1, 1) = vertex 5: x = 10.5, z = 20.5, y = ground 101 + lava 1 + lift.
        assert_eq!((pos[5][0], pos[5][2]), (10.5, 20.5));
        assert!((pos[5][1] - (102.0 + LIFT)).abs() < 1e-4, "{:?}", pos[5]);
        // A dry cell sinks under its ground.
        assert!((pos[0][1] - (100.0 - SINK)).abs() < 1e-4, "{:?}", pos[0]);
        // Quads touching vertex 5: (0,0), (1,0), (0,1), (1,1) → 4 quads, 24 indices.
        let Some(Indices::U32(idx)) = mesh.indices() else { panic!("u32 indices") };
        assert_eq!(idx.len(), 24);
        assert!(idx.chunks(6).all(|q| q.contains(&5)));
        // Empty field: no triangles.
        let empty = FlowField::flat(4, 3, 0.5).unwrap();
        let m = surface_mesh(&empty, &crust, &p, LavaRenderMode::Lit);
        assert_eq!(m.indices().map(|i| i.len()), Some(0));
    }

    #[test]
    fn emissive_texels_glow_only_on_hot_lava() {
        let f = field();
        let p = LavaParams::default();
        let mut tex = Vec::new();
        emissive_texels(&f, &[0.0; 12], &p, &mut tex);
        assert_eq!(tex.len(), 4 * 12);
        assert!(tex[4 * 5] > 120, "hot lava glows red: {:?}", &tex[20..24]);
        assert_eq!(&tex[0..3], &[0, 0, 0], "dry ground does not glow");
        let mut crusted = Vec::new();
        emissive_texels(&f, &[0.03; 12], &p, &mut crusted);
        assert!(crusted[4 * 5] < tex[4 * 5] / 4, "a crust darkens it: {:?}", &crusted[20..24]);
    }
}
