//! Pure part of the ash-fall renderer: the layers' ash concentration (g/m³) resampled on a
//! voxel grid for the lit volume pass, with fall streaks.
//!
//! The atmosphere holds ash per layer (`LayerFields::ash`, g/m³; the coupling feeds it from the
//! column and the umbrella, the atmosphere's weather step advects and settles it). Ash
//! settling through a layer *is* that layer's ash, so drawing each layer's field over the
//! layer's whole slab draws the fall: a curtain under the umbrella, bent by the winds of the
//! layers it crosses, dense where the field is dense. The field is piecewise constant in
//! altitude (one value per layer); streaks — a horizontal noise at a few voxels, constant along
//! the fall — break the curtain into shafts, with a mean factor of 1 so the drawn mass follows
//! the field. Below the terrain nothing is drawn, and over the top layer the ash fades to
//! nothing at the stack's top ([`lid_fade`]): held at the top layer's value up to its top, the
//! curtain had a flat, hard lid above the umbrella. That fade and the one along the footprint's
//! sides ([`edge_fade`]) are moved per column by a noise ([`relief_factors`]).

use bevy::math::Vec2;
use noise::{Fbm, MultiFractal, NoiseFn, Perlin};
use volcano_atmosphere::view::{GridSpec, LayerFields, ash_blended, layer_blend};
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
    // The field, blurred level by level, then streaks, fades and the ground.
    for (iz, &(_, blend)) in levels.iter().enumerate() {
        let Some(blend) = blend else { continue };
        let level = &mut out[iz * nxy * nxy..(iz + 1) * nxy * nxy];
        for (k, v) in level.iter_mut().enumerate() {
            let p = Vec2::new(column_xy(k % nxy) as f32, column_xy(k / nxy) as f32);
            *v = ash_blended(layers, blend, p) as f32;
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
/// up to its top, the curtain had a flat, hard lid above the umbrella; faded over the layer's
/// upper half only, with a noise-lowered ramp, its top seen edge-on from a camera near the lid
/// was a row of square notches. The top layer is also where the umbrella's spheres draw the
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
/// had a straight vertical edge kilometres tall. A rendering choice; the mass stays where the
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
/// reached the boundary stood as a wall with straight vertical edges (the box's own). A
/// rendering choice, like [`lid_fade`]; the ash budget is the layers'.
pub fn edge_fade(inside: f64, band: f64) -> f64 {
    if band.is_nan() || band <= 0.0 {
        return 1.0;
    }
    let t = (inside / band).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Streak factor of each voxel column (`nxy²`, x fastest): `max(0, 1 + a·p)` with `p` a Perlin
/// noise (mean 0, |p| ≤ 1) over `streak_m`-sized features, `a` = `spec.streaks`, so the factors
/// average ≈ 1 and the drawn ash mass follows the field.
pub fn streak_factors(spec: &AshVolumeSpec, extent: f64) -> Vec<f64> {
    let noise = Perlin::new(spec.seed);
    let nxy = spec.nxy;
    let mut out = Vec::with_capacity(nxy * nxy);
    for jy in 0..nxy {
        for ix in 0..nxy {
            let (x, y) = ((ix as f64 + 0.5) * extent / nxy as f64, (jy as f64 + 0.5) * extent / nxy as f64);
            // Perlin is 0 on integer lattice points: offset so columns do not land on them.
            let p = noise.get([x / spec.streak_m + 0.37, y / spec.streak_m + 0.71]);
            out.push((1.0 + spec.streaks * p.clamp(-1.0, 1.0)).max(0.0));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layers(grid: GridSpec) -> Vec<LayerFields> {
        // Three 1 km slabs from 0 to 3 km.
        (0..3)
            .map(|i| LayerFields::new(grid, 500.0 + 1000.0 * i as f64, 1000.0 * i as f64, 1000.0, 280.0))
            .collect()
    }

    fn spec(nxy: usize, nz: usize, streaks: f64) -> AshVolumeSpec {
        AshVolumeSpec {
            nxy,
            nz,
            z_min: 0.0,
            z_max: 3000.0,
            streaks,
            streak_m: 400.0,
            seed: 3,
            edge_fraction: 0.0,
            blur_m: 0.0,
            relief: 0.0,
            relief_m: 1500.0,
        }
    }

    #[test]
    fn levels_blend_the_layers_linearly_between_their_centres() {
        let grid = GridSpec::new(16, 250.0).unwrap();
        let mut ls = layers(grid);
        ls[1].ash.data_mut().fill(2.0);
        ls[2].ash.data_mut().fill(0.5);
        let refs: Vec<&LayerFields> = ls.iter().collect();
        // Six levels at 250, 750, …, 2,750 m; layer centres at 500, 1,500, 2,500 m.
        let v = ash_density_volume(&refs, grid, None, &spec(4, 6, 0.0)).unwrap();
        let level = |iz: usize| {
            let l = &v[iz * 16..(iz + 1) * 16];
            assert!(l.iter().all(|&c| c == l[0]), "uniform field, uniform level");
            l[0]
        };
        // Above the top layer's bottom (2,000 m) the lid fade, a smoothstep to 0 at 3,000 m:
        // 0.843 75 at 2,250 m, 0.156 25 at 2,750 m.
        let expect = [0.0, 0.5, 1.5, 2.0 - 0.25 * 1.5, (2.0 - 0.75 * 1.5) * 0.843_75, 0.5 * 0.156_25];
        for (iz, e) in expect.iter().enumerate() {
            assert!((level(iz) - e).abs() < 1e-6, "level {iz}: {} vs {e}", level(iz));
        }
        assert_eq!(layer_blend(&refs, -1.0), None);
        assert_eq!(layer_blend(&refs, 3000.0), None);
        assert_eq!(layer_blend(&refs, 2900.0), Some((2, 2, 0.0)));
    }

    #[test]
    fn denser_field_denser_voxels_and_nothing_under_the_ground() {
        let grid = GridSpec::new(16, 250.0).unwrap();
        let mut ls = layers(grid);
        // Ash twice as dense in the east half of layer 1.
        for k in 0..grid.cells() {
            ls[1].ash.data_mut()[k] = if grid.centre(k).0 > 0.0 { 2.0 } else { 1.0 };
        }
        let refs: Vec<&LayerFields> = ls.iter().collect();
        let s = spec(16, 6, 0.6);
        let v = ash_density_volume(&refs, grid, None, &s).unwrap();
        let f = streak_factors(&s, grid.extent());
        let iz = 2; // 1,250 m: 3/4 of layer 1, 1/4 of layer 0 (which holds no ash)
        for jy in 0..16 {
            // Columns well inside each half (the bilinear sample blends the middle).
            let (w, e) = (jy * 16 + 2, jy * 16 + 13);
            assert!((v[iz * 256 + w] as f64 - 0.75 * f[w]).abs() < 1e-6);
            assert!((v[iz * 256 + e] as f64 - 1.5 * f[e]).abs() < 1e-6);
        }
        // A 1,500 m ridge along the west half: layer 1's lower level (1,250 m) is underground there.
        let mut ground = grid.grid(0.0f32);
        for k in 0..grid.cells() {
            if grid.centre(k).0 < 0.0 {
                ground.data_mut()[k] = 1500.0;
            }
        }
        let g = ash_density_volume(&refs, grid, Some(&ground), &s).unwrap();
        assert_eq!(g[iz * 256 + 16 * 8 + 1], 0.0, "under the ridge");
        assert_eq!(g[iz * 256 + 16 * 8 + 14], v[iz * 256 + 16 * 8 + 14], "beside it");
        assert!(g[3 * 256 + 16 * 8 + 1] > 0.0, "above the ridge (1,750 m)");
    }

    #[test]
    fn the_ash_fades_out_toward_the_sides_of_the_footprint() {
        let grid = GridSpec::new(16, 250.0).unwrap();
        let mut ls = layers(grid);
        ls[1].ash.data_mut().fill(1.0);
        let refs: Vec<&LayerFields> = ls.iter().collect();
        // 16 columns of 250 m; a 1,000 m band (4 columns) along each side.
        let s = AshVolumeSpec { edge_fraction: 0.25, ..spec(16, 6, 0.0) };
        let v = ash_density_volume(&refs, grid, None, &s).unwrap();
        let row = |jy: usize| -> Vec<f32> { (0..16).map(|ix| v[(2 * 16 + jy) * 16 + ix]).collect() };
        let mid = row(8);
        // Rising from the west side to the middle, symmetric, full value well inside.
        assert!(mid[0] < 0.05 && mid[0] > 0.0, "{mid:?}");
        assert!(mid.windows(2).take(4).all(|w| w[1] > w[0]), "{mid:?}");
        assert!((mid[0] - mid[15]).abs() < 1e-6 && (mid[2] - mid[13]).abs() < 1e-6, "{mid:?}");
        assert!((mid[8] - 0.75).abs() < 1e-6, "{mid:?}");
        // By the distance to the nearest side: the south side fades row 1 as the west side
        // fades column 1.
        assert!((row(1)[8] - mid[1]).abs() < 1e-6 && (row(1)[1] - mid[1]).abs() < 1e-6, "{:?}", row(1));
        assert_eq!(edge_fade(0.0, 100.0), 0.0);
        assert_eq!(edge_fade(100.0, 100.0), 1.0);
        assert!((edge_fade(50.0, 100.0) - 0.5).abs() < 1e-12);
        assert_eq!(edge_fade(10.0, 0.0), 1.0);
    }

    /// Highest level (index) drawing at least a tenth of the full value, per column.
    fn tops(v: &[f32], nxy: usize, nz: usize, full: f32) -> Vec<usize> {
        (0..nxy * nxy)
            .map(|c| (0..nz).rev().find(|&iz| v[iz * nxy * nxy + c] >= 0.1 * full).unwrap_or(0))
            .collect()
    }

    /// With the default relief the curtain's top over a uniform field spans most of the 400 m
    /// the lid can drop in a 1 km top layer (a ruled line without), its sides' fade moves in and out along each side, and a column's
    /// lid is never raised above the stack's top nor lowered by more than a thickness.
    #[test]
    fn relief_makes_the_top_and_the_sides_ragged() {
        let grid = GridSpec::new(64, 250.0).unwrap();
        let mut ls = layers(grid);
        for l in &mut ls {
            l.ash.data_mut().fill(1.0);
        }
        let refs: Vec<&LayerFields> = ls.iter().collect();
        let nz = 60; // 50 m levels
        let flat = AshVolumeSpec { edge_fraction: 0.1, ..spec(64, nz, 0.0) };
        let ragged = AshVolumeSpec { relief: 0.8, ..flat };
        let (v0, v1) = (
            ash_density_volume(&refs, grid, None, &flat).unwrap(),
            ash_density_volume(&refs, grid, None, &ragged).unwrap(),
        );
        // Tops of the inner columns (away from the side fade).
        let inner = |t: Vec<usize>| -> Vec<usize> {
            (0..64 * 64)
                .filter(|c| (12..52).contains(&(c % 64)) && (12..52).contains(&(c / 64)))
                .map(|c| t[c])
                .collect()
        };
        let span = |t: &[usize]| 50.0 * (*t.iter().max().unwrap() - *t.iter().min().unwrap()) as f64;
        let (t0, t1) = (inner(tops(&v0, 64, nz, 1.0)), inner(tops(&v1, 64, nz, 1.0)));
        assert_eq!(span(&t0), 0.0, "without relief the top is flat");
        assert!(span(&t1) >= 250.0, "the ragged top spans {} m", span(&t1));
        // The side band: the first column reaching half the full value, along the west side.
        let half_in = |v: &[f32], jy: usize| (0..32).find(|&ix| v[(30 * 64 + jy) * 64 + ix] >= 0.5).unwrap();
        let west: Vec<usize> = (8..56).map(|jy| half_in(&v1, jy)).collect();
        assert!(west.iter().max().unwrap() - west.iter().min().unwrap() >= 2, "{west:?}");
        assert!((8..56).all(|jy| half_in(&v0, jy) == half_in(&v0, 8)), "without relief a straight side");
        let (drop, side) = relief_factors(&ragged, grid.extent());
        assert!(
            drop.iter().all(|d| (0.0..=0.8).contains(d)) && side.iter().all(|f| (0.52..=1.48).contains(f))
        );
        let (drop, side) = relief_factors(&flat, grid.extent());
        assert!(drop.iter().all(|&d| d == 0.0) && side.iter().all(|&f| f == 1.0));
    }

    #[test]
    fn the_blur_softens_an_upwind_edge_and_keeps_the_mass() {
        // A step: no ash in the west half, 1 g/m³ in the east half, on 64 columns.
        let n = 64;
        let mut level: Vec<f32> = (0..n * n).map(|k| if k % n >= n / 2 { 1.0 } else { 0.0 }).collect();
        let before: f32 = level.iter().sum();
        blur_level(&mut level, n, 3);
        let row = &level[20 * n..21 * n];
        // A ramp twelve columns wide (two passes of seven) instead of a jump between two.
        assert!(row[n / 2 - 7] < 1e-6 && row[n / 2 + 6] > 0.999, "{row:?}");
        assert!(row[n / 2 - 6] > 0.01 && row[n / 2 + 5] < 0.99, "{row:?}");
        assert!((row[n / 2 - 1] + row[n / 2] - 1.0).abs() < 1e-5, "symmetric: {row:?}");
        assert!(row.windows(2).all(|w| w[1] >= w[0] - 1e-6), "{row:?}");
        // Mass kept (edges clamped: the step does not touch the east and west sides' ends).
        let after: f32 = level.iter().sum();
        assert!((after - before).abs() < 1e-3 * before, "{before} → {after}");
        // No blur: unchanged.
        let mut same = vec![0.5f32; 16];
        blur_level(&mut same, 4, 0);
        assert!(same.iter().all(|&v| v == 0.5));
    }

    #[test]
    fn streaks_vary_but_keep_the_mean() {
        let s = spec(128, 2, 0.6);
        let f = streak_factors(&s, 25_600.0);
        let mean = f.iter().sum::<f64>() / f.len() as f64;
        let var = f.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / f.len() as f64;
        assert!((mean - 1.0).abs() < 0.05, "mean streak factor {mean}");
        assert!(var.sqrt() > 0.1, "streaks too weak: σ = {}", var.sqrt());
        assert!(f.iter().all(|&x| x >= 0.0));
        assert!(streak_factors(&spec(8, 2, 0.0), 1000.0).iter().all(|&x| x == 1.0));
    }

    #[test]
    fn bad_input_is_an_error_or_ignored() {
        let grid = GridSpec::new(16, 100.0).unwrap();
        let mut ls = layers(grid);
        ls[0].ash.data_mut()[0] = f64::NAN;
        ls[0].ash.data_mut()[1] = -1.0;
        let refs: Vec<&LayerFields> = ls.iter().collect();
        let v = ash_density_volume(&refs, grid, None, &spec(4, 3, 0.0)).unwrap();
        assert!(v.iter().all(|c| c.is_finite() && *c >= 0.0));
        let e = ash_density_volume(&refs, grid, None, &spec(1, 3, 0.0)).unwrap_err().to_string();
        assert!(e.contains("voxels_xy"), "{e}");
        let e = ash_density_volume(&refs, grid, None, &spec(4, 3, 1.5)).unwrap_err().to_string();
        assert!(e.contains("streaks"), "{e}");
    }
}
