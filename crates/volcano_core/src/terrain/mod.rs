//! Terrain: a heightfield of absolute altitudes (m above sea level) with a land-cover map,
//! height/normal queries and ray intersection for picking.
//!
//! Generators live in [`generate`] (procedural stratovolcano) and [`png_io`] (16-bit PNG
//! heightmaps, the way real DEMs are commonly shared); a scene (`bsn!`) builds a terrain from a
//! [`TerrainTemplate`] when it spawns.
//!
//! What the simulation adds on top of the ground (frozen lava) is kept as an exact `f64`
//! *added layer* per node beside the `f32` heights (docs/physics/lava.md §6.7): heights are
//! `base + added` rounded to `f32` for rendering and queries, and the layer's sum is the
//! volume gained. [`remap`] carries a patch's cell field onto the nodes conservatively, and
//! [`TerrainChanged`] tells games and the renderer which nodes moved.

pub mod generate;
mod placement;
pub use placement::ignored_parts as ignored_transform_parts;
pub mod png_io;
pub mod remap;
mod template;

use std::ops::{Deref, DerefMut};

use bevy::ecs::component::Component;
use bevy::ecs::entity::Entity;
use bevy::ecs::message::Message;
use bevy::ecs::reflect::ReflectComponent;
use bevy::math::{Vec2, Vec3};
use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};

pub use generate::StratovolcanoParams;
pub(crate) use placement::place_terrains;
pub use remap::{NodeRegion, NodeRemap};
pub use template::TerrainTemplate;

use crate::error::ConfigError;
use crate::grid::{Boundary, Grid2};

/// Surface type of a terrain cell; drives its colour, and its albedo, emissivity and heat
/// capacity in the atmosphere model (thesis §4.2.5).
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
///
/// Heights are the ground as built or edited ([`Terrain::heights_mut`] edits that *base*) plus
/// the [added layer](Terrain::added), kept in `f64` so volumes written by the simulation
/// balance exactly although an `f32` height at 2.5 km moves in steps of 2.4e-4 m.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(opaque)]
#[reflect(Component)]
pub struct Terrain {
    /// `base + added`, rounded to f32.
    heights: Grid2<f32>,
    cover: Grid2<LandCover>,
    sea_level: f32,
    /// The base heights and the added thickness, once anything was added.
    layer: Option<AddedLayer>,
    /// World (x, z) of sample (0, 0) as built, before [`Terrain::set_placement`].
    built_origin: Vec2,
    /// Offset of the grids from where they were built (the entity's translation, x and z).
    placement: Vec2,
}

/// Base heights under the added layer, and the layer's thickness per node (m, f64).
#[derive(Debug, Clone, PartialEq)]
struct AddedLayer {
    base: Grid2<f32>,
    added: Grid2<f64>,
}

/// Heights of some terrain nodes changed (frozen lava written back, see
/// [`Terrain::add_thickness`]): rebuild what depends on them there (meshes, colliders,
/// caches). Such changes do not trigger Bevy's change detection on [`Terrain`] (that would
/// make every `Changed<Terrain>` reader redo a whole 512² terrain once a second); a whole new
/// or edited terrain does.
#[derive(Message, Debug, Clone, Copy, PartialEq, Eq, Reflect)]
pub struct TerrainChanged {
    /// The terrain entity.
    pub terrain: Entity,
    /// The nodes whose height changed (a rectangle holding all of them).
    pub region: NodeRegion,
}

/// Mutable access to a terrain's base heights (the ground under the added layer); the heights
/// are recomputed when it is dropped.
pub struct BaseHeightsMut<'a> {
    terrain: &'a mut Terrain,
}

impl Deref for BaseHeightsMut<'_> {
    type Target = Grid2<f32>;
    fn deref(&self) -> &Grid2<f32> {
        self.terrain.base_heights()
    }
}

impl DerefMut for BaseHeightsMut<'_> {
    fn deref_mut(&mut self) -> &mut Grid2<f32> {
        match &mut self.terrain.layer {
            Some(layer) => &mut layer.base,
            None => &mut self.terrain.heights,
        }
    }
}

impl Drop for BaseHeightsMut<'_> {
    fn drop(&mut self) {
        if let Some(layer) = &self.terrain.layer {
            let h = self.terrain.heights.data_mut();
            for ((h, b), a) in h.iter_mut().zip(layer.base.data()).zip(layer.added.data()) {
                *h = (*b as f64 + a) as f32;
            }
        }
    }
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
        let built_origin = heights.origin();
        Ok(Self { heights, cover, sea_level, layer: None, built_origin, placement: Vec2::ZERO })
    }

    /// A flat terrain of `n × n` samples at altitude `height`, centred on the origin.
    pub fn flat(n: usize, cell: f64, height: f32) -> Result<Self, ConfigError> {
        let origin = centred_origin(n, cell);
        let heights = Grid2::new(n, n, cell, origin, height)?;
        let cover = Grid2::new(n, n, cell, origin, LandCover::Ground)?;
        Self::new(heights, cover, f32::MIN)
    }

    /// How far the terrain was moved from where it was built (world x, z; m): its entity's
    /// `Transform` translation, applied by the core plugin (`place_terrains`).
    pub fn placement(&self) -> Vec2 {
        self.placement
    }

    /// Moves the terrain `offset` (world x, z; m) from where it was built: every grid's sample
    /// (0, 0) goes to the built origin plus `offset`, so placing it again never accumulates
    /// rounding. The core plugin calls it from the entity's `Transform`; a game moves a terrain
    /// by moving its entity. Errors, changing nothing, on a non-finite offset.
    pub fn set_placement(&mut self, offset: Vec2) -> Result<(), ConfigError> {
        if !offset.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "terrain placement",
                value: if offset.x.is_finite() { offset.y } else { offset.x } as f64,
                reason: "must be finite".into(),
            });
        }
        let origin = self.built_origin + offset;
        if !origin.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "terrain placement",
                value: offset.length() as f64,
                reason: "moves the grid beyond f32 range".into(),
            });
        }
        self.heights.set_origin(origin);
        self.cover.set_origin(origin);
        if let Some(layer) = &mut self.layer {
            layer.base.set_origin(origin);
            layer.added.set_origin(origin);
        }
        self.placement = offset;
        Ok(())
    }

    /// The heightfield (absolute altitudes, m): base plus added layer.
    pub fn heights(&self) -> &Grid2<f32> {
        &self.heights
    }
    /// Mutable base heightfield, for tools that edit the ground; the added layer stays on top
    /// (the heights are recomputed when the returned guard is dropped).
    pub fn heights_mut(&mut self) -> BaseHeightsMut<'_> {
        BaseHeightsMut { terrain: self }
    }
    /// The ground under the added layer (the heights if nothing was added).
    pub fn base_heights(&self) -> &Grid2<f32> {
        self.layer.as_ref().map_or(&self.heights, |l| &l.base)
    }
    /// Thickness added per node (m, f64), or `None` if nothing was ever added.
    pub fn added(&self) -> Option<&Grid2<f64>> {
        self.layer.as_ref().map(|l| &l.added)
    }
    /// Volume of the added layer (m³): its thickness summed in row order times the node area.
    pub fn added_volume(&self) -> f64 {
        let a = self.heights.cell() * self.heights.cell();
        self.added().map_or(0.0, |g| g.data().iter().sum::<f64>() * a)
    }

    /// Adds `thickness[k]` metres (negative removes) to node `k` of `region` (row-major over
    /// the region) in the `f64` layer, and refreshes those heights. Errors, changing nothing,
    /// if the region leaves the grid, the lengths differ or a value is not finite. Returns the
    /// rectangle of nodes whose `f32` height moved (empty if none did: a change below the
    /// `f32` step is recorded but not visible yet).
    pub fn add_thickness(
        &mut self,
        region: NodeRegion,
        thickness: &[f64],
    ) -> Result<NodeRegion, ConfigError> {
        let (nx, ny) = (self.heights.nx(), self.heights.ny());
        if region.i0 + region.ni > nx || region.j0 + region.nj > ny {
            return Err(ConfigError::InvalidParameter {
                name: "terrain region",
                value: (region.i0 + region.ni).max(region.j0 + region.nj) as f64,
                reason: format!("must lie within the {nx}×{ny} nodes"),
            });
        }
        if thickness.len() != region.len() {
            return Err(ConfigError::InvalidParameter {
                name: "added thickness length",
                value: thickness.len() as f64,
                reason: format!("must equal the region's {} nodes", region.len()),
            });
        }
        if let Some(bad) = thickness.iter().find(|v| !v.is_finite()) {
            return Err(ConfigError::InvalidParameter {
                name: "added thickness",
                value: *bad,
                reason: "must be finite".into(),
            });
        }
        if region.is_empty() {
            return Ok(NodeRegion::default());
        }
        if self.layer.is_none() {
            let added = Grid2::new(nx, ny, self.heights.cell(), self.heights.origin(), 0.0)?;
            self.layer = Some(AddedLayer { base: self.heights.clone(), added });
        }
        let (heights, Some(layer)) = (&mut self.heights, self.layer.as_mut()) else {
            return Ok(NodeRegion::default());
        };
        let (mut lo, mut hi) = ((usize::MAX, usize::MAX), (0, 0));
        for (r, row) in thickness.chunks(region.ni.max(1)).enumerate() {
            let j = region.j0 + r;
            for (d, &dh) in row.iter().enumerate() {
                let i = region.i0 + d;
                let k = j * nx + i;
                let a = &mut layer.added.data_mut()[k];
                *a += dh;
                let h = (layer.base.data()[k] as f64 + *a) as f32;
                if h != heights.data()[k] {
                    heights.data_mut()[k] = h;
                    lo = (lo.0.min(i), lo.1.min(j));
                    hi = (hi.0.max(i), hi.1.max(j));
                }
            }
        }
        Ok(if lo.0 == usize::MAX {
            NodeRegion::default()
        } else {
            NodeRegion { i0: lo.0, j0: lo.1, ni: hi.0 + 1 - lo.0, nj: hi.1 + 1 - lo.1 }
        })
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
        let mut g = t.heights_mut();
        for j in 0..65 {
            for i in 0..65 {
                let p = g.position(i, j);
                g.set(i, j, 100.0 + 0.5 * p.x);
            }
        }
        drop(g);
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
    fn the_added_layer_keeps_increments_below_the_f32_step() {
        // At 2,500 m an f32 step is 2.4e-4 m: ten additions of 1e-4 m, each below half a step,
        // would all round away if added to the heights; the f64 layer keeps them.
        let mut t = Terrain::flat(8, 2.0, 2500.0).unwrap();
        let region = NodeRegion { i0: 2, j0: 3, ni: 2, nj: 1 };
        let mut moved = NodeRegion::default();
        for _ in 0..10 {
            moved = moved.union(t.add_thickness(region, &[1e-4, 0.0]).unwrap());
        }
        assert_eq!(moved, NodeRegion { i0: 2, j0: 3, ni: 1, nj: 1 }, "only the node that moved");
        let h = t.heights().get(2, 3) as f64;
        assert!((h - 2500.001).abs() < 1.3e-4, "height {h}");
        assert_eq!(t.heights().get(3, 3), 2500.0);
        assert!((t.added().unwrap().get(2, 3) - 1e-3).abs() < 1e-15);
        assert!((t.added_volume() - 4e-3).abs() < 1e-15, "{}", t.added_volume());
        assert_eq!(t.base_heights().get(2, 3), 2500.0);
    }

    #[test]
    fn editing_the_base_keeps_the_layer_on_top() {
        let mut t = Terrain::flat(8, 2.0, 100.0).unwrap();
        t.add_thickness(NodeRegion { i0: 1, j0: 1, ni: 1, nj: 1 }, &[0.5]).unwrap();
        t.heights_mut().map_in_place(|h| h + 10.0);
        assert_eq!(t.heights().get(1, 1), 110.5);
        assert_eq!(t.heights().get(0, 0), 110.0);
        assert_eq!(t.base_heights().get(1, 1), 110.0);
        assert!((t.added_volume() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn bad_additions_are_errors_and_change_nothing() {
        let mut t = Terrain::flat(8, 2.0, 100.0).unwrap();
        let before = t.clone();
        assert!(t.add_thickness(NodeRegion { i0: 6, j0: 0, ni: 3, nj: 1 }, &[0.1; 3]).is_err());
        assert!(t.add_thickness(NodeRegion { i0: 0, j0: 0, ni: 2, nj: 2 }, &[0.1; 3]).is_err());
        let e = t.add_thickness(NodeRegion { i0: 0, j0: 0, ni: 2, nj: 1 }, &[0.1, f64::NAN]).unwrap_err();
        assert!(e.to_string().contains("added thickness"), "{e}");
        assert_eq!(t, before);
        assert!(t.add_thickness(NodeRegion::default(), &[]).unwrap().is_empty());
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
