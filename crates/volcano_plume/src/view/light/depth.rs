//! The optical-depth grid of [`super::light_parents`]: the parents' extinction splatted on a
//! coarse grid whose third axis points at the light, summed toward it once per grid column.
//!
//! Cost: a frame has ~6,000 parents (the plume bench's column: 1–6 cells in radius at the
//! default 64 cells per axis), each splatted on two grids. A ball's cells are found by sweeping
//! its bounding box with the inside test, one comparison per cell that compiles to vector
//! selects ([`Ball::for_each_column`]); a lookup finds the parent's own share in the few grid
//! columns it reads ([`Ball::run`]) instead of scanning the whole ball. Testing every cell
//! with a square root and a pushed list, then scanning that list again for each corner of
//! every lookup, would cost 80 ms a frame (`cargo bench -p volcano_plume --bench plume_ecs`).

use bevy::prelude::*;

use super::{ParentSphere, valid};

/// Largest radius (cells) a parent is splatted over; a larger one puts all its mass inside it.
const MAX_SPAN: f32 = 12.0;

/// Optical depth toward a light, on a grid whose third axis points at it.
pub(super) struct DepthGrid {
    /// Rows: the grid axes u, v, w (w toward the light).
    axes: [Vec3; 3],
    /// Grid coordinates of the lower corner.
    origin: Vec3,
    /// Cell size (m).
    h: f32,
    dims: [usize; 3],
    /// Optical depth from each cell centre to the grid's end toward the light.
    tau: Vec<f32>,
    /// Fraction of the splatted extinction each cell kept under its density cap (1 where the
    /// parents' sum stayed below it): a parent's own share of a cell is scaled by it too.
    kept: Vec<f32>,
    /// Per parent (same order as the slice the grid was built from): the weight `1 / n` of
    /// each of the `n` cells of its ball, or 0 if its mass went to trilinear points instead.
    ball_weight: Vec<f32>,
    extinction: f32,
}

/// The cells of a parent wider than a cell: those whose centre lies within `span` of `g`
/// (cell-centre coordinates) and inside the grid, found column by column.
#[derive(Debug, Clone, Copy)]
struct Ball {
    g: Vec3,
    span2: f32,
    /// Inclusive cell ranges of the ball's bounding box, clamped to the grid.
    lo: [usize; 3],
    hi: [usize; 3],
}

impl Ball {
    /// Calls `f(first_cell, dz², dxy²)` for every grid column `(x, y)` of the ball's bounding
    /// box that it reaches: `first_cell` is the index of the column's cell `lo[2]`, `dz²` the
    /// squared offsets of its cells `lo[2]..=hi[2]` from the centre, `dxy²` the column's.
    /// A cell is inside when `dxy² + dz² ≤ span²` (the test of [`Self::run`] too). Sweeping
    /// the whole box with that test, a comparison per cell that compiles to vector selects, is
    /// faster than finding each column's run (a square root, rounding and four tests per
    /// column: 65 ns a column here, for columns of 5 cells on average).
    fn for_each_column(&self, dims: [usize; 3], mut f: impl FnMut(usize, &[f32], f32)) {
        let mut dz2 = [0.0f32; 2 * MAX_SPAN as usize + 2];
        let depth = (self.hi[2] + 1).saturating_sub(self.lo[2]).min(dz2.len());
        for (k, d) in dz2[..depth].iter_mut().enumerate() {
            let dz = (self.lo[2] + k) as f32 - self.g.z;
            *d = dz * dz;
        }
        for x in self.lo[0]..=self.hi[0] {
            let dx = x as f32 - self.g.x;
            for y in self.lo[1]..=self.hi[1] {
                let dy = y as f32 - self.g.y;
                let dxy2 = dx * dx + dy * dy;
                if depth > 0 && dxy2 <= self.span2 {
                    f((x * dims[1] + y) * dims[2] + self.lo[2], &dz2[..depth], dxy2);
                }
            }
        }
    }

    /// Cells `z0..=z1` of grid column `(x, y)` inside the ball, if any (for lookups: the
    /// splat sweeps the box). A cell is inside when `(dx² + dy²) + dz² ≤ span²`. That sum
    /// grows with `|dz|` in floating point too, so the inside cells are one run; a square root
    /// puts each end within a cell of the truth and one test each way settles it.
    fn run(&self, x: usize, y: usize) -> Option<(usize, usize)> {
        let (lo, hi) = (self.lo, self.hi);
        if x < lo[0] || x > hi[0] || y < lo[1] || y > hi[1] {
            return None;
        }
        let (dx, dy) = (x as f32 - self.g.x, y as f32 - self.g.y);
        let dxy2 = dx * dx + dy * dy;
        let inside = |z: i64| {
            let dz = z as f32 - self.g.z;
            dxy2 + dz * dz <= self.span2
        };
        let t = (self.span2 - dxy2).max(0.0).sqrt();
        let mut z0 = -floor(t - self.g.z);
        z0 -= i64::from(inside(z0 - 1));
        z0 += i64::from(!inside(z0));
        let mut z1 = floor(self.g.z + t);
        z1 += i64::from(inside(z1 + 1));
        z1 -= i64::from(!inside(z1));
        let (z0, z1) = (z0.max(lo[2] as i64), z1.min(hi[2] as i64));
        (z0 <= z1).then_some((z0 as usize, z1 as usize))
    }
}

/// `⌊v⌋` for the cell coordinates here (finite, far inside `i64`), without the library call
/// `f32::floor` is on baseline x86-64 (no SSE4.1 rounding instruction).
fn floor(v: f32) -> i64 {
    let i = v as i64;
    i - i64::from(i as f32 > v)
}

impl DepthGrid {
    pub(super) fn build(
        parents: &[ParentSphere],
        toward: Vec3,
        extinction: f32,
        max_cells: usize,
    ) -> Option<Self> {
        let w = toward;
        let u = w.any_orthonormal_vector();
        let axes = [u, w.cross(u), w];
        let local = |c: Vec3| Vec3::new(c.dot(axes[0]), c.dot(axes[1]), c.dot(axes[2]));
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in parents.iter().filter(|p| valid(p)) {
            let c = local(p.center);
            lo = lo.min(c - p.radius);
            hi = hi.max(c + p.radius);
        }
        if !lo.is_finite() || !hi.is_finite() {
            return None;
        }
        let extent = hi - lo;
        let h = (extent.max_element() / max_cells as f32).max(1.0);
        let dims = (extent / h).to_array().map(|e| (e.ceil() as usize).clamp(1, max_cells));
        let cells = dims[0] * dims[1] * dims[2];
        let mut grid = Self {
            axes,
            origin: lo,
            h,
            dims,
            tau: vec![0.0; cells],
            kept: vec![1.0; cells],
            ball_weight: vec![0.0; parents.len()],
            extinction,
        };
        // Extinction coefficient per cell (1/m), then the running sum toward the light. The
        // parents are overlapping samples of one continuum (a slice's ring spheres overlap
        // their neighbours, and a column's slices overlap many deep), so their masses are not
        // stacked: a cell holds at most the density of the densest parent reaching it (their
        // union). Sparse puffs smaller than a cell still add up below that cap.
        let mut sigma = vec![0.0f32; cells];
        let mut cap = vec![0.0f32; cells];
        for (index, p) in parents.iter().enumerate().filter(|(_, p)| valid(p)) {
            let s = grid.cross_section(p) / (h * h * h);
            let densest = extinction * p.density;
            let ball = grid.ball(p);
            let mut n = 0usize;
            if let Some(ball) = &ball {
                ball.for_each_column(dims, |_, dz2, dxy2| {
                    n += dz2.iter().filter(|&&d| dxy2 + d <= ball.span2).count();
                });
            }
            match ball.filter(|_| n > 0) {
                Some(ball) => {
                    let weight = 1.0 / n as f32;
                    grid.ball_weight[index] = weight;
                    let add = s * weight;
                    ball.for_each_column(dims, |first, dz2, dxy2| {
                        let cells = first..first + dz2.len();
                        for ((sg, cp), &d) in sigma[cells.clone()].iter_mut().zip(&mut cap[cells]).zip(dz2) {
                            let inside = dxy2 + d <= ball.span2;
                            // + 0.0 keeps every bit of a sum that starts at +0 and only grows.
                            *sg += if inside { add } else { 0.0 };
                            *cp = if inside { cp.max(densest) } else { *cp };
                        }
                    });
                }
                None => grid.trilinear(grid.cell_coords(p.center), |cell, wt| {
                    let i = grid.index(cell);
                    sigma[i] += s * wt;
                    cap[i] = cap[i].max(densest);
                }),
            }
        }
        for ((s, &c), kept) in sigma.iter_mut().zip(&cap).zip(grid.kept.iter_mut()) {
            if *s > c {
                *kept = c / *s;
                *s = c;
            }
        }
        let [nx, ny, nz] = dims;
        for i in 0..nx * ny {
            let mut acc = 0.0;
            for k in (0..nz).rev() {
                let c = i * nz + k;
                grid.tau[c] = acc + 0.5 * sigma[c] * h;
                acc += sigma[c] * h;
            }
        }
        Some(grid)
    }

    /// Extinction cross-section of a parent, `κ ρ V` (m²).
    fn cross_section(&self, p: &ParentSphere) -> f32 {
        self.extinction * p.density * 4.0 / 3.0 * std::f32::consts::PI * p.radius.powi(3)
    }

    fn local(&self, c: Vec3) -> Vec3 {
        (Vec3::new(c.dot(self.axes[0]), c.dot(self.axes[1]), c.dot(self.axes[2])) - self.origin) / self.h
    }

    /// A world point in cell-centre coordinates (cell `(i, j, k)`'s centre at `(i, j, k)`).
    fn cell_coords(&self, c: Vec3) -> Vec3 {
        self.local(c) - 0.5
    }

    fn index(&self, i: [usize; 3]) -> usize {
        (i[0] * self.dims[1] + i[1]) * self.dims[2] + i[2]
    }

    /// The ball a parent wider than a cell is splatted over (radius capped at [`MAX_SPAN`]).
    fn ball(&self, p: &ParentSphere) -> Option<Ball> {
        let r = p.radius / self.h;
        if r <= 1.0 {
            return None;
        }
        let g = self.cell_coords(p.center);
        let span = r.min(MAX_SPAN);
        Some(Ball {
            g,
            span2: span * span,
            // ⌈g − span⌉ and ⌊g + span⌋, clamped to the grid.
            lo: [0, 1, 2].map(|a| (-floor(span - g[a])).max(0) as usize),
            hi: [0, 1, 2].map(|a| (floor(g[a] + span).max(0) as usize).min(self.dims[a] - 1)),
        })
    }

    /// Calls `f(cell, weight)` for the (up to 8) cells around `g` (cell-centre coordinates,
    /// clamped to the grid).
    fn trilinear(&self, g: Vec3, mut f: impl FnMut([usize; 3], f32)) {
        let max = Vec3::new(self.dims[0] as f32, self.dims[1] as f32, self.dims[2] as f32) - 1.0;
        let g = g.clamp(Vec3::ZERO, max);
        // g ≥ 0: truncation is the floor, without the library call `floorf` is on baseline
        // x86-64 (6 % of the light of 50,000 particles).
        let cell = [g.x as usize, g.y as usize, g.z as usize];
        let t = g - Vec3::new(cell[0] as f32, cell[1] as f32, cell[2] as f32);
        for corner in 0..8u32 {
            let o = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let mut wt = 1.0;
            let mut idx = [0usize; 3];
            for a in 0..3 {
                let ta = t[a];
                wt *= if o[a] == 1 { ta } else { 1.0 - ta };
                idx[a] = (cell[a] + o[a] as usize).min(self.dims[a] - 1);
            }
            if wt > 0.0 {
                f(idx, wt);
            }
        }
    }

    /// Optical depth from parent `index`'s (`p`'s) light-facing surface to the light, without
    /// the parent's own contribution; `p` must be the parent the grid was built with at
    /// `index`.
    pub(super) fn depth_at_surface(&self, index: usize, p: &ParentSphere) -> f32 {
        if !valid(p) {
            return 0.0;
        }
        let q = self.cell_coords(p.center + self.axes[2] * p.radius);
        let nz = self.dims[2];
        let own_sigma = self.cross_section(p) / (self.h * self.h * self.h);
        let weight = self.ball_weight.get(index).copied().unwrap_or(0.0);
        let ball = if weight > 0.0 { self.ball(p) } else { None };
        // A small parent's own cells, as grid coordinates (no divisions in the loop below:
        // they would be most of a lookup's cost).
        let (mut points, mut count) = ([([0usize; 3], 0.0f32); 8], 0);
        if ball.is_none() {
            self.trilinear(self.cell_coords(p.center), |cell, wt| {
                points[count] = (cell, wt);
                count += 1;
            });
        }
        let (mut total, mut mine) = (0.0, 0.0);
        self.trilinear(q, |[x, y, k], wt| {
            let column = (x * self.dims[1] + y) * nz;
            total += wt * self.tau[column + k];
            // The parent's share of tau[c]: its cells in the same grid column at or beyond c
            // (half of c itself, whose tau counts half its own cell).
            let mut add = |z: usize, ow: f32| {
                let part = if z == k { 0.5 } else { 1.0 };
                mine += wt * part * own_sigma * ow * self.h * self.kept[column + z];
            };
            if let Some(run) = ball.and_then(|b| b.run(x, y)) {
                (run.0.max(k)..=run.1).for_each(|z| add(z, weight));
            }
            for &([ox, oy, oz], ow) in &points[..count] {
                if ox == x && oy == y && oz >= k {
                    add(oz, ow);
                }
            }
        });
        (total - mine).max(0.0)
    }
}

#[cfg(test)]
mod tests;
