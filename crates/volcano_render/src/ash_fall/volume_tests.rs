//! Tests of [`super`]: the ash volume's fields, streaks, fades, blur and meander.

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
        meander_m: 0.0,
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
fn each_voxel_is_the_blend_of_the_layers_at_its_column() {
    // A field that varies within cells (not a multiple of the voxel size), NaN and negative
    // cells: the columns sampled once per layer give what `ash_blended` gives per voxel.
    let grid = GridSpec::new(32, 130.0).unwrap();
    let mut ls = layers(grid);
    for (i, l) in ls.iter_mut().enumerate() {
        for k in 0..grid.cells() {
            let (x, y) = grid.centre(k);
            l.ash.data_mut()[k] = 0.01 * (1.0 + i as f64) * (1.0 + (x / 700.0).sin() * (y / 450.0).cos());
        }
        l.ash.data_mut()[5] = f64::NAN;
        l.ash.data_mut()[9] = -1.0;
    }
    let refs: Vec<&LayerFields> = ls.iter().collect();
    let (n, nz) = (20, 12);
    let s = spec(n, nz, 0.0);
    let v = ash_density_volume(&refs, grid, None, &s).unwrap();
    let extent = grid.extent();
    let column = |i: usize| (-0.5 * extent + (i as f64 + 0.5) * extent / n as f64) as f32;
    let mut checked = 0;
    for iz in 0..nz {
        let z = s.level_altitude(iz);
        // Below the top layer, where no lid fade applies.
        let Some(blend) = layer_blend(&refs, z).filter(|_| z < 2_000.0) else { continue };
        for k in 0..n * n {
            let want =
                volcano_atmosphere::view::ash_blended(&refs, blend, Vec2::new(column(k % n), column(k / n)));
            assert_eq!(v[iz * n * n + k], want as f32, "level {iz}, voxel {k}");
            checked += 1;
        }
    }
    assert!(checked >= 6 * n * n, "{checked}");
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
    assert!(drop.iter().all(|d| (0.0..=0.8).contains(d)) && side.iter().all(|f| (0.52..=1.48).contains(f)));
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
fn streaks_are_shafts_and_gaps_several_voxels_wide_with_mean_one() {
    // The eruption scene's volume: 128 voxels over 25.6 km (200 m each).
    let (n, extent) = (128, 25_600.0);
    let f = streak_factors(&AshVolumeSpec { streaks: 1.0, streak_m: 1_500.0, ..spec(n, 2, 1.0) }, extent);
    let mean = f.iter().sum::<f64>() / f.len() as f64;
    assert!((mean - 1.0).abs() < 1e-9, "mean streak factor {mean}");
    assert!(f.iter().all(|&x| x >= 0.0));
    // Gaps and shafts: columns nearly empty and columns well over the field.
    let share = |pred: &dyn Fn(f64) -> bool| f.iter().filter(|&&x| pred(x)).count() as f64 / f.len() as f64;
    let (gaps, shafts) = (share(&|x| x < 0.3), share(&|x| x > 1.6));
    assert!(gaps > 0.05 && shafts > 0.05, "gaps {gaps:.3}, shafts {shafts:.3}");
    // Wide enough to survive the filtering: neighbours 2 voxels apart still correlate.
    let var = f.iter().map(|x| (x - 1.0).powi(2)).sum::<f64>();
    let cov: f64 = (0..n * n).filter(|k| k % n + 2 < n).map(|k| (f[k] - 1.0) * (f[k + 2] - 1.0)).sum();
    let r2 = cov / var * (n * n) as f64 / ((n - 2) * n) as f64;
    assert!(r2 > 0.5, "streaks decorrelate within 2 voxels: r = {r2:.2}");
    assert!(streak_factors(&spec(8, 2, 0.0), 1000.0).iter().all(|&x| x == 1.0));
}

#[test]
fn meandering_sides_wander_with_altitude_and_keep_the_ash_in_the_curtain() {
    // Every layer holds the same disc of ash (r = 4 km): without meander each level draws
    // it where the others do, the sides straight up.
    let grid = GridSpec::new(64, 400.0).unwrap();
    let mut ls = layers(grid);
    for l in &mut ls {
        for k in 0..64 * 64 {
            let (x, y) = grid.centre(k);
            l.ash.data_mut()[k] = if x.hypot(y) < 4_000.0 { 0.05 } else { 0.0 };
        }
    }
    let refs: Vec<&LayerFields> = ls.iter().collect();
    let (n, nz) = (64, 24);
    // Per level: the ash's sum and the x of its east edge on the row through the centre.
    let profile = |v: &[f32]| -> Vec<(f64, usize)> {
        (0..nz)
            .map(|iz| {
                let level = &v[iz * n * n..(iz + 1) * n * n];
                let row = &level[(n / 2) * n..(n / 2 + 1) * n];
                let east = (0..n).rev().find(|&i| row[i] > 0.025).unwrap_or(0);
                (level.iter().map(|&c| c as f64).sum(), east)
            })
            .collect()
    };
    let straight = profile(&ash_density_volume(&refs, grid, None, &spec(n, nz, 0.0)).unwrap());
    let meander = AshVolumeSpec { meander_m: 1_500.0, relief_m: 6_000.0, ..spec(n, nz, 0.0) };
    let wandering = profile(&ash_density_volume(&refs, grid, None, &meander).unwrap());
    // Below the top layer (whose ash fades out upward, `lid_fade`).
    let full = straight.iter().take_while(|&&(sum, _)| sum > 0.95 * straight[0].0).count();
    assert!(full >= 12, "{straight:?}");
    let edges = |p: &[(f64, usize)]| {
        let e: Vec<usize> = p[..full].iter().map(|&(_, e)| e).collect();
        *e.iter().max().unwrap() - *e.iter().min().unwrap()
    };
    assert_eq!(edges(&straight), 0, "{straight:?}");
    // 400 m voxels: the east edge moves by at least 2 voxels (800 m) over the levels.
    assert!(edges(&wandering) >= 2, "the side stands straight: {wandering:?}");
    let worst = straight.iter().zip(&wandering).map(|(a, b)| (b.0 / a.0 - 1.0).abs()).fold(0.0, f64::max);
    eprintln!(
        "east edge moves over {} voxels; level ash changed by at most {:.1} %",
        edges(&wandering),
        100.0 * worst
    );
    for (iz, (&(a, _), &(b, _))) in straight.iter().zip(&wandering).enumerate() {
        assert!((b - a).abs() < 0.25 * a, "level {iz}: ash {a:.1} drawn as {b:.1}");
    }
    assert!(meander_offsets(&spec(n, nz, 0.0), 25_600.0).is_empty());
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
