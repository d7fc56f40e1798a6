//! The crust's texture: glowing cracks and mottling in the emissive texture (a few texels per
//! cell), and static tileable detail (albedo grain, roughness, bumps) in world space. Pure
//! functions, no ECS.
//!
//! - **Emissive** ([`glow_texels`]): each cell has two colours, the [`incandescent`] colour of
//!   its crust top ([`surface_temperature`] under the whole crust) and that of a crack (under
//!   [`CRACK_DEPTH`] of it). A fixed world-space pattern ([`GlowPattern`]: warped Voronoi plate
//!   edges about [`PLATE`] apart, patchy, plus mottling) mixes the two per texel, so a thin crust
//!   shows a net of hot cracks, a thick one a few dull red lines and a rigid one none, and
//!   fresh lava glows unevenly. Texels are `Rgba16Float` (linear, unclamped).
//! - **Detail** ([`detail_images`]): a tileable grain multiplying the vertex albedo, a
//!   roughness map (glassy to rough) and a normal map of centimetre bumps, all on UV 1
//!   (world metres / [`DETAIL_TILE`]).

use bevy::asset::RenderAssetUsages;
use bevy::color::LinearRgba;
use bevy::image::{Image, ImageAddressMode, ImageSampler, ImageSamplerDescriptor};
use bevy::math::Vec2;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use volcano_lava::view::surface_temperature;
use volcano_lava::{FlowField, LavaParams};

use crate::terrain::{lattice_hash as hash01, smoothstep, value_noise};

/// Fraction of the crust left at the bottom of a crack: its top is that much hotter.
pub const CRACK_DEPTH: f64 = 0.2;
/// Mean spacing (m) of the crust plates whose edges crack.
pub const PLATE: f32 = 0.9;
/// Width (m) of a crack (drawn at least a texel wide).
pub const CRACK_WIDTH: f32 = 0.05;
/// Size (m) of one tile of the detail textures on UV 1.
pub const DETAIL_TILE: f32 = 3.0;
/// Most emissive texels along a side: fields above 128 cells get fewer texels per cell.
pub const MAX_TEXELS: usize = 512;

/// Second radiation constant `hc/k` (m·K) of Planck's law.
const C2: f64 = 1.438_777e-2;
/// Wavelengths (m) standing for the red, green and blue channels.
const WAVELENGTHS: [f64; 3] = [610e-9, 550e-9, 465e-9];
/// Temperature (K) whose red radiance maps to 1.0 in [`incandescent`]: hotter saturates.
pub const REFERENCE_TEMPERATURE: f64 = 1500.0;

/// Relative spectral radiance of a black body at temperature `t` (K) in the red, green and
/// blue channels (Planck's law at `WAVELENGTHS`), scaled so the red channel of a body at
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

/// Emissive texels per cell side for an `nx × ny` field: 4, fewer on large fields (at least 1).
pub fn texels_per_cell(nx: usize, ny: usize) -> usize {
    (MAX_TEXELS / nx.max(ny).max(1)).clamp(1, 4)
}

/// The fixed per-texel pattern of a field's emissive texture: crack coverage (0–1) and
/// mottling (a brightness factor around 1).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GlowPattern {
    /// Texels per cell side.
    pub s: usize,
    /// Texture width (cells × `s`).
    pub width: usize,
    /// Texture height.
    pub height: usize,
    /// Crack coverage of each texel, row-major.
    pub crack: Vec<f32>,
    /// Brightness factor of each texel.
    pub mottle: Vec<f32>,
}

impl GlowPattern {
    /// The pattern of `flow`'s grid: texel centres mapped to world `(x, z)` as the cells are.
    pub fn new(flow: &FlowField) -> Self {
        let (nx, ny) = (flow.nx(), flow.ny());
        let s = texels_per_cell(nx, ny);
        let (width, height) = (nx * s, ny * s);
        let first = flow.thickness().position(0, 0);
        let cell = flow.cell() as f32;
        let texel = cell / s as f32;
        let mut crack = Vec::with_capacity(width * height);
        let mut mottle = Vec::with_capacity(width * height);
        for v in 0..height {
            for u in 0..width {
                let x = (u as f32 + 0.5) / s as f32 - 0.5;
                let y = (v as f32 + 0.5) / s as f32 - 0.5;
                let p = first + Vec2::new(x, y) * cell;
                // Warped, so the plates are not a regular honeycomb.
                let warp = Vec2::new(value_noise(p, 0.7, 77), value_noise(p, 0.7, 78)) - 0.5;
                let d = plate_edge_distance(p + 0.4 * PLATE * warp);
                let half = (0.5 * CRACK_WIDTH * (0.6 + 0.8 * value_noise(p, 1.3, 71))).max(0.5 * texel);
                let cover = ((half - d) / texel + 0.5).clamp(0.0, 1.0);
                // Patchy: some plate edges have not opened.
                let open = smoothstep(0.4, 0.7, value_noise(p, 2.7, 72));
                crack.push(cover * open);
                mottle.push(0.75 + 0.5 * (0.6 * value_noise(p, 0.6, 73) + 0.4 * value_noise(p, 2.1, 74)));
            }
        }
        Self { s, width, height, crack, mottle }
    }

    /// Whether this pattern fits `flow`'s grid.
    pub fn fits(&self, flow: &FlowField) -> bool {
        let s = texels_per_cell(flow.nx(), flow.ny());
        self.s == s && self.width == flow.nx() * s && self.height == flow.ny() * s
    }
}

/// Distance (m) from `p` to the nearest edge of a Voronoi tiling with one jittered site per
/// [`PLATE`]-sized lattice cell.
pub fn plate_edge_distance(p: Vec2) -> f32 {
    let q = p / PLATE;
    let (fx, fz) = (q.x.floor() as i32, q.y.floor() as i32);
    let mut sites = [Vec2::ZERO; 9];
    let mut nearest = (f32::INFINITY, 0);
    for (n, site) in sites.iter_mut().enumerate() {
        let (ix, iz) = (fx + n as i32 % 3 - 1, fz + n as i32 / 3 - 1);
        let jitter = Vec2::new(hash01(ix, iz, 5), hash01(ix, iz, 6));
        *site = (Vec2::new(ix as f32, iz as f32) + 0.1 + 0.8 * jitter) * PLATE;
        let d = site.distance_squared(p);
        if d < nearest.0 {
            nearest = (d, n);
        }
    }
    let c1 = sites[nearest.1];
    sites
        .iter()
        .enumerate()
        .filter(|(n, _)| *n != nearest.1)
        .map(|(_, &c)| {
            let axis = c - c1;
            let len = axis.length();
            if len > 1e-6 { (0.5 * (c1 + c) - p).dot(axis / len) } else { f32::INFINITY }
        })
        .fold(f32::INFINITY, f32::min)
}

/// Emissive texels (`Rgba16Float`, [`GlowPattern`]'s size, row `v` along cell rows) of the lit
/// view; `out` is cleared and refilled. Per cell: the crust-top and crack colours of liquid
/// lava (black elsewhere), spread into dry cells next to lava so the margin keeps its colour up
/// to the outline; per texel: the two interpolated between cell centres and mixed by the
/// pattern.
pub fn glow_texels(
    flow: &FlowField,
    crust: &[f64],
    params: &LavaParams,
    pattern: &GlowPattern,
    out: &mut Vec<u8>,
) {
    let (nx, ny) = (flow.nx(), flow.ny());
    let (h, temp) = (flow.thickness().data(), flow.temperature().data());
    let wet: Vec<bool> = h.iter().map(|&h| h > params.min_thickness).collect();
    let colour = |k: usize, f: f64| {
        let c = crust.get(k).copied().unwrap_or(0.0) * f;
        let c = incandescent(surface_temperature(params, temp[k], c));
        [c.red.min(8.0), c.green.min(8.0), c.blue.min(8.0)]
    };
    let mut skin: Vec<[f32; 3]> =
        (0..h.len()).map(|k| if wet[k] { colour(k, 1.0) } else { [0.0; 3] }).collect();
    let mut crack: Vec<[f32; 3]> =
        (0..h.len()).map(|k| if wet[k] { colour(k, CRACK_DEPTH) } else { [0.0; 3] }).collect();
    dilate(&mut skin, &wet, nx, ny);
    dilate(&mut crack, &wet, nx, ny);
    out.clear();
    out.reserve(8 * pattern.width * pattern.height);
    let s = pattern.s as f32;
    for v in 0..pattern.height {
        let y = ((v as f32 + 0.5) / s - 0.5).clamp(0.0, (ny - 1) as f32);
        let (j0, fy) = (y.floor() as usize, y.fract());
        let j1 = (j0 + 1).min(ny - 1);
        for u in 0..pattern.width {
            let x = ((u as f32 + 0.5) / s - 0.5).clamp(0.0, (nx - 1) as f32);
            let (i0, fx) = (x.floor() as usize, x.fract());
            let i1 = (i0 + 1).min(nx - 1);
            let bilerp = |a: &[[f32; 3]], n: usize| {
                let (a00, a10, a01, a11) =
                    (a[j0 * nx + i0][n], a[j0 * nx + i1][n], a[j1 * nx + i0][n], a[j1 * nx + i1][n]);
                let top = a00 + (a10 - a00) * fx;
                top + (a01 + (a11 - a01) * fx - top) * fy
            };
            let t = v * pattern.width + u;
            let (m, mottle) = (pattern.crack[t], pattern.mottle[t]);
            for n in 0..3 {
                let top = bilerp(&skin, n) * mottle;
                let c = top + (bilerp(&crack, n) - top) * m;
                out.extend_from_slice(&f16_bits(c).to_le_bytes());
            }
            out.extend_from_slice(&f16_bits(1.0).to_le_bytes());
        }
    }
}

/// Gives each cell that is not `keep` but has `keep` neighbours (8) their mean value.
pub fn dilate<const N: usize>(values: &mut [[f32; N]], keep: &[bool], nx: usize, ny: usize) {
    let source = values.to_vec();
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            if keep[k] {
                continue;
            }
            let (mut sum, mut n) = ([0.0; N], 0.0);
            for b in j.saturating_sub(1)..(j + 2).min(ny) {
                for a in i.saturating_sub(1)..(i + 2).min(nx) {
                    if keep[b * nx + a] {
                        for (s, x) in sum.iter_mut().zip(source[b * nx + a]) {
                            *s += x;
                        }
                        n += 1.0;
                    }
                }
            }
            if n > 0.0 {
                values[k] = sum.map(|s| s / n);
            }
        }
    }
}

/// IEEE half-precision bits of `x` (non-negative; NaN and negatives give 0, large values the
/// largest finite half), rounded to nearest.
pub fn f16_bits(x: f32) -> u16 {
    if x.is_nan() || x <= 0.0 {
        return 0;
    }
    if x >= 65504.0 {
        return 0x7bff;
    }
    let bits = x.to_bits();
    let exp = ((bits >> 23) & 0xff) as i32 - 127;
    if exp < -25 {
        return 0;
    }
    if exp < -14 {
        // Subnormal: units of 2^-24.
        return (x * 16_777_216.0).round() as u16;
    }
    let half = (((exp + 15) as u32) << 10) | ((bits >> 13) & 0x3ff);
    (half + ((bits >> 12) & 1)).min(0x7bff) as u16
}

/// Brightness factor of the crust albedo at world `p` (vertex colours): ±20 % over metres.
pub fn albedo_variation(p: Vec2) -> f32 {
    0.8 + 0.25 * value_noise(p, 1.7, 75) + 0.15 * value_noise(p, 5.3, 76)
}

/// Texels along a side of the detail textures.
const DETAIL_SIZE: usize = 256;

/// Tileable fBm in [0, 1] on a `DETAIL_SIZE` square: value noise with lattice periods 64, 32,
/// 16 and 8 texels, wrapped.
fn tile_fbm(u: usize, v: usize, seed: u32) -> f32 {
    let mut sum = 0.0;
    let mut weight = 0.0;
    for (octave, period) in [64usize, 32, 16, 8].into_iter().enumerate() {
        let lattice = DETAIL_SIZE / period;
        let (x, y) = (u as f32 / period as f32, v as f32 / period as f32);
        let (ix, iy) = (x.floor() as usize, y.floor() as usize);
        let (tx, ty) = (x.fract(), y.fract());
        let (sx, sy) = (tx * tx * (3.0 - 2.0 * tx), ty * ty * (3.0 - 2.0 * ty));
        let h = |a: usize, b: usize| {
            hash01((a % lattice) as i32, (b % lattice) as i32, seed + octave as u32 * 17)
        };
        let top = h(ix, iy) + (h(ix + 1, iy) - h(ix, iy)) * sx;
        let bottom = h(ix, iy + 1) + (h(ix + 1, iy + 1) - h(ix, iy + 1)) * sx;
        let w = 0.55f32.powi(octave as i32);
        sum += w * (top + (bottom - top) * sy);
        weight += w;
    }
    sum / weight
}

/// The detail textures (albedo grain, metallic-roughness, normal map), linear `Rgba8Unorm`,
/// tileable with a repeating sampler; `DETAIL_SIZE` texels per [`DETAIL_TILE`].
pub fn detail_images() -> [Image; 3] {
    let n = DETAIL_SIZE;
    let bump: Vec<f32> = (0..n * n).map(|t| tile_fbm(t % n, t / n, 80)).collect();
    let mut albedo = Vec::with_capacity(4 * n * n);
    let mut rough = Vec::with_capacity(4 * n * n);
    let mut normal = Vec::with_capacity(4 * n * n);
    // Bumps of ±1.5 cm; slopes from central differences (texel = DETAIL_TILE / n metres).
    let (amplitude, texel) = (0.03, DETAIL_TILE / n as f32);
    let unorm = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    for v in 0..n {
        for u in 0..n {
            let grain = 0.7 + 0.3 * (0.5 * tile_fbm(u, v, 81) + 0.5 * bump[v * n + u]);
            albedo.extend([unorm(grain), unorm(grain), unorm(grain), 255]);
            let r = 0.3 + 0.6 * tile_fbm(u, v, 82);
            rough.extend([0, unorm(r), 0, 255]);
            let at = |du: isize, dv: isize| {
                let (a, b) =
                    ((u as isize + du).rem_euclid(n as isize), (v as isize + dv).rem_euclid(n as isize));
                bump[b as usize * n + a as usize]
            };
            let dx = amplitude * (at(1, 0) - at(-1, 0)) / (2.0 * texel);
            let dy = amplitude * (at(0, 1) - at(0, -1)) / (2.0 * texel);
            let nrm = bevy::math::Vec3::new(-dx, -dy, 1.0).normalize();
            normal.extend([
                unorm(0.5 + 0.5 * nrm.x),
                unorm(0.5 + 0.5 * nrm.y),
                unorm(0.5 + 0.5 * nrm.z),
                255,
            ]);
        }
    }
    [albedo, rough, normal].map(|data| {
        let size = Extent3d { width: n as u32, height: n as u32, depth_or_array_layers: 1 };
        let mut image = Image::new(
            size,
            TextureDimension::D2,
            data,
            TextureFormat::Rgba8Unorm,
            RenderAssetUsages::RENDER_WORLD,
        );
        image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
            address_mode_u: ImageAddressMode::Repeat,
            address_mode_v: ImageAddressMode::Repeat,
            ..ImageSamplerDescriptor::linear()
        });
        image
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_core::Grid2;
    use volcano_lava::Edges;

    fn glow_sum(c: LinearRgba) -> f32 {
        c.red + c.green + c.blue
    }

    #[test]
    fn half_floats_round_trip() {
        assert_eq!(f16_bits(1.0), 0x3c00);
        assert_eq!(f16_bits(0.5), 0x3800);
        assert_eq!(f16_bits(65504.0), 0x7bff);
        assert_eq!(f16_bits(1e9), 0x7bff);
        assert_eq!(f16_bits(2f32.powi(-24)), 1);
        assert_eq!(f16_bits(-1.0), 0);
        assert_eq!(f16_bits(f32::NAN), 0);
        assert_eq!(f16_bits(1.0 + 1.0 / 1024.0), 0x3c01);
    }

    #[test]
    fn cracks_are_thin_and_glow_hotter_than_the_crust() {
        // A 16 × 16 field of 0.5 m cells covered by 0.5 m of lava.
        let g = Grid2::new(16, 16, 0.5, Vec2::ZERO, 0.0).unwrap();
        let mut flow = FlowField::new(g, Edges::default(), 300.0).unwrap();
        flow.place_volume(Vec2::ZERO, 20.0, 0.5 * 0.25 * 256.0, 1450.0).unwrap();
        let pattern = GlowPattern::new(&flow);
        assert_eq!((pattern.s, pattern.width), (4, 64));
        let cracked = pattern.crack.iter().filter(|&&c| c > 0.5).count() as f32;
        let share = cracked / pattern.crack.len() as f32;
        assert!(share > 0.01 && share < 0.2, "cracks cover {share}");
        assert_eq!(pattern, GlowPattern::new(&flow), "deterministic");
        let p = LavaParams::default();
        let mut tex = Vec::new();
        glow_texels(&flow, &[0.01; 256], &p, &pattern, &mut tex);
        assert_eq!(tex.len(), 8 * 64 * 64);
        let red = |t: usize| {
            let b = [tex[8 * t], tex[8 * t + 1]];
            u16::from_le_bytes(b)
        };
        // Mean red over cracked texels exceeds that over crust texels by far.
        let (mut crack, mut crust) = ((0.0, 0.0), (0.0, 0.0));
        for (t, &c) in pattern.crack.iter().enumerate() {
            let r = red(t) as f64;
            if c > 0.9 {
                crack = (crack.0 + r, crack.1 + 1.0);
            } else if c == 0.0 {
                crust = (crust.0 + r, crust.1 + 1.0);
            }
        }
        // Half-float bits grow with the value: compare the values.
        assert!(crack.0 / crack.1 > crust.0 / crust.1 + 1024.0, "{crack:?} vs {crust:?}");
        let hot = glow_sum(incandescent(surface_temperature(&p, 1450.0, 0.01 * CRACK_DEPTH)));
        let dull = glow_sum(incandescent(surface_temperature(&p, 1450.0, 0.01)));
        assert!(hot > 5.0 * dull, "{hot} vs {dull}");
    }

    #[test]
    fn only_lava_glows_and_the_glow_reaches_the_outline() {
        // 16 × 16 cells of 0.5 m, one hot cell of 1 m at (4, 4).
        let g = Grid2::new(16, 16, 0.5, Vec2::ZERO, 0.0).unwrap();
        let mut flow = FlowField::new(g, Edges::default(), 300.0).unwrap();
        flow.place_volume(Vec2::new(2.0, 2.0), 0.0, 0.25, 1450.0).unwrap();
        let pattern = GlowPattern::new(&flow);
        let mut tex = Vec::new();
        glow_texels(&flow, &[0.0; 256], &LavaParams::default(), &pattern, &mut tex);
        let red = |u: usize, v: usize| {
            let t = v * pattern.width + u;
            u16::from_le_bytes([tex[8 * t], tex[8 * t + 1]])
        };
        // Cell (4, 4) spans texels 16..20; its dry neighbour (5, 4) takes its colour (the
        // outline lies between them), cells further away stay black.
        assert!(red(18, 18) > 0x3000, "hot lava glows: {:#x}", red(18, 18));
        assert!(red(22, 18) > 0x3000, "the margin keeps the glow: {:#x}", red(22, 18));
        assert_eq!(red(40, 40), 0, "dry ground does not glow");
        assert_eq!(red(18, 30), 0);
    }

    #[test]
    fn detail_textures_tile() {
        let [albedo, rough, normal] = detail_images();
        let data = normal.data.as_ref().unwrap();
        assert_eq!(data.len(), 4 * DETAIL_SIZE * DETAIL_SIZE);
        // Wrapping: the first and last columns of the fBm are neighbours.
        let n = DETAIL_SIZE;
        assert!((tile_fbm(0, 5, 80) - tile_fbm(n - 1, 5, 80)).abs() < 0.05);
        assert!(albedo.data.as_ref().unwrap().chunks(4).all(|p| p[0] >= 170));
        assert!(rough.data.as_ref().unwrap().chunks(4).all(|p| p[1] >= 70));
    }
}
