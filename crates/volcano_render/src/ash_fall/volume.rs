//! Pure part of the ash-fall renderer: the layers' ash concentration (g/m³) resampled on a
//! voxel grid for the lit volume pass, with fall streaks.
//!
//! The atmosphere holds ash per layer (`LayerFields::ash`, g/m³; the coupling feeds it from the
//! column and the umbrella, the atmosphere's weather step advects and settles it). Ash
//! settling through a layer *is* that layer's ash, so drawing each layer's field over the
//! layer's whole slab draws the fall: a curtain under the umbrella, bent by the winds of the
//! layers it crosses, dense where the field is dense. The field is piecewise constant in
//! altitude (one value per layer); streaks — a horizontal noise of kilometre features,
//! constant along the fall — break the curtain into shafts, with a mean factor of 1 so the
//! drawn mass follows the field, and each level reads the field a little to the side
//! ([`meander_offsets`]) so the curtain's sides wander instead of standing straight. Below the
//! terrain nothing is drawn, and over the top layer the ash fades to nothing at the stack's
//! top ([`lid_fade`]): held at the top layer's value up to its top, the curtain would have a
//! flat, hard lid above the umbrella. That fade and the one along the footprint's
//! sides ([`edge_fade`]) are moved per column by a noise ([`relief_factors`]).

use bevy::math::Vec2;
use noise::{Fbm, MultiFractal, NoiseFn, Perlin};
use volcano_atmosphere::view::{GridSpec, LayerFields, blend_layers, layer_ash, layer_blend};
use volcano_core::error::in_range;
use volcano_core::grid::Boundary;
use volcano_core::{ConfigError, Grid2};

/// The voxel grid of an ash volume: `nxy × nxy` columns over the atmosphere's footprint (centred
/// on the world origin, like its grid), `nz` levels from `z_min` to `z_max` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AshVolumeSpec {
    /// Voxels per side horizontally.
    pub nxy: usize,
    /// Voxels vertically.
    pub nz: usize,
    /// Altitude of the volume's bottom (m).
    pub z_min: f64,
    /// Altitude of the volume's top (m).
    pub z_max: f64,
    /// Strength of the fall streaks, 0 (a smooth curtain) to 1 (shafts and gaps).
    pub streaks: f64,
    /// Horizontal size of a streak (m).
    pub streak_m: f64,
    /// Seed of the streak noise.
    pub seed: u32,
    /// Width of the band along the footprint's sides over which the ash fades to nothing, as
    /// a fraction of the footprint's side (0–0.5; [`edge_fade`]).
    pub edge_fraction: f64,
    /// Horizontal blur (m): half-width of the box filter run twice over each level
    /// ([`blur_level`]); 0 for none.
    pub blur_m: f64,
    /// How ragged the curtain's top and sides are, 0 (the straight fades of [`lid_fade`] and
    /// [`edge_fade`]) to 1 ([`relief_factors`]).
    pub relief: f64,
    /// Horizontal size (m) of the raggedness' features.
    pub relief_m: f64,
    /// How far (m) each level reads the layers' ash away from its voxel ([`meander_offsets`]):
    /// the curtain's sides wander with altitude instead of standing straight; 0 for none.
    pub meander_m: f64,
}

impl AshVolumeSpec {
    /// Altitudes (m) a volume over a stack of layers spans: from the lowest layer's bottom
    /// (not below sea level) to the top layer's top.
    pub fn altitude_range(layers: &[&LayerFields]) -> (f64, f64) {
        let z_min = layers.iter().map(|l| l.bottom).fold(f64::INFINITY, f64::min);
        let z_max = layers.iter().map(|l| l.bottom + l.thickness).fold(f64::NEG_INFINITY, f64::max);
        let z_min = if z_min.is_finite() { z_min.max(0.0) } else { 0.0 };
        let z_max = if z_max.is_finite() { z_max.max(z_min + 1.0) } else { z_min + 1.0 };
        (z_min, z_max)
    }

    /// Checks the sizes and the streak parameters; the error names the field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("ash voxels_xy", self.nxy as f64, 2.0, 1024.0)?;
        in_range("ash voxels_z", self.nz as f64, 2.0, 512.0)?;
        in_range("ash streaks", self.streaks, 0.0, 1.0)?;
        in_range("ash streak_m", self.streak_m, 1.0, 1e6)?;
        in_range("ash edge_fraction", self.edge_fraction, 0.0, 0.5)?;
        in_range("ash blur_m", self.blur_m, 0.0, 1e6)?;
        in_range("ash relief", self.relief, 0.0, 1.0)?;
        in_range("ash relief_m", self.relief_m, 1.0, 1e6)?;
        in_range("ash meander_m", self.meander_m, 0.0, 1e5)?;
        if !(self.z_min.is_finite() && self.z_max.is_finite() && self.z_max > self.z_min) {
            return Err(ConfigError::InvalidParameter {
                name: "ash volume altitudes",
                value: self.z_max - self.z_min,
                reason: format!("need finite z_min < z_max, got {} .. {}", self.z_min, self.z_max),
            });
        }
        Ok(())
    }

    /// Altitude of the centre of level `iz` (m).
    pub fn level_altitude(&self, iz: usize) -> f64 {
        self.z_min + (iz as f64 + 0.5) * (self.z_max - self.z_min) / self.nz as f64
    }
}

/// Ash concentration (g/m³) of the voxels of `spec` over an atmosphere of grid `grid` (x
/// fastest, then grid y, then altitude — the layout of `density_volume::density_texels`): each voxel
/// takes the bilinear sample of the layers' ash fields at its position, blended in altitude
/// by [`layer_blend`] (a curtain sheared by the winds leans smoothly instead of in steps),
/// times the streak factor and [`edge_fade`] of its column and [`lid_fade`] (both made ragged
/// by [`relief_factors`]); 0 above the layers and under
/// `ground` (terrain altitude at the atmosphere's cell centres, if given). Non-finite or negative ash counts as none.
pub fn ash_density_volume(
    layers: &[&LayerFields],
    grid: GridSpec,
    ground: Option<&Grid2<f32>>,
    spec: &AshVolumeSpec,
) -> Result<Vec<f32>, ConfigError> {
    spec.validate()?;
    let (nxy, nz) = (spec.nxy, spec.nz);
    let extent = grid.extent();
    let mut streak = streak_factors(spec, extent);
    let (lid_drop, side_relief) = relief_factors(spec, extent);
    let band = spec.edge_fraction * extent;
    for (k, f) in streak.iter_mut().enumerate() {
        let (ix, jy) = ((k % nxy) as f64 + 0.5, (k / nxy) as f64 + 0.5);
        let inside = (ix.min(nxy as f64 - ix).min(jy).min(nxy as f64 - jy)) * extent / nxy as f64;
        *f *= edge_fade(inside, band * side_relief[k]);
    }
    // World position of each voxel column's centre.
    let column_xy = |i: usize| -0.5 * extent + (i as f64 + 0.5) * extent / nxy as f64;
    // Per level: altitude and the layers it blends ([`layer_blend`]).
    type Level = (f64, Option<(usize, usize, f64)>);
    let levels: Vec<Level> = (0..nz)
        .map(|iz| {
            let z = spec.level_altitude(iz);
            (z, layer_blend(layers, z))
        })
        .collect();
    let mut out = vec![0.0f32; nxy * nxy * nz];
    let radius = (spec.blur_m * nxy as f64 / extent).round() as usize;
    let meander = meander_offsets(spec, extent);
    // Each layer's ash at the voxel columns, sampled once: the columns are the same at every
    // level, and a level blends two layers (sampled per voxel, the same bilinear reads would
    // be repeated for every level of a layer; `benches/ash_volume.rs`, the plain sampling of a
    // 128² × 64 volume: 14 ms, 50 ms per voxel).
    let mut at_columns: Vec<Option<Vec<f64>>> = vec![None; layers.len()];
    for &(_, blend) in &levels {
        let Some((lo, hi, w)) = blend else { continue };
        for li in [Some(lo), (w > 0.0).then_some(hi)].into_iter().flatten() {
            if at_columns[li].is_none() {
                at_columns[li] = Some(
                    (0..nxy * nxy)
                        .map(|k| {
                            let p = Vec2::new(column_xy(k % nxy) as f32, column_xy(k / nxy) as f32);
                            layer_ash(layers[li], p)
                        })
                        .collect(),
                );
            }
        }
    }
    let (mut unshifted, mut shifts) = (vec![0.0f32; nxy * nxy], vec![Vec2::ZERO; nxy * nxy]);
    // The field (blended as `ash_blended` blends it, then read at the meandered positions),
    // blurred level by level, then streaks, fades and the ground.
    for (iz, &(_, blend)) in levels.iter().enumerate() {
        let Some((lo, hi, w)) = blend else { continue };
        let level = &mut out[iz * nxy * nxy..(iz + 1) * nxy * nxy];
        let (Some(a), b) = (&at_columns[lo], &at_columns[hi]) else { continue };
        for (k, v) in level.iter_mut().enumerate() {
            *v = blend_layers(a[k], || b.as_ref().map_or(0.0, |b| b[k]), w) as f32;
        }
        if let Some(lattice) =
            meander.get(iz * MEANDER_NODES * MEANDER_NODES..(iz + 1) * MEANDER_NODES * MEANDER_NODES)
        {
            unshifted.copy_from_slice(level);
            meander_shifts(lattice, nxy, &mut shifts);
            let voxel = (extent / nxy as f64) as f32;
            for (k, (v, shift)) in level.iter_mut().zip(&shifts).enumerate() {
                let (u, w) = ((k % nxy) as f32 + shift.x / voxel, (k / nxy) as f32 + shift.y / voxel);
                *v = bilinear_clamped(&unshifted, nxy, u, w);
            }
        }
        blur_level(level, nxy, radius);
    }
    for jy in 0..nxy {
        for ix in 0..nxy {
            let p = Vec2::new(column_xy(ix) as f32, column_xy(jy) as f32);
            let floor = ground.map_or(f64::NEG_INFINITY, |g| g.sample(p, Boundary::Clamp) as f64);
            let (s, drop) = (streak[jy * nxy + ix], lid_drop[jy * nxy + ix]);
            for (iz, &(z, _)) in levels.iter().enumerate() {
                let v = &mut out[(iz * nxy + jy) * nxy + ix];
                *v = if z < floor { 0.0 } else { (*v as f64 * s * lid_fade(layers, z, drop)) as f32 };
            }
        }
    }
    Ok(out)
}

/// How much of the ash is drawn at altitude `z` in a column whose lid is lowered by `drop`
/// (0–1, [`relief_factors`]): 1 up to the top layer's bottom, then a smoothstep down to 0 at
/// its top, the whole ramp lowered by half of `drop` times the top layer's thickness. The
/// layers hold one value per slab; where the stack ends, this reads the air above as thinning
/// out. A rendering choice, against two defects seen in renders: held at the top layer's value
/// up to its top, the curtain has a flat, hard lid above the umbrella; faded over the layer's
/// upper half only, with a noise-lowered ramp, its top seen edge-on from a camera near the lid
/// is a row of square notches. The top layer is also where the umbrella's spheres draw the
/// same ash. The air-ash query (`air_ash_at`) keeps the slab's value.
pub fn lid_fade(layers: &[&LayerFields], z: f64, drop: f64) -> f64 {
    let Some(top) = layers.last() else { return 0.0 };
    let lower = 0.5 * drop.clamp(0.0, 1.0) * top.thickness;
    let (start, end) = (top.bottom - lower, top.bottom + top.thickness - lower);
    if z <= start || end <= start {
        return 1.0;
    }
    let s = ((end - z) / (end - start)).clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

/// Per voxel column (`nxy²`, x fastest): how far the lid is lowered (0–`relief`; [`lid_fade`])
/// and the factor on the side band's width (1 ± 0.6 `relief`; [`edge_fade`]), both from one
/// two-octave Perlin fBm over `relief_m`-sized features, sampled at offset points for the two
/// uses. All 0 and 1 when `relief` is 0.
pub fn relief_factors(spec: &AshVolumeSpec, extent: f64) -> (Vec<f64>, Vec<f64>) {
    let noise =
        Fbm::<Perlin>::new(spec.seed.wrapping_add(1)).set_octaves(2).set_frequency(1.0 / spec.relief_m);
    let nxy = spec.nxy;
    let (mut drop, mut side) = (Vec::with_capacity(nxy * nxy), Vec::with_capacity(nxy * nxy));
    for k in 0..nxy * nxy {
        let (x, y) =
            (((k % nxy) as f64 + 0.5) * extent / nxy as f64, ((k / nxy) as f64 + 0.5) * extent / nxy as f64);
        // Tripled so the noise spans most of ±1, then clamped.
        let a = (3.0 * noise.get([x + 0.37 * spec.relief_m, y + 0.71 * spec.relief_m])).clamp(-1.0, 1.0);
        let b = (3.0 * noise.get([x + 5.3 * spec.relief_m, y - 2.9 * spec.relief_m])).clamp(-1.0, 1.0);
        drop.push(spec.relief * 0.5 * (1.0 - a));
        side.push(1.0 + 0.6 * spec.relief * b);
    }
    (drop, side)
}

/// Blurs one `nxy × nxy` level (x fastest) in place: a box filter of half-width `radius`
/// voxels along x, then y, twice (close to a Gaussian of σ ≈ 0.8 · radius), edges clamped.
/// The atmosphere's ash is advected with little diffusion, so where it begins upwind of the
/// column it begins within a cell, the same cell in every layer: drawn as sampled, the curtain
/// would have a straight vertical edge kilometres tall. A rendering choice; the mass stays where the
/// layers hold it, spread over a few hundred metres. Written by hand: a running sum per row.
pub fn blur_level(level: &mut [f32], nxy: usize, radius: usize) {
    if radius == 0 || nxy < 2 || level.len() != nxy * nxy {
        return;
    }
    let r = radius as isize;
    let n = nxy as isize;
    let mut line = vec![0.0f32; nxy];
    let width = (2 * radius + 1) as f32;
    for _ in 0..2 {
        for axis in 0..2 {
            for a in 0..nxy {
                let at = |b: usize| if axis == 0 { a * nxy + b } else { b * nxy + a };
                for (b, v) in line.iter_mut().enumerate() {
                    *v = level[at(b)];
                }
                let clamp = |i: isize| line[i.clamp(0, n - 1) as usize];
                let mut sum: f32 = (-r..=r).map(clamp).sum();
                for b in 0..nxy {
                    level[at(b)] = sum / width;
                    let b = b as isize;
                    sum += clamp(b + r + 1) - clamp(b - r);
                }
            }
        }
    }
}

/// How much of the ash is drawn `inside` metres from the nearest side of the footprint: 0 at
/// the side, rising smoothly (smoothstep) to 1 at `band` metres in. The atmosphere's grid
/// ends there but the air does not: drawn at full value up to the side, an umbrella's ash that
/// reaches the boundary would stand as a wall with straight vertical edges (the box's own). A
/// rendering choice, like [`lid_fade`]; the ash budget is the layers'.
pub fn edge_fade(inside: f64, band: f64) -> f64 {
    if band.is_nan() || band <= 0.0 {
        return 1.0;
    }
    let t = (inside / band).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The `n × n` image `img` (x fastest) at voxel coordinates `(u, v)` (voxel centres at
/// integers), interpolated bilinearly, clamped to the edge voxels: what
/// `Grid2::sample_grid(u, v, Boundary::Clamp)` gives, in f32 on a plain slice, because this is
/// the meander's per-voxel read (the grid's sampler, with its f64 coordinates and an index
/// resolve per read, makes a 128² × 64 rebuild about 10 ms slower: 47–52 vs 37 ms, `ash_volume`
/// bench).
fn bilinear_clamped(img: &[f32], n: usize, u: f32, v: f32) -> f32 {
    let top = (n - 1) as f32;
    let (u, v) = (u.clamp(0.0, top), v.clamp(0.0, top));
    let (i, j) = ((u as usize).min(n.saturating_sub(2)), (v as usize).min(n.saturating_sub(2)));
    let (fu, fv) = (u - i as f32, v - j as f32);
    let at = |i: usize, j: usize| img[(j * n + i).min(img.len() - 1)];
    let (i1, j1) = ((i + 1).min(n - 1), (j + 1).min(n - 1));
    let bottom = at(i, j) + fu * (at(i1, j) - at(i, j));
    let upper = at(i, j1) + fu * (at(i1, j1) - at(i, j1));
    bottom + fv * (upper - bottom)
}

/// Nodes per side of the lattice [`meander_offsets`] samples its noise on (32 cells over the
/// footprint: 800 m in the `eruption` scene), interpolated bilinearly in between.
pub const MEANDER_NODES: usize = 33;

/// Per level (`nz`), the horizontal offsets (m) at which the level reads the layers' ash, on a
/// [`MEANDER_NODES`]² lattice over the footprint (x fastest): two Perlin noises of
/// (x, y, altitude) with features of half `relief_m` across and 3 km in altitude, doubled
/// and clamped to ±1, times `meander_m`. Empty when `meander_m` is 0. A rendering choice: the
/// layers' ash is advected with the same winds over a few layers, so where the curtain ends
/// sideways it ends in the same cell at every altitude: read straight down, its sides would
/// be vertical edges kilometres tall. Reading each level a little to the side makes them
/// wander; an offset of up to ±1.5 km over 3 km features changes a level's drawn ash by up to
/// 12 % (tested; the default is ±800 m). Sampled on a lattice, not per voxel: 2 · 33² · 64
/// noise calls instead of 2 · 128² · 64 per rebuild (4.4 ms; the whole meander adds 14 ms to
/// a 128² × 64 rebuild, `benches/ash_volume.rs`).
pub fn meander_offsets(spec: &AshVolumeSpec, extent: f64) -> Vec<Vec2> {
    if spec.meander_m <= 0.0 {
        return Vec::new();
    }
    let (nx, ny) = (Perlin::new(spec.seed.wrapping_add(2)), Perlin::new(spec.seed.wrapping_add(3)));
    let across = 0.5 * spec.relief_m;
    let cells = (MEANDER_NODES - 1) as f64;
    let mut out = Vec::with_capacity(spec.nz * MEANDER_NODES * MEANDER_NODES);
    for iz in 0..spec.nz {
        let z = spec.level_altitude(iz) / 3_000.0 + 0.13;
        for k in 0..MEANDER_NODES * MEANDER_NODES {
            let (x, y) = (
                (k % MEANDER_NODES) as f64 * extent / cells / across + 0.37,
                (k / MEANDER_NODES) as f64 * extent / cells / across + 0.71,
            );
            let d = |n: &Perlin| ((2.0 * n.get([x, y, z])).clamp(-1.0, 1.0) * spec.meander_m) as f32;
            out.push(Vec2::new(d(&nx), d(&ny)));
        }
    }
    out
}

/// One level's [`meander_offsets`] lattice interpolated bilinearly at the centres of the
/// `nxy²` voxel columns (x fastest; the footprint centred on the origin, clamped at the
/// sides), written into `out`: separably, the lattice's rows along x first, then one lerp per
/// voxel between two of those rows (per voxel, the full bilinear lookup cost about 35 ns,
/// half of a 128² × 64 rebuild). Rows of `out` beyond `nxy` are left as they are.
pub fn meander_shifts(lattice: &[Vec2], nxy: usize, out: &mut [Vec2]) {
    let cells = (MEANDER_NODES - 1) as f32;
    // Lattice coordinate of voxel centre `i`: lower node and weight.
    let weights: Vec<(usize, f32)> = (0..nxy)
        .map(|i| {
            let u = ((i as f32 + 0.5) / nxy as f32 * cells).clamp(0.0, cells);
            let i0 = (u as usize).min(MEANDER_NODES - 2);
            (i0, u - i0 as f32)
        })
        .collect();
    let node = |i: usize, j: usize| lattice.get(j * MEANDER_NODES + i).copied().unwrap_or(Vec2::ZERO);
    // Every lattice row at the voxel columns.
    let rows: Vec<Vec2> = (0..MEANDER_NODES)
        .flat_map(|j| weights.iter().map(move |&(i0, fu)| node(i0, j).lerp(node(i0 + 1, j), fu)))
        .collect();
    for (row, &(j0, fv)) in out.chunks_mut(nxy.max(1)).zip(&weights) {
        let (lower, upper) = (&rows[j0 * nxy..(j0 + 1) * nxy], &rows[(j0 + 1) * nxy..(j0 + 2) * nxy]);
        for ((o, a), b) in row.iter_mut().zip(lower).zip(upper) {
            *o = a.lerp(*b, fv);
        }
    }
}

/// Streak factor of each voxel column (`nxy²`, x fastest): `max(0, 1 + a·p)` with `p` a
/// two-octave Perlin fBm over `streak_m`-sized features, doubled and clamped to ±1 (the fBm
/// spans about ±0.5), `a` = `spec.streaks`; then divided by the factors' mean, so they average
/// exactly 1 and the drawn ash mass follows the field. At `a` = 1 the gaps are empty and the
/// shafts about twice the field. A rendering choice: the layers' ash has no structure below
/// their cells, and a real fall hangs in shafts (fall streaks) under the umbrella. The
/// features must span several voxels to survive the pass's filtering and the kilometres of
/// curtain a view ray crosses: at 350 m over 200 m voxels the curtain reads as one smooth grey
/// wall.
pub fn streak_factors(spec: &AshVolumeSpec, extent: f64) -> Vec<f64> {
    let nxy = spec.nxy;
    if spec.streaks <= 0.0 {
        return vec![1.0; nxy * nxy];
    }
    let noise = Fbm::<Perlin>::new(spec.seed).set_octaves(2).set_frequency(1.0 / spec.streak_m);
    let raw: Vec<f64> = (0..nxy * nxy)
        .map(|k| {
            let (x, y) = (
                ((k % nxy) as f64 + 0.5) * extent / nxy as f64,
                ((k / nxy) as f64 + 0.5) * extent / nxy as f64,
            );
            // Offset so columns do not land on the lattice points, where Perlin is 0.
            let p = (2.0 * noise.get([x + 0.37 * spec.streak_m, y + 0.71 * spec.streak_m])).clamp(-1.0, 1.0);
            (1.0 + spec.streaks * p).max(0.0)
        })
        .collect();
    let mean = raw.iter().sum::<f64>() / raw.len() as f64;
    if mean > 0.0 { raw.into_iter().map(|f| f / mean).collect() } else { vec![1.0; nxy * nxy] }
}

#[cfg(test)]
#[path = "volume_tests.rs"]
mod tests;
