//! [`Grid2`]: a regular 2D field stored as one flat `Vec` (structure of arrays: a vector field
//! is two `Grid2<f32>`, not a `Grid2<Vec2>`), with cell size, origin, bilinear sampling,
//! finite differences and wrap/clamp boundaries.
//!
//! Sample `(i, j)` sits at `origin + (i, j) · cell`. Grid `x` is world `x`, grid `y` is world
//! `z` (Bevy is y-up).

use bevy::math::Vec2;
use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, positive};

/// How indices outside the grid are resolved.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect, Serialize, Deserialize)]
pub enum Boundary {
    /// Use the nearest edge sample.
    #[default]
    Clamp,
    /// Toroidal: indices wrap around.
    Wrap,
}

impl Boundary {
    /// Resolves a possibly out-of-range index on an axis of length `n` (n ≥ 1).
    #[inline]
    pub fn resolve(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        match self {
            Boundary::Clamp => i.clamp(0, n - 1) as usize,
            Boundary::Wrap => i.rem_euclid(n) as usize,
        }
    }
}

/// Values that can be linearly interpolated (for bilinear sampling).
pub trait Lerp: Copy {
    /// `a + (b − a)·t`.
    fn lerp(a: Self, b: Self, t: f64) -> Self;
}

impl Lerp for f32 {
    fn lerp(a: Self, b: Self, t: f64) -> Self {
        a + (b - a) * t as f32
    }
}
impl Lerp for f64 {
    fn lerp(a: Self, b: Self, t: f64) -> Self {
        a + (b - a) * t
    }
}

/// A 2D field of `nx × ny` samples, row-major (`x` fastest).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Grid2<T> {
    nx: usize,
    ny: usize,
    cell: f64,
    origin: Vec2,
    data: Vec<T>,
}

impl<T: Copy> Grid2<T> {
    /// A grid filled with `value`. Errors on a zero dimension or a non-positive cell size.
    pub fn new(nx: usize, ny: usize, cell: f64, origin: Vec2, value: T) -> Result<Self, ConfigError> {
        Self::check_dims(nx, ny, cell, origin)?;
        Ok(Self { nx, ny, cell, origin, data: vec![value; nx * ny] })
    }

    /// A grid from existing row-major data; errors if the length does not match.
    pub fn from_vec(
        nx: usize,
        ny: usize,
        cell: f64,
        origin: Vec2,
        data: Vec<T>,
    ) -> Result<Self, ConfigError> {
        Self::check_dims(nx, ny, cell, origin)?;
        if data.len() != nx * ny {
            return Err(ConfigError::InvalidParameter {
                name: "grid data length",
                value: data.len() as f64,
                reason: format!("must equal nx·ny = {}", nx * ny),
            });
        }
        Ok(Self { nx, ny, cell, origin, data })
    }

    fn check_dims(nx: usize, ny: usize, cell: f64, origin: Vec2) -> Result<(), ConfigError> {
        if nx == 0 || ny == 0 {
            return Err(ConfigError::InvalidParameter {
                name: "grid size",
                value: (nx.min(ny)) as f64,
                reason: "both dimensions must be at least 1".into(),
            });
        }
        positive("cell size", cell)?;
        if !origin.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "grid origin",
                value: f64::NAN,
                reason: "must be finite".into(),
            });
        }
        Ok(())
    }

    /// Samples along x.
    pub fn nx(&self) -> usize {
        self.nx
    }
    /// Samples along y.
    pub fn ny(&self) -> usize {
        self.ny
    }
    /// Distance between samples (m).
    pub fn cell(&self) -> f64 {
        self.cell
    }
    /// World position of sample (0, 0).
    pub fn origin(&self) -> Vec2 {
        self.origin
    }
    /// Moves the grid: sample (0, 0) to `origin` (finite: callers check).
    pub(crate) fn set_origin(&mut self, origin: Vec2) {
        debug_assert!(origin.is_finite());
        self.origin = origin;
    }
    /// Extent covered by the samples: `(nx − 1, ny − 1) · cell`.
    pub fn extent(&self) -> Vec2 {
        Vec2::new(((self.nx - 1) as f64 * self.cell) as f32, ((self.ny - 1) as f64 * self.cell) as f32)
    }
    /// Row-major samples.
    pub fn data(&self) -> &[T] {
        &self.data
    }
    /// Mutable row-major samples.
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }
    /// Flat index of `(i, j)` (must be in range).
    #[inline]
    pub fn index(&self, i: usize, j: usize) -> usize {
        debug_assert!(i < self.nx && j < self.ny);
        j * self.nx + i
    }
    /// Sample `(i, j)` (must be in range).
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> T {
        self.data[self.index(i, j)]
    }
    /// Sets sample `(i, j)` (must be in range).
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, v: T) {
        let k = self.index(i, j);
        self.data[k] = v;
    }
    /// Sample at possibly out-of-range indices, resolved by `b`.
    #[inline]
    pub fn at(&self, i: i64, j: i64, b: Boundary) -> T {
        self.get(b.resolve(i, self.nx), b.resolve(j, self.ny))
    }
    /// World position of sample `(i, j)`.
    pub fn position(&self, i: usize, j: usize) -> Vec2 {
        self.origin + Vec2::new((i as f64 * self.cell) as f32, (j as f64 * self.cell) as f32)
    }
    /// Continuous grid coordinates of a world point (sample units).
    pub fn to_grid(&self, p: Vec2) -> (f64, f64) {
        ((p.x as f64 - self.origin.x as f64) / self.cell, (p.y as f64 - self.origin.y as f64) / self.cell)
    }
    /// Whether a world point lies within the sampled rectangle.
    pub fn contains(&self, p: Vec2) -> bool {
        let (gx, gy) = self.to_grid(p);
        gx >= 0.0 && gy >= 0.0 && gx <= (self.nx - 1) as f64 && gy <= (self.ny - 1) as f64
    }
    /// Nearest sample to a world point, resolved by `b`.
    pub fn nearest(&self, p: Vec2, b: Boundary) -> T {
        let (gx, gy) = self.to_grid(p);
        let (gx, gy) = (finite_or_zero(gx), finite_or_zero(gy));
        self.at(gx.round() as i64, gy.round() as i64, b)
    }
    /// Applies `f` to every sample.
    pub fn map_in_place(&mut self, mut f: impl FnMut(T) -> T) {
        for v in &mut self.data {
            *v = f(*v);
        }
    }
}

fn finite_or_zero(x: f64) -> f64 {
    if x.is_finite() { x.clamp(-1e15, 1e15) } else { 0.0 }
}

impl<T: Lerp> Grid2<T> {
    /// Bilinear sample at a world point; outside the grid, indices resolve by `b`.
    /// Non-finite coordinates sample at the origin rather than producing NaN.
    pub fn sample(&self, p: Vec2, b: Boundary) -> T {
        let (gx, gy) = self.to_grid(p);
        self.sample_grid(finite_or_zero(gx), finite_or_zero(gy), b)
    }

    /// Bilinear sample at continuous grid coordinates.
    pub fn sample_grid(&self, gx: f64, gy: f64, b: Boundary) -> T {
        let (fx, fy) = (gx.floor(), gy.floor());
        let (tx, ty) = (gx - fx, gy - fy);
        let (i, j) = (fx as i64, fy as i64);
        let a = T::lerp(self.at(i, j, b), self.at(i + 1, j, b), tx);
        let c = T::lerp(self.at(i, j + 1, b), self.at(i + 1, j + 1, b), tx);
        T::lerp(a, c, ty)
    }
}

impl Grid2<f32> {
    /// Central-difference gradient at sample `(i, j)` (one-sided at clamped edges).
    pub fn gradient(&self, i: usize, j: usize, b: Boundary) -> Vec2 {
        let (i, j) = (i as i64, j as i64);
        let d = |lo: i64, hi: i64, n: usize, along_x: bool| -> f32 {
            let (lo_r, hi_r) = (b.resolve(lo, n) as i64, b.resolve(hi, n) as i64);
            let span = match b {
                Boundary::Wrap => 2.0,
                Boundary::Clamp => (hi_r - lo_r) as f64,
            };
            if span == 0.0 {
                return 0.0;
            }
            let (vl, vh) = if along_x {
                (self.at(lo, j, b), self.at(hi, j, b))
            } else {
                (self.at(i, lo, b), self.at(i, hi, b))
            };
            ((vh - vl) as f64 / (span * self.cell)) as f32
        };
        Vec2::new(d(i - 1, i + 1, self.nx, true), d(j - 1, j + 1, self.ny, false))
    }

    /// Divergence `∂u/∂x + ∂v/∂y` of the vector field `(u, v)` by central differences, written
    /// into `out` (same shape). Errors if the shapes differ.
    pub fn divergence_into(
        u: &Grid2<f32>,
        v: &Grid2<f32>,
        b: Boundary,
        out: &mut Grid2<f32>,
    ) -> Result<(), ConfigError> {
        if u.nx != v.nx || u.ny != v.ny || out.nx != u.nx || out.ny != u.ny {
            return Err(ConfigError::InvalidParameter {
                name: "divergence grid shapes",
                value: 0.0,
                reason: "u, v and out must have the same dimensions".into(),
            });
        }
        let (nx, ny) = (u.nx, u.ny);
        let inv2h = (0.5 / u.cell) as f32;
        // Interior: direct indexing (the hot path); the one-cell border goes through the
        // boundary-aware gradient.
        if nx >= 3 && ny >= 3 {
            for j in 1..ny - 1 {
                let row = j * nx;
                for i in 1..nx - 1 {
                    let k = row + i;
                    out.data[k] = (u.data[k + 1] - u.data[k - 1] + v.data[k + nx] - v.data[k - nx]) * inv2h;
                }
            }
        }
        for j in 0..ny {
            let border_row = j == 0 || j + 1 >= ny;
            let mut i = 0;
            while i < nx {
                let d = u.gradient(i, j, b).x + v.gradient(i, j, b).y;
                out.set(i, j, d);
                // Interior rows only need their first and last samples here.
                i = if border_row || i + 1 >= nx - 1 || nx < 3 { i + 1 } else { nx - 1 };
            }
        }
        Ok(())
    }

    /// Sum of all samples in f64.
    pub fn sum(&self) -> f64 {
        self.data.iter().map(|&v| v as f64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Grid2<f32> {
        // f(x, y) = 2x + 3y on a 5×4 grid with cell 0.5 and origin (10, 20).
        let mut g = Grid2::new(5, 4, 0.5, Vec2::new(10.0, 20.0), 0.0).unwrap();
        for j in 0..4 {
            for i in 0..5 {
                let p = g.position(i, j);
                g.set(i, j, 2.0 * (p.x - 10.0) + 3.0 * (p.y - 20.0));
            }
        }
        g
    }

    #[test]
    fn bilinear_is_exact_on_linear_fields() {
        let g = ramp();
        for (x, y) in [(10.3, 20.7), (11.9, 21.4), (10.0, 20.0), (12.0, 21.5)] {
            let v = g.sample(Vec2::new(x, y), Boundary::Clamp);
            let expect = 2.0 * (x - 10.0) + 3.0 * (y - 20.0);
            assert!((v - expect).abs() < 1e-4, "({x},{y}): {v} vs {expect}");
        }
        // Clamped outside: equals the edge value.
        let out = g.sample(Vec2::new(100.0, 20.0), Boundary::Clamp);
        assert!((out - 4.0).abs() < 1e-5);
        // NaN coordinates do not produce NaN.
        assert!(g.sample(Vec2::new(f32::NAN, 0.0), Boundary::Clamp).is_finite());
    }

    #[test]
    fn gradient_and_divergence_of_linear_fields() {
        let g = ramp();
        for j in 0..4 {
            for i in 0..5 {
                let d = g.gradient(i, j, Boundary::Clamp);
                assert!((d.x - 2.0).abs() < 1e-4 && (d.y - 3.0).abs() < 1e-4, "{i},{j}: {d}");
            }
        }
        // div (x, y) = 2.
        let mut u = Grid2::new(6, 6, 1.0, Vec2::ZERO, 0.0f32).unwrap();
        let mut v = u.clone();
        for j in 0..6 {
            for i in 0..6 {
                u.set(i, j, i as f32);
                v.set(i, j, j as f32);
            }
        }
        let mut out = u.clone();
        Grid2::divergence_into(&u, &v, Boundary::Clamp, &mut out).unwrap();
        assert!(out.data().iter().all(|d| (d - 2.0).abs() < 1e-5));
    }

    #[test]
    fn fast_divergence_matches_per_sample_gradients() {
        for b in [Boundary::Clamp, Boundary::Wrap] {
            for (nx, ny) in [(7, 5), (2, 9), (1, 4), (16, 16)] {
                let mut u = Grid2::new(nx, ny, 0.7, Vec2::ZERO, 0.0f32).unwrap();
                let mut v = u.clone();
                for j in 0..ny {
                    for i in 0..nx {
                        u.set(i, j, ((i * 7 + j * 13) % 11) as f32 * 0.3);
                        v.set(i, j, ((i * 5 + j * 3) % 7) as f32 - 2.0);
                    }
                }
                let mut out = u.clone();
                Grid2::divergence_into(&u, &v, b, &mut out).unwrap();
                for j in 0..ny {
                    for i in 0..nx {
                        let expect = u.gradient(i, j, b).x + v.gradient(i, j, b).y;
                        assert!((out.get(i, j) - expect).abs() < 1e-5, "{b:?} {nx}×{ny} at ({i},{j})");
                    }
                }
            }
        }
    }

    #[test]
    fn wrap_boundary_is_toroidal() {
        let mut g = Grid2::new(4, 4, 1.0, Vec2::ZERO, 0.0f32).unwrap();
        g.set(0, 0, 1.0);
        assert_eq!(g.at(4, 4, Boundary::Wrap), 1.0);
        assert_eq!(g.at(-4, 0, Boundary::Wrap), 1.0);
        assert_eq!(g.at(-1, 0, Boundary::Clamp), 1.0);
        // Halfway between the last sample (3) and the wrapped first (0).
        let s = g.sample_grid(3.5, 0.0, Boundary::Wrap);
        assert!((s - 0.5).abs() < 1e-6);
        // A periodic sine has a periodic gradient: cos at every sample.
        let n = 64;
        let cell = 1.0;
        let k = std::f64::consts::TAU / n as f64;
        let mut s = Grid2::new(n, 1, cell, Vec2::ZERO, 0.0f32).unwrap();
        for i in 0..n {
            s.set(i, 0, (k * i as f64).sin() as f32);
        }
        for i in 0..n {
            let d = s.gradient(i, 0, Boundary::Wrap).x as f64;
            assert!((d - k * (k * i as f64).cos()).abs() < 2e-3, "i={i}");
        }
    }

    #[test]
    fn bad_shapes_are_errors() {
        assert!(Grid2::new(0, 3, 1.0, Vec2::ZERO, 0.0f32).is_err());
        assert!(Grid2::new(3, 3, -1.0, Vec2::ZERO, 0.0f32).is_err());
        assert!(Grid2::new(3, 3, f64::NAN, Vec2::ZERO, 0.0f32).is_err());
        assert!(Grid2::from_vec(3, 3, 1.0, Vec2::ZERO, vec![0.0f32; 8]).is_err());
        let a = Grid2::new(3, 3, 1.0, Vec2::ZERO, 0.0f32).unwrap();
        let b = Grid2::new(4, 3, 1.0, Vec2::ZERO, 0.0f32).unwrap();
        let mut o = a.clone();
        assert!(Grid2::divergence_into(&a, &b, Boundary::Clamp, &mut o).is_err());
    }
}
