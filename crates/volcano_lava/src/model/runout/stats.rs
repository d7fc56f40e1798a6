//! What a [`super::Runout`]'s flow looks like from above: how far it ran, how wide and deep
//! it is, where its front is. Read by the CLI summary, the tests and gameplay messages.

use bevy::math::DVec2;

use super::Runout;
use super::tiles::TILE_CELLS;

/// A flow's shape, measured from its vent.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunoutStats {
    /// Farthest distance from the vent of a cell with liquid or frozen lava (m).
    pub runout_m: f64,
    /// The farthest cell with liquid lava (the front), world (x, z).
    pub front: Option<DVec2>,
    /// Its distance from the vent (m).
    pub front_m: f64,
    /// Area covered by liquid or frozen lava thicker than `min_thickness` (m²).
    pub covered_m2: f64,
    /// Area of liquid lava thicker than `min_thickness` (m²).
    pub liquid_m2: f64,
    /// Liquid volume over that area (m).
    pub mean_depth_m: f64,
    /// Covered area over the runout (m): the mean width of a flow that is longer than wide.
    pub mean_width_m: f64,
    /// Liquid lava (m³).
    pub liquid_m3: f64,
    /// Lava frozen in the stored tiles (m³).
    pub frozen_m3: f64,
    /// Smallest and largest world (x, z) of the covered cells' centres.
    pub bounds: Option<(DVec2, DVec2)>,
}

impl Runout {
    /// The flow's shape, distances measured from `vent` (world x, z); cells thinner than
    /// `min_thickness` (m) count as bare.
    pub fn stats(&self, vent: DVec2, min_thickness: f64) -> RunoutStats {
        let area = self.grid.cell * self.grid.cell;
        let mut s = RunoutStats::default();
        let mut liquid_over = 0.0;
        for tile in &self.tiles.list {
            for k in 0..TILE_CELLS {
                let (h, solid) = (tile.h[k], tile.solid[k]);
                s.liquid_m3 += h * area;
                s.frozen_m3 += solid * area;
                if h + solid <= min_thickness {
                    continue;
                }
                let (a, b) = super::global(tile.key, k);
                let p = self.grid.centre(a, b);
                let d = p.distance(vent);
                s.covered_m2 += area;
                s.bounds = Some(match s.bounds {
                    Some((lo, hi)) => (lo.min(p), hi.max(p)),
                    None => (p, p),
                });
                s.runout_m = s.runout_m.max(d);
                if h > min_thickness {
                    s.liquid_m2 += area;
                    liquid_over += h * area;
                    if d > s.front_m || s.front.is_none() {
                        s.front_m = d;
                        s.front = Some(p);
                    }
                }
            }
        }
        if s.liquid_m2 > 0.0 {
            s.mean_depth_m = liquid_over / s.liquid_m2;
        }
        if s.runout_m > 0.0 {
            s.mean_width_m = s.covered_m2 / s.runout_m;
        }
        s
    }
}
