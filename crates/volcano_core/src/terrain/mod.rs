//! Terrain: a heightfield of absolute altitudes (m above sea level) with a land-cover map,
//! height/normal queries and ray intersection for picking.
//!
//! Generators live in [`generate`] (procedural stratovolcano) and [`png_io`] (16-bit PNG
//! heightmaps, the way real DEMs are commonly shared).

pub mod generate;
pub mod png_io;

use bevy::ecs::component::Component;
use bevy::math::{Vec2, Vec3};
use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};

pub use generate::StratovolcanoParams;

use crate::error::ConfigError;
use crate::grid::{Boundary, Grid2};

/// Surface type of a terrain cell; drives colour now, and albedo, emissivity and heat
/// capacity in the atmosphere model later (thesis §4.2.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Reflect, Serialize, Deserialize)]
pub enum LandCover {
    /// Bare rock, ash or soil.
    #[default]
    Ground,
    /// Grass, forest, crops.
    Vegetation,
    /// Sea or lake.
    Water,
    /// Snow or ice.
    Snow,
}

/// A heightfield terrain. Lives as a component on one entity; the grid's `(x, y)` maps to world
/// `(x, z)` and heights to world `y`.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(opaque)]
pub struct Terrain {
    heights: Grid2<f32>,
    cover: Grid2<LandCover>,
    sea_level: f32,
}

impl Terrain {
    /// Builds a terrain from heights and land cover of the same shape. Heights must be finite.
    pub fn new(heights: Grid2<f32>, cover: Grid2<LandCover>, sea_level: f32) -> Result<Self, ConfigError> {
        if heights.nx() != cover.nx() || heights.ny() != cover.ny() {
            return Err(ConfigError::InvalidParameter {
                name: "land cover size",
                value: (cover.nx() * cover.ny()) as f64,
                reason: format!("must match the heightfield's {}×{}", heights.nx(), heights.ny()),
            });
        }
        if let Some(bad) = heights.data().iter().find(|h| !h.is_finite()) {
            return Err(ConfigError::InvalidParameter {
                name: "terrain height",
                value: *bad as f64,
                reason: "all heights must be finite".into(),
            });
        }
        crate::error::finite("sea_level", sea_level as f64)?;
        Ok(Self { heights, cover, sea_level })
    }

    /// A flat terrain of `n × n` samples at altitude `height`, centred on the origin.
    pub fn flat(n: usize, cell: f64, height: f32) -> Result<Self, ConfigError> {
        let origin = centred_origin(n, cell);
        let heights = Grid2::new(n, n, cell, origin, height)?;
        let cover = Grid2::new(n, n, cell, origin, LandCover::Ground)?;
        Self::new(heights, cover, f32::MIN)
    }

    /// The heightfield (absolute altitudes, m).
    pub fn heights(&self) -> &Grid2<f32> {
        &self.heights
    }
    /// Mutable heightfield, for tools that edit the terrain (lava freezing, deposits).
    pub fn heights_mut(&mut self) -> &mut Grid2<f32> {
        &mut self.heights
    }
    /// The land-cover map.
    pub fn cover(&self) -> &Grid2<LandCover> {
        &self.cover
    }
    /// Sea level (m); cells below it are water.
    pub fn sea_level(&self) -> f32 {
        self.sea_level
    }
    /// Lowest and highest altitude.
    pub fn height_range(&self) -> (f32, f32) {
        self.heights
            .data()
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &h| (lo.min(h), hi.max(h)))
    }

    /// Terrain altitude at world `(x, z)`, bilinear, clamped at the edges.
    pub fn height_at(&self, x: f32, z: f32) -> f32 {
        self.heights.sample(Vec2::new(x, z), Boundary::Clamp)
    }

    /// Unit surface normal at world `(x, z)` (y-up), from central differences of the
    /// bilinear surface over one cell.
    pub fn normal_at(&self, x: f32, z: f32) -> Vec3 {
        let e = (self.heights.cell() * 0.5) as f32;
        let dhdx = (self.height_at(x + e, z) - self.height_at(x - e, z)) / (2.0 * e);
        let dhdz = (self.height_at(x, z + e) - self.height_at(x, z - e)) / (2.0 * e);
        Vec3::new(-dhdx, 1.0, -dhdz).normalize_or(Vec3::Y)
    }

    /// Land cover nearest to world `(x, z)`.
    pub fn cover_at(&self, x: f32, z: f32) -> LandCover {
        self.cover.nearest(Vec2::new(x, z), Boundary::Clamp)
    }

    /// Whether world `(x, z)` lies over the heightfield.
    pub fn contains(&self, x: f32, z: f32) -> bool {
        self.heights.contains(Vec2::new(x, z))
    }

    /// First intersection of the ray `origin + t·dir` (t ≥ 0) with the terrain surface inside
    /// its footprint, or `None`. Marches at half-cell steps inside the terrain's bounding box
    /// and refines by bisection.
    pub fn raycast(&self, origin: Vec3, dir: Vec3) -> Option<Vec3> {
        if !origin.is_finite() || !dir.is_finite() {
            return None;
        }
        let dir = dir.try_normalize()?;
        let (lo, hi) = self.height_range();
        let min = self.heights.origin();
        let max = min + self.heights.extent();
        let (t0, t1) =
            slab(origin, dir, Vec3::new(min.x, lo - 1.0, min.y), Vec3::new(max.x, hi + 1.0, max.y))?;
        let step = (self.heights.cell() * 0.5) as f32;
        let above = |t: f32| {
            let p = origin + dir * t;
            p.y - self.height_at(p.x, p.z)
        };
        let mut t_prev = t0.max(0.0);
        if above(t_prev) <= 0.0 {
            // Starting below the surface: report the entry point.
            return Some(origin + dir * t_prev);
        }
        let mut t = t_prev;
        while t < t1 {
            t = (t + step).min(t1);
            let f = above(t);
            if f <= 0.0 {
                // Bisection between t_prev (above) and t (below).
                let (mut a, mut b) = (t_prev, t);
                for _ in 0..40 {
                    let m = 0.5 * (a + b);
                    if above(m) > 0.0 { a = m } else { b = m }
                }
                return Some(origin + dir * b);
            }
            t_prev = t;
        }
        None
    }
}

/// Ray/axis-aligned box clipping; returns the parametric interval inside the box.
fn slab(o: Vec3, d: Vec3, min: Vec3, max: Vec3) -> Option<(f32, f32)> {
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for a in 0..3 {
        let (oa, da, lo, hi) = (o[a], d[a], min[a], max[a]);
        if da.abs() < 1e-12 {
            if oa < lo || oa > hi {
                return None;
            }
        } else {
            let (mut ta, mut tb) = ((lo - oa) / da, (hi - oa) / da);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Origin that centres an `n × n` grid of spacing `cell` on world (0, 0).
pub fn centred_origin(n: usize, cell: f64) -> Vec2 {
    let half = ((n.max(1) - 1) as f64 * cell * 0.5) as f32;
    Vec2::splat(-half)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tilted() -> Terrain {
        // h = 100 + 0.5 x on a 65×65 grid with 2 m cells.
        let mut t = Terrain::flat(65, 2.0, 0.0).unwrap();
        let g = t.heights_mut();
        for j in 0..65 {
            for i in 0..65 {
                let p = g.position(i, j);
                g.set(i, j, 100.0 + 0.5 * p.x);
            }
        }
        t
    }

    #[test]
    fn height_and_normal_of_a_plane() {
        let t = tilted();
        assert!((t.height_at(10.0, 3.0) - 105.0).abs() < 1e-3);
        let n = t.normal_at(5.0, 5.0);
        let expect = Vec3::new(-0.5, 1.0, 0.0).normalize();
        assert!((n - expect).length() < 1e-4, "{n}");
    }

    #[test]
    fn ray_hits_where_expected() {
        let t = tilted();
        // Straight down at (20, -7): hits at h = 110.
        let hit = t.raycast(Vec3::new(20.0, 500.0, -7.0), Vec3::NEG_Y).unwrap();
        assert!((hit - Vec3::new(20.0, 110.0, -7.0)).length() < 1e-2, "{hit}");
        // Oblique ray from above the left side: x = −60 + s, y = 300 − 2s meets the plane
        // y = 100 + 0.5x at s = 230/2.5 = 92, i.e. (32, 116, 0).
        let hit = t.raycast(Vec3::new(-60.0, 300.0, 0.0), Vec3::new(1.0, -2.0, 0.0)).unwrap();
        assert!((hit - Vec3::new(32.0, 116.0, 0.0)).length() < 1e-2, "{hit}");
        // Pointing up or away misses.
        assert!(t.raycast(Vec3::new(0.0, 500.0, 0.0), Vec3::Y).is_none());
        assert!(t.raycast(Vec3::new(1000.0, 500.0, 0.0), Vec3::X).is_none());
        assert!(t.raycast(Vec3::new(0.0, 500.0, 0.0), Vec3::new(f32::NAN, 0.0, 0.0)).is_none());
    }

    #[test]
    fn mismatched_cover_and_nan_heights_are_errors() {
        let h = Grid2::new(4, 4, 1.0, Vec2::ZERO, 0.0f32).unwrap();
        let c = Grid2::new(3, 4, 1.0, Vec2::ZERO, LandCover::Ground).unwrap();
        assert!(Terrain::new(h.clone(), c, 0.0).is_err());
        let mut bad = h.clone();
        bad.set(1, 1, f32::NAN);
        let c = Grid2::new(4, 4, 1.0, Vec2::ZERO, LandCover::Ground).unwrap();
        let err = Terrain::new(bad, c, 0.0).unwrap_err();
        assert!(err.to_string().contains("terrain height"), "{err}");
    }
}
