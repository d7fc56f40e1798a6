//! The collision surface (terrain + deposit) as the particle step reads it: a bilinear sample
//! of the deposit map's `surface` grid, bit for bit what `Grid2::sample(p, Boundary::Clamp)`
//! returns, with the grid's geometry read once per step instead of once per sample and the
//! floor taken without a call into libm (the default x86-64 target has no rounding
//! instruction). A particle samples it five times per substep (height and normal), so this is
//! the inner loop of the domain.

use bevy::math::{Vec2, Vec3};
use volcano_core::Grid2;

/// A read-only view of a `Grid2<f32>` for clamped bilinear sampling.
#[derive(Debug, Clone, Copy)]
pub struct Surface<'a> {
    data: &'a [f32],
    nx: usize,
    ny: usize,
    origin: (f64, f64),
    cell: f64,
}

impl<'a> Surface<'a> {
    /// The view of `grid`.
    pub fn new(grid: &'a Grid2<f32>) -> Self {
        let o = grid.origin();
        Self {
            data: grid.data(),
            nx: grid.nx(),
            ny: grid.ny(),
            origin: (o.x as f64, o.y as f64),
            cell: grid.cell(),
        }
    }

    /// `grid.sample(p, Boundary::Clamp)`, bit for bit (the same operations in the same order).
    #[inline]
    pub fn sample(&self, p: Vec2) -> f32 {
        let gx = finite_or_zero((p.x as f64 - self.origin.0) / self.cell);
        let gy = finite_or_zero((p.y as f64 - self.origin.1) / self.cell);
        let (fx, fy) = (floor(gx), floor(gy));
        let (tx, ty) = (gx - fx, gy - fy);
        let (i, j) = (fx as i64, fy as i64);
        let a = lerp(self.at(i, j), self.at(i + 1, j), tx);
        let c = lerp(self.at(i, j + 1), self.at(i + 1, j + 1), tx);
        lerp(a, c, ty)
    }

    /// Height (plume frame, m above the vent at world `vent`) under plume-frame `(x, y)`:
    /// [`super::ground_below`] with this surface.
    #[inline]
    pub fn below(&self, vent: Vec3, x: f64, y: f64) -> f64 {
        (self.sample(Vec2::new(vent.x + x as f32, vent.z - y as f32)) - vent.y) as f64
    }

    #[inline]
    fn at(&self, i: i64, j: i64) -> f32 {
        let i = i.clamp(0, self.nx as i64 - 1) as usize;
        let j = j.clamp(0, self.ny as i64 - 1) as usize;
        self.data[j * self.nx + i]
    }
}

/// As `volcano_core::grid`'s: non-finite coordinates sample at the origin.
#[inline]
fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() { x.clamp(-1e15, 1e15) } else { 0.0 }
}

/// `f32::lerp` of `volcano_core::grid::Lerp`: `a + (b − a)·t`.
#[inline]
fn lerp(a: f32, b: f32, t: f64) -> f32 {
    a + (b - a) * t as f32
}

/// `x.floor()` for finite `|x| ≤ 1e15` (what `finite_or_zero` leaves), signed zeros included:
/// truncation, one down for negative non-integers, and the sign of `x` (a floor never changes
/// it: `floor(−0.3) = −1`, `floor(−0.0) = −0.0`, `floor(0.3) = +0.0`).
#[inline]
fn floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    (if t > x { t - 1.0 } else { t }).copysign(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;
    use volcano_core::Boundary;
    use volcano_core::rng::derive_stream;

    #[test]
    fn floor_is_the_standard_floor() {
        let xs = [0.0, -0.0, 0.3, -0.3, 1.0, -1.0, 2.5, -2.5, 511.999_999, -1e15, 1e15, 4.9e-324, -4.9e-324];
        for x in xs {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
        let mut rng = derive_stream(1, 1);
        for _ in 0..100_000 {
            let x: f64 = rng.random_range(-1e4..1e4);
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
    }

    #[test]
    fn samples_are_the_grids_bit_for_bit() {
        let mut rng = derive_stream(1, 2);
        let (nx, ny) = (37, 23);
        let data: Vec<f32> = (0..nx * ny).map(|_| rng.random_range(-50.0..3_000.0)).collect();
        let mut grid = Grid2::new(nx, ny, 40.0, Vec2::new(-731.5, -459.25), 0.0f32).unwrap();
        grid.data_mut().copy_from_slice(&data);
        let view = Surface::new(&grid);
        let mut points: Vec<Vec2> = (0..200_000)
            .map(|_| Vec2::new(rng.random_range(-1_000.0..1_000.0), rng.random_range(-700.0..700.0)))
            .collect();
        // Nodes, edges, far outside, non-finite.
        for (i, j) in [(0, 0), (nx - 1, ny - 1), (5, 7), (nx - 1, 0)] {
            points.push(grid.position(i, j));
        }
        points.extend([
            Vec2::new(f32::NAN, 0.0),
            Vec2::new(f32::INFINITY, f32::NEG_INFINITY),
            Vec2::new(1e30, -1e30),
            Vec2::new(-0.0, -0.0),
        ]);
        for p in points {
            assert_eq!(view.sample(p).to_bits(), grid.sample(p, Boundary::Clamp).to_bits(), "{p}");
        }
    }
}
