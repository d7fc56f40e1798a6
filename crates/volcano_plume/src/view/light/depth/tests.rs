use rand::RngExt;

use super::super::sphere;
use super::*;

/// A parent's cells by their definition, every cell of the grid tested (x, then y, then z
/// ascending): those whose centre lies within the capped radius, `1 / n` each; if there are
/// none (or the parent is not wider than a cell), the trilinear points of its centre.
fn cells_by_definition(grid: &DepthGrid, p: &ParentSphere) -> Vec<(usize, f32)> {
    let g = grid.cell_coords(p.center);
    let span = (p.radius / grid.h).min(MAX_SPAN);
    let mut out = Vec::new();
    if p.radius / grid.h > 1.0 {
        for x in 0..grid.dims[0] {
            for y in 0..grid.dims[1] {
                for z in 0..grid.dims[2] {
                    if (Vec3::new(x as f32, y as f32, z as f32) - g).length_squared() <= span * span {
                        out.push((grid.index([x, y, z]), 1.0));
                    }
                }
            }
        }
    }
    let n = out.len();
    out.iter_mut().for_each(|c| c.1 = 1.0 / n as f32);
    if n == 0 {
        grid.trilinear(g, |cell, wt| out.push((grid.index(cell), wt)));
    }
    out
}

/// The depth at a parent's surface with its own share found by scanning all its cells for
/// each corner of the lookup.
fn depth_by_scanning(grid: &DepthGrid, p: &ParentSphere) -> f32 {
    let q = grid.cell_coords(p.center + grid.axes[2] * p.radius);
    let nz = grid.dims[2];
    let own = cells_by_definition(grid, p);
    let own_sigma = grid.cross_section(p) / (grid.h * grid.h * grid.h);
    let (mut total, mut mine) = (0.0, 0.0);
    grid.trilinear(q, |cell, wt| {
        let c = grid.index(cell);
        total += wt * grid.tau[c];
        let (column, k) = (c / nz, c % nz);
        for &(o, ow) in &own {
            if o / nz == column && o % nz >= k {
                let part = if o % nz == k { 0.5 } else { 1.0 };
                mine += wt * part * own_sigma * ow * grid.h * grid.kept[o];
            }
        }
    });
    (total - mine).max(0.0)
}

/// The grid's `tau` and `kept` built from [`cells_by_definition`].
fn grid_by_definition(grid: &DepthGrid, parents: &[ParentSphere]) -> (Vec<f32>, Vec<f32>) {
    let (mut sigma, mut cap) = (vec![0.0f32; grid.tau.len()], vec![0.0f32; grid.tau.len()]);
    for p in parents.iter().filter(|p| valid(p)) {
        let s = grid.cross_section(p) / (grid.h * grid.h * grid.h);
        for (i, wt) in cells_by_definition(grid, p) {
            sigma[i] += s * wt;
            cap[i] = cap[i].max(grid.extinction * p.density);
        }
    }
    let mut kept = vec![1.0; sigma.len()];
    for ((s, &c), k) in sigma.iter_mut().zip(&cap).zip(&mut kept) {
        if *s > c {
            *k = c / *s;
            *s = c;
        }
    }
    let nz = grid.dims[2];
    let mut tau = vec![0.0; sigma.len()];
    for column in 0..grid.dims[0] * grid.dims[1] {
        let mut acc = 0.0;
        for c in (column * nz..(column + 1) * nz).rev() {
            tau[c] = acc + 0.5 * sigma[c] * grid.h;
            acc += sigma[c] * grid.h;
        }
    }
    (tau, kept)
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_grid_and_its_lookups_match_testing_every_cell() {
    let mut rng = volcano_core::rng::derive_stream(11, 0);
    // Radii from a tenth of a cell to past the 12-cell cap, some balls reaching out of the
    // grid, and a stack on the axis (cell centres and faces: ties for the nearest cell).
    let mut parents: Vec<ParentSphere> = (0..300u64)
        .map(|i| {
            let c = Vec3::new(
                rng.random_range(-3e3..3e3),
                rng.random_range(0.0..6e3),
                rng.random_range(-3e3..3e3),
            );
            sphere(i, c, 10f32.powf(rng.random_range(0.5..3.6)), rng.random_range(0.01..2.0))
        })
        .collect();
    for (i, id) in (0..40).zip(300u64..) {
        parents.push(sphere(id, Vec3::new(0.0, 100.0 * i as f32, 0.0), 50.0 * (1 + i % 9) as f32, 0.5));
    }
    for sun in [Vec3::new(0.3, 0.8, -0.5), Vec3::Y, Vec3::X] {
        let grid = DepthGrid::build(&parents, sun.normalize(), 0.003, 32).unwrap();
        let (tau, kept) = grid_by_definition(&grid, &parents);
        assert_eq!(bits(&grid.tau), bits(&tau), "sun {sun}");
        assert_eq!(bits(&grid.kept), bits(&kept), "sun {sun}");
        let [nx, ny, nz] = grid.dims;
        let mut balls = 0;
        for (index, p) in parents.iter().enumerate() {
            let cells = cells_by_definition(&grid, p);
            let weight = grid.ball_weight[index];
            if weight > 0.0 {
                balls += 1;
                assert_eq!(weight, cells[0].1, "{p:?}");
                // Each column's run is the column's cells by definition.
                let ball = grid.ball(p).unwrap();
                for column in 0..nx * ny {
                    let run: Vec<usize> = ball
                        .run(column / ny, column % ny)
                        .map_or(Vec::new(), |(z0, z1)| (z0..=z1).map(|z| column * nz + z).collect());
                    let mine: Vec<usize> = cells.iter().map(|c| c.0).filter(|&c| c / nz == column).collect();
                    assert_eq!(run, mine, "{p:?}, column {column}");
                }
            } else {
                assert!(cells.len() <= 8, "{p:?}");
            }
            let (new, scanned) = (grid.depth_at_surface(index, p), depth_by_scanning(&grid, p));
            assert_eq!(new.to_bits(), scanned.to_bits(), "{p:?}: {new} vs {scanned}");
        }
        assert!(balls > 50 && balls < parents.len() - 50, "both kinds of parent: {balls} balls");
    }
}
