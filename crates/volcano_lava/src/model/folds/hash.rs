//! Uniform grid of particle indices for the fold neighbour searches (collisions, chaining,
//! burial). A dense grid over the particles' bounding box, rebuilt each step: no hashing of
//! keys (the `HashMap` it replaces spent most of its time hashing), buckets keep their
//! allocations between rebuilds.

use bevy::math::DVec2;

/// Buckets per axis, at most: a larger extent gets larger buckets.
const MAX_PER_AXIS: usize = 1024;

/// Uniform grid of particle indices. Positions outside the box of the last rebuild (particles
/// added since) go to the nearest edge bucket, so a query still sees every particle within
/// one bucket size.
#[derive(Debug, Clone, Default)]
pub struct SpatialHash {
    size: f64,
    min: DVec2,
    nx: usize,
    ny: usize,
    buckets: Vec<Vec<u32>>,
    used: Vec<u32>,
}

impl SpatialHash {
    /// An empty grid with buckets of `size` m.
    pub fn new(size: f64) -> Self {
        Self { size: size.max(1e-3), ..Default::default() }
    }

    /// Bucket size (m): queries through [`Self::near`] see everything within this distance.
    pub fn size(&self) -> f64 {
        self.size
    }

    fn cell(&self, p: DVec2) -> (usize, usize) {
        let g = (p - self.min) / self.size;
        let clamp = |v: f64, n: usize| if v > 0.0 { (v as usize).min(n - 1) } else { 0 };
        (clamp(g.x, self.nx), clamp(g.y, self.ny))
    }

    /// Clears and inserts `points` (index = position in the sequence) with buckets of at
    /// least `size` m. Non-finite points are left out.
    pub fn rebuild(&mut self, size: f64, points: impl Iterator<Item = DVec2> + Clone) {
        for &b in &self.used {
            self.buckets[b as usize].clear();
        }
        self.used.clear();
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in points.clone().filter(|p| p.is_finite()) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if lo.x > hi.x {
            (lo, hi) = (DVec2::ZERO, DVec2::ZERO);
        }
        let extent = (hi - lo).max_element();
        self.size = size.max(1e-3).max(extent / (MAX_PER_AXIS - 1) as f64);
        self.min = lo;
        self.nx = ((hi.x - lo.x) / self.size) as usize + 1;
        self.ny = ((hi.y - lo.y) / self.size) as usize + 1;
        if self.buckets.len() < self.nx * self.ny {
            self.buckets.resize_with(self.nx * self.ny, Vec::new);
        }
        for (k, p) in points.enumerate() {
            self.insert(k as u32, p);
        }
    }

    /// Adds particle `idx` at `p` (a particle created after the last rebuild).
    pub fn insert(&mut self, idx: u32, p: DVec2) {
        if !p.is_finite() || self.nx == 0 {
            return;
        }
        let (i, j) = self.cell(p);
        let b = j * self.nx + i;
        if self.buckets[b].is_empty() {
            self.used.push(b as u32);
        }
        self.buckets[b].push(idx);
    }

    /// Indices in the 3×3 buckets around `p` (everything within one bucket size), in a fixed
    /// order (bucket by bucket, each in insertion order), so results are deterministic.
    pub fn near(&self, p: DVec2, out: &mut Vec<u32>) {
        out.clear();
        if !p.is_finite() || self.nx == 0 {
            return;
        }
        let (ci, cj) = self.cell(p);
        for j in cj.saturating_sub(1)..(cj + 2).min(self.ny) {
            for i in ci.saturating_sub(1)..(ci + 2).min(self.nx) {
                out.extend_from_slice(&self.buckets[j * self.nx + i]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// Every point within the bucket size of a query is returned, for points inside the box
    /// and for points added later outside it; nothing is returned twice.
    #[test]
    fn near_returns_a_superset_of_the_neighbours() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut pts: Vec<DVec2> = (0..2000)
            .map(|_| DVec2::new(rng.random_range(-20.0..30.0), rng.random_range(5.0..9.0)))
            .collect();
        let mut grid = SpatialHash::new(1.0);
        grid.rebuild(0.7, pts.iter().copied());
        for _ in 0..200 {
            let p = DVec2::new(rng.random_range(-25.0..35.0), rng.random_range(0.0..14.0));
            grid.insert(pts.len() as u32, p);
            pts.push(p);
        }
        let mut out = Vec::new();
        for _ in 0..500 {
            let q = DVec2::new(rng.random_range(-26.0..36.0), rng.random_range(-1.0..15.0));
            grid.near(q, &mut out);
            let mut got = out.clone();
            got.sort_unstable();
            got.dedup();
            assert_eq!(got.len(), out.len(), "duplicates");
            for (k, p) in pts.iter().enumerate() {
                if p.distance(q) < grid.size() {
                    assert!(got.binary_search(&(k as u32)).is_ok(), "{p} missing near {q}");
                }
            }
        }
        // A rebuild forgets everything before it.
        grid.rebuild(0.7, [DVec2::ZERO].into_iter());
        grid.near(DVec2::ZERO, &mut out);
        assert_eq!(out, vec![0]);
        grid.rebuild(0.7, std::iter::empty());
        grid.near(DVec2::ZERO, &mut out);
        assert!(out.is_empty());
    }
}
