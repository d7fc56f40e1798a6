//! Frozen lava written back into the large terrain (docs/ARCHITECTURE.md §6.1: lava colder
//! than the solidus freezes into the ground). Inside a field the ground already includes the
//! frozen layer; this carries it to the world's `Terrain` heights, so a field built later (or
//! moved), the pyroclastic particles and gameplay height queries see the new ground: later
//! lava flows over earlier lava.

use bevy::math::Vec2;
use volcano_core::Grid2;

use super::field::FlowField;

/// Terrain nodes under one lava field, their heights when the field was built, and the
/// thickness last written to each.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainImprint {
    i0: usize,
    j0: usize,
    ni: usize,
    nj: usize,
    base: Vec<f32>,
    written: Vec<f32>,
}

impl TerrainImprint {
    /// The terrain nodes that lie within the field's extent (cell centres, first to last).
    /// Empty if the terrain has no node there (a field finer than one terrain cell still
    /// covers the nodes inside it, possibly none).
    pub fn new(heights: &Grid2<f32>, field: &FlowField) -> Self {
        let g = field.ground();
        let lo = g.origin();
        let hi = lo + Vec2::new((g.nx() - 1) as f32, (g.ny() - 1) as f32) * g.cell() as f32;
        let (a, b) = (heights.to_grid(lo), heights.to_grid(hi));
        let first = |x: f64| x.ceil().max(0.0) as usize;
        let (i0, j0) = (first(a.0), first(a.1));
        let i1 = (b.0.floor() as i64).min(heights.nx() as i64 - 1);
        let j1 = (b.1.floor() as i64).min(heights.ny() as i64 - 1);
        let ni = (i1 + 1 - i0 as i64).max(0) as usize;
        let nj = (j1 + 1 - j0 as i64).max(0) as usize;
        let mut base = Vec::with_capacity(ni * nj);
        for j in j0..j0 + nj {
            for i in i0..i0 + ni {
                base.push(heights.get(i, j));
            }
        }
        Self { i0, j0, ni, nj, written: vec![0.0; base.len()], base }
    }

    /// Terrain nodes covered.
    pub fn len(&self) -> usize {
        self.base.len()
    }

    /// Whether no terrain node lies under the field.
    pub fn is_empty(&self) -> bool {
        self.base.is_empty()
    }

    /// Sets each covered node to its base height plus the mean frozen thickness of the field
    /// cells within its footprint (a terrain cell centred on the node; the nearest field cell
    /// if none is inside), so the terrain gains the frozen volume. Nodes whose value moved by
    /// less than `tolerance` m are left alone. Returns how many nodes changed.
    pub fn apply(&mut self, heights: &mut Grid2<f32>, field: &FlowField, tolerance: f32) -> usize {
        let solid = field.solid();
        let (nx, ny) = (solid.nx() as i64, solid.ny() as i64);
        // Half a terrain cell in field cells.
        let half = 0.5 * heights.cell() / solid.cell();
        let mut changed = 0;
        for jj in 0..self.nj {
            for ii in 0..self.ni {
                let (i, j) = (self.i0 + ii, self.j0 + jj);
                let (gx, gy) = solid.to_grid(heights.position(i, j));
                let lo = |c: f64| ((c - half).ceil() as i64).max(0);
                let hi = |c: f64, n: i64| ((c + half).floor() as i64).min(n - 1);
                let (ia, ib, ja, jb) = (lo(gx), hi(gx, nx), lo(gy), hi(gy, ny));
                let mean = if ia > ib || ja > jb {
                    let (ci, cj) =
                        (gx.round().clamp(0.0, (nx - 1) as f64), gy.round().clamp(0.0, (ny - 1) as f64));
                    solid.get(ci as usize, cj as usize)
                } else {
                    let mut sum = 0.0;
                    for cj in ja..=jb {
                        for ci in ia..=ib {
                            sum += solid.get(ci as usize, cj as usize);
                        }
                    }
                    sum / ((ib - ia + 1) * (jb - ja + 1)) as f64
                };
                let k = jj * self.ni + ii;
                let add = mean as f32;
                if (add - self.written[k]).abs() >= tolerance && add.is_finite() {
                    self.written[k] = add;
                    heights.set(i, j, self.base[k] + add);
                    changed += 1;
                }
            }
        }
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::field::{Edges, FlowField};

    /// A 2 m terrain and a 0.5 m field of 64² cells placed on it, cell-aligned so that each
    /// interior node's footprint holds exactly 4 × 4 field cells.
    fn setup() -> (Grid2<f32>, FlowField) {
        let terrain = Grid2::new(32, 32, 2.0, Vec2::ZERO, 10.0f32).unwrap();
        let ground = Grid2::new(64, 64, 0.5, Vec2::new(10.25, 10.25), 10.0f64).unwrap();
        (terrain, FlowField::new(ground, Edges::default(), 300.0).unwrap())
    }

    #[test]
    fn frozen_volume_reaches_the_terrain_once() {
        let (mut terrain, mut field) = setup();
        let mut imprint = TerrainImprint::new(&terrain, &field);
        // Nodes at x = 12, 14, …, 40 lie inside [10.25, 41.75]: 15 × 15.
        assert_eq!(imprint.len(), 225);
        // 0.3 m frozen over a 10 × 10 m block of cells aligned with node footprints
        // (x from 15 to 25 m: footprints of nodes 16, 18, 20, 22, 24).
        for j in 0..64 {
            for i in 0..64 {
                let p = field.ground().position(i, j);
                if (15.0..25.0).contains(&p.x) && (15.0..25.0).contains(&p.y) {
                    field.solid.set(i, j, 0.3);
                }
            }
        }
        let frozen = field.solid().data().iter().sum::<f64>() * 0.25;
        let before = terrain.sum();
        let changed = imprint.apply(&mut terrain, &field, 1e-3);
        assert_eq!(changed, 25);
        let gained = (terrain.sum() - before) * 4.0;
        assert!((gained - frozen).abs() < 1e-4 * frozen, "terrain gained {gained} m³ of {frozen}");
        assert!((terrain.get(10, 10) - 10.3).abs() < 1e-5);
        assert_eq!(terrain.get(5, 5), 10.0, "outside the field");
        assert_eq!(imprint.apply(&mut terrain, &field, 1e-3), 0, "nothing new to write");
    }

    #[test]
    fn a_field_between_nodes_covers_nothing() {
        let terrain = Grid2::new(8, 8, 100.0, Vec2::ZERO, 0.0f32).unwrap();
        let ground = Grid2::new(16, 16, 0.5, Vec2::new(110.0, 110.0), 0.0f64).unwrap();
        let field = FlowField::new(ground, Edges::default(), 300.0).unwrap();
        let mut imprint = TerrainImprint::new(&terrain, &field);
        assert!(imprint.is_empty());
        let mut t2 = terrain.clone();
        assert_eq!(imprint.apply(&mut t2, &field, 0.0), 0);
        assert_eq!(t2, terrain);
    }
}
