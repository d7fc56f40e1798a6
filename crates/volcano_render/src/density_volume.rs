//! What the cloud and ash-fall renderers share: a 3D density (condensed water or ash, x
//! fastest, then grid y, then altitude) as an `R8Unorm` 3D [`Image`] (u = world x,
//! v = altitude, w = world z = grid y; the layout Bevy's `FogVolume` reads too, which both
//! used before the lit pass of [`crate::clouds::material`]) and the volume's placement.

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageAddressMode, ImageFilterMode, ImageSampler, ImageSamplerDescriptor};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
use volcano_core::ConfigError;
use volcano_core::error::positive;

/// Texel value (0–1) of a condensed-water density `d` (g/m³): `1 − exp(−d / d₀)`, linear for
/// thin cloud and saturating for dense cores, so the 8-bit texture keeps thin cirrus
/// (≈ 0.01 g/m³) and thick cumulus (≈ 1 g/m³) apart. Non-finite or negative input is 0.
pub fn texel(d: f32, d0: f32) -> f32 {
    if !(d.is_finite() && d > 0.0 && d0 > 0.0) {
        return 0.0;
    }
    1.0 - (-d / d0).exp()
}

/// Reorders `density` (`nxy × nxy × nz`, x fastest, then grid y, then altitude) into 8-bit
/// texels with u = x, v = altitude, w = grid y (the fog volume's local axes), mapping each
/// value with [`texel`]. Errors if the length does not match.
pub fn density_texels(density: &[f32], nxy: usize, nz: usize, d0: f32) -> Result<Vec<u8>, ConfigError> {
    if nxy == 0 || nz == 0 || density.len() != nxy * nxy * nz {
        return Err(ConfigError::InvalidParameter {
            name: "cloud density volume",
            value: density.len() as f64,
            reason: format!("expected {nxy}×{nxy}×{nz} values"),
        });
    }
    positive("cloud density scale d0", d0 as f64)?;
    let mut out = vec![0u8; density.len()];
    for iz in 0..nz {
        for jy in 0..nxy {
            let src = (iz * nxy + jy) * nxy;
            let dst = (jy * nz + iz) * nxy;
            for ix in 0..nxy {
                out[dst + ix] = (texel(density[src + ix], d0) * 255.0).round() as u8;
            }
        }
    }
    Ok(out)
}

/// Smooths a density volume (`nxy × nxy × nz`, x fastest, then grid y, then altitude) in
/// place with `passes` passes of the [1, 2, 1] / 4 kernel along each axis (edges clamped).
/// The volume samples the nearest atmosphere cell per voxel column, so cells of several voxels
/// show as blocks with vertical walls; a pass or two rounds them without moving mass
/// (interior sums are kept). Errors if the length does not match.
pub fn smooth_density(density: &mut [f32], nxy: usize, nz: usize, passes: u32) -> Result<(), ConfigError> {
    if nxy == 0 || nz == 0 || density.len() != nxy * nxy * nz {
        return Err(ConfigError::InvalidParameter {
            name: "cloud density volume",
            value: density.len() as f64,
            reason: format!("expected {nxy}×{nxy}×{nz} values"),
        });
    }
    let mut line = Vec::new();
    for _ in 0..passes {
        // (axis, stride, count, number of lines)
        for (axis, stride, count, lines) in
            [(0, 1, nxy, nxy * nz), (1, nxy, nxy, nxy * nz), (2, nxy * nxy, nz, nxy * nxy)]
        {
            if count < 2 {
                continue;
            }
            for i in 0..lines {
                // First element of line i.
                let s0 = match axis {
                    0 => i * nxy,
                    1 => (i / nxy) * nxy * nxy + i % nxy,
                    _ => i,
                };
                line.clear();
                line.extend((0..count).map(|k| density[s0 + k * stride]));
                for k in 0..count {
                    let (a, c) = (line[k.saturating_sub(1)], line[(k + 1).min(count - 1)]);
                    density[s0 + k * stride] = 0.25 * a + 0.5 * line[k] + 0.25 * c;
                }
            }
        }
    }
    Ok(())
}

/// Appends to `texels` (a `w × h × d` level, u fastest, then v, then w) its chain of coarser
/// levels down to 1 × 1 × 1 for the cloud pass's occupancy test, which skips the empty
/// stretches of a ray. Each coarser level halves every axis (rounded down, at least 1; the
/// last texel of an odd axis takes the leftover one); a texel of it holds the **maximum** of
/// the finer texels under it *and under its neighbours* (one texel of its level on every side,
/// 27 in all). So a texel is 0 only where no texel within one coarse texel of it is lit, and
/// the pass can read the one texel around a point, unfiltered, to learn whether anything lies
/// within a coarse texel of the point in any direction. (A texel holding the maximum under
/// itself alone would have to be read through the linear filter, whose 8-bit result rounds a
/// faint texel's small share to 0: faint puffs near the edges of the coarse texels would be
/// skipped.) Cost: the levels add 1/7 of the texels; the widening is three passes
/// of three comparisons per texel. Returns the number of levels.
pub fn append_max_levels(texels: &mut Vec<u8>, w: usize, h: usize, d: usize) -> u32 {
    let (mut dims, mut levels) = ([w, h, d], 1u32);
    // The previous level's plain maxima (not widened), from which the next is reduced; none
    // for the first step, which reduces level 0 itself.
    let mut plain: Option<Vec<u8>> = None;
    let span = |i: usize, m: usize, n: usize| 2 * i..=if i + 1 == m { n - 1 } else { 2 * i + 1 };
    while dims.iter().any(|&n| n > 1) {
        let [nw, nh, nd] = dims;
        let [mw, mh, md] = dims.map(|n| (n / 2).max(1));
        let src: &[u8] = plain.as_deref().unwrap_or(&texels[..w * h * d]);
        let mut reduced = Vec::with_capacity(mw * mh * md);
        for z in 0..md {
            for y in 0..mh {
                for x in 0..mw {
                    let mut m = 0u8;
                    for sz in span(z, md, nd) {
                        for sy in span(y, mh, nh) {
                            for sx in span(x, mw, nw) {
                                m = m.max(src[(sz * nh + sy) * nw + sx]);
                            }
                        }
                    }
                    reduced.push(m);
                }
            }
        }
        texels.extend(widen(&reduced, [mw, mh, md]));
        (dims, plain, levels) = ([mw, mh, md], Some(reduced), levels + 1);
    }
    levels
}

/// Each texel of a `w × h × d` grid replaced by the maximum of itself and its 26 neighbours:
/// the maximum over the 3 × 3 × 3 block, taken one axis after the other.
fn widen(level: &[u8], dims: [usize; 3]) -> Vec<u8> {
    let mut out = level.to_vec();
    let strides = [1, dims[0], dims[0] * dims[1]];
    for axis in 0..3 {
        let (n, stride) = (dims[axis], strides[axis]);
        if n < 2 {
            continue;
        }
        let prev = out.clone();
        for (k, v) in out.iter_mut().enumerate() {
            let i = (k / stride) % n;
            if i > 0 {
                *v = (*v).max(prev[k - stride]);
            }
            if i + 1 < n {
                *v = (*v).max(prev[k + stride]);
            }
        }
    }
    out
}

/// A 3D `R8Unorm` image (`nxy × nz × nxy`, linear filtering, clamped) from [`density_texels`],
/// with its maximum levels ([`append_max_levels`]; read with the nearest level).
pub fn density_image(density: &[f32], nxy: usize, nz: usize, d0: f32) -> Result<Image, ConfigError> {
    let data = density_texels(density, nxy, nz, d0)?;
    let size = Extent3d { width: nxy as u32, height: nz as u32, depth_or_array_layers: nxy as u32 };
    let mut image =
        Image::new(size, TextureDimension::D3, data, TextureFormat::R8Unorm, RenderAssetUsages::all());
    if let Some(data) = image.data.as_mut() {
        image.texture_descriptor.mip_level_count = append_max_levels(data, nxy, nz, nxy);
    }
    // Sampled only, never copied into: without `COPY_DST`, an image replaced in place under its
    // handle (as a game may do; the rebuilds add a new handle) gets a new texture with every
    // level; a material's bind group then needs the material touched too. With
    // it, Bevy would reuse the texture and write the new data into level 0 alone
    // (`GpuImage::prepare_asset`), so the maximum levels would keep the first volume's
    // occupancy and the pass would skip today's cloud where yesterday's air was clear.
    image.texture_descriptor.usage = TextureUsages::TEXTURE_BINDING;
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        address_mode_u: ImageAddressMode::ClampToEdge,
        address_mode_v: ImageAddressMode::ClampToEdge,
        address_mode_w: ImageAddressMode::ClampToEdge,
        mag_filter: ImageFilterMode::Linear,
        min_filter: ImageFilterMode::Linear,
        mipmap_filter: ImageFilterMode::Nearest,
        ..default()
    });
    Ok(image)
}

/// Fraction of the texels of an image's finest level that are not empty (diagnostics, tests).
pub fn filled_fraction(image: &Image) -> f32 {
    let size = image.texture_descriptor.size;
    let n = (size.width * size.height * size.depth_or_array_layers) as usize;
    image.data.as_ref().map_or(0.0, |d| {
        let level0 = &d[..n.min(d.len())];
        level0.iter().filter(|&&v| v > 0).count() as f32 / level0.len().max(1) as f32
    })
}

/// Transform of the unit fog cube covering an `extent × extent` footprint centred on the
/// world origin (the atmosphere grid is centred there too) from altitude `z_min` to `z_max`.
pub fn volume_transform(extent: f32, z_min: f32, z_max: f32) -> Transform {
    Transform::from_xyz(0.0, 0.5 * (z_min + z_max), 0.0).with_scale(Vec3::new(
        extent,
        (z_max - z_min).max(1.0),
        extent,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texel_saturates_and_rejects_bad_values() {
        assert_eq!(texel(0.0, 0.1), 0.0);
        assert_eq!(texel(-1.0, 0.1), 0.0);
        assert_eq!(texel(f32::NAN, 0.1), 0.0);
        assert_eq!(texel(f32::INFINITY, 0.1), 0.0);
        assert!((texel(0.1, 0.1) - (1.0 - (-1.0f32).exp())).abs() < 1e-6);
        assert!(texel(10.0, 0.1) > 0.999);
        // Monotone.
        assert!(texel(0.01, 0.1) < texel(0.02, 0.1));
    }

    #[test]
    fn texels_are_reordered_to_u_x_v_altitude_w_y() {
        let (nxy, nz) = (4, 3);
        // Input index of (x, grid y, level z); output index of (u = x, v = z, w = y).
        let src = |x: usize, y: usize, z: usize| (z * nxy + y) * nxy + x;
        let dst = |u: usize, v: usize, w: usize| (w * nz + v) * nxy + u;
        let mut d = vec![0.0f32; nxy * nxy * nz];
        // One dense voxel at x = 1, grid y = 2, level z = 0 (input: x fastest, then y, then z).
        d[src(1, 2, 0)] = 5.0;
        // A thin one at x = 3, y = 0, z = 2.
        d[src(3, 0, 2)] = 0.01;
        let t = density_texels(&d, nxy, nz, 0.1).unwrap();
        // Output: u = x fastest, then v = z, then w = y.
        assert_eq!(t[dst(1, 0, 2)], 255);
        let thin = t[dst(3, 2, 0)];
        assert!((20..=30).contains(&thin), "{thin}");
        assert_eq!(t.iter().filter(|&&v| v > 0).count(), 2);
        assert!(density_texels(&d[1..], nxy, nz, 0.1).is_err());
        assert!(density_texels(&d, nxy, nz, 0.0).is_err());
    }

    #[test]
    fn smoothing_spreads_a_voxel_along_every_axis_and_keeps_its_mass() {
        let (nxy, nz) = (8, 6);
        let idx = |x: usize, y: usize, z: usize| (z * nxy + y) * nxy + x;
        let mut d = vec![0.0f32; nxy * nxy * nz];
        d[idx(4, 3, 2)] = 64.0;
        smooth_density(&mut d, nxy, nz, 1).unwrap();
        assert!((d.iter().sum::<f32>() - 64.0).abs() < 1e-3);
        assert!((d[idx(4, 3, 2)] - 8.0).abs() < 1e-4, "{}", d[idx(4, 3, 2)]);
        for n in [idx(3, 3, 2), idx(5, 3, 2), idx(4, 2, 2), idx(4, 4, 2), idx(4, 3, 1), idx(4, 3, 3)] {
            assert!((d[n] - 4.0).abs() < 1e-4, "{}", d[n]);
        }
        assert_eq!(d[idx(6, 3, 2)], 0.0);
        assert!(smooth_density(&mut d[1..], nxy, nz, 1).is_err());
    }

    /// Every coarser texel is the maximum of the texels under it and under its neighbours, odd
    /// axes included: one lit texel anywhere lights, on each level, the texel over it and
    /// those next to that one, and nothing else.
    #[test]
    fn max_levels_keep_every_occupied_texel_and_its_neighbours() {
        let (w, h, d) = (8, 3, 5);
        for k in 0..w * h * d {
            let mut t = vec![0u8; w * h * d];
            t[k] = 7;
            let levels = append_max_levels(&mut t, w, h, d);
            assert_eq!(levels, 4, "8×3×5 → 4×1×2 → 2×1×1 → 1×1×1");
            assert_eq!(t.len(), 120 + 8 + 2 + 1);
            let (x, y, z) = (k % w, (k / w) % h, k / (w * h));
            // Level 1 is 4 × 1 × 2: x/2, y → 0, z 0–1 → 0 and 2–4 → 1; the texel over the lit
            // one is (x/2, 0, z ≥ 2), lit with its neighbours along x and both z rows.
            let (cx, cz) = (x / 2, usize::from(z >= 2));
            let want1: Vec<usize> = (0..2)
                .flat_map(|iz| (cx.saturating_sub(1)..=(cx + 1).min(3)).map(move |ix| iz * 4 + ix))
                .collect();
            let lit: Vec<usize> = (0..8).filter(|&i| t[120 + i] != 0).collect();
            assert_eq!(lit, want1, "texel {k} ({x}, {y}, {z}), level 1 texel ({cx}, 0, {cz})");
            // Level 2 (2 × 1 × 1) and level 3: both lit, every neighbour counts.
            assert_eq!(&t[128..], &[7, 7, 7]);
        }
        // The widening reaches one texel of the coarse level, not more: in a 16-long row, a
        // lit texel at 0 lights level-1 texels 0 and 1 (of 8), level-2 texels 0 and 1 (of 4).
        let mut row = vec![0u8; 16];
        row[0] = 3;
        append_max_levels(&mut row, 16, 1, 1);
        assert_eq!(&row[16..24], &[3, 3, 0, 0, 0, 0, 0, 0]);
        assert_eq!(&row[24..28], &[3, 3, 0, 0]);
        let mut flat = vec![0u8; 4];
        assert_eq!(append_max_levels(&mut flat, 4, 1, 1), 3);
        assert_eq!(flat.len(), 4 + 2 + 1);
    }

    #[test]
    fn image_is_3d_and_sized_for_the_volume() {
        let img = density_image(&vec![0.2; 8 * 8 * 4], 8, 4, 0.1).unwrap();
        assert_eq!(img.texture_descriptor.dimension, TextureDimension::D3);
        assert_eq!(img.texture_descriptor.size, Extent3d { width: 8, height: 4, depth_or_array_layers: 8 });
        // 8×4×8, then 4×2×4, 2×1×2, 1×1×1.
        assert_eq!(img.texture_descriptor.mip_level_count, 4);
        assert_eq!(img.data.as_ref().map(|d| d.len()), Some(256 + 32 + 4 + 1));
        assert_eq!(filled_fraction(&img), 1.0);
        let t = volume_transform(51_200.0, 0.0, 10_000.0);
        assert_eq!(t.translation.y, 5_000.0);
        assert_eq!(t.scale, Vec3::new(51_200.0, 10_000.0, 51_200.0));
    }
}
