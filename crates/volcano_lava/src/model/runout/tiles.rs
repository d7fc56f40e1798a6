//! The sparse tiles of a [`super::Runout`]: the lava grid over the whole terrain, stored only
//! where lava is or was recently. A tile is `TILE × TILE` cells; it wakes (is allocated, its
//! ground sampled from the terrain) when lava reaches its neighbour's border, and sleeps (is
//! dropped) once it and its neighbours' borders have been dry for a while. Frozen lava is
//! written into the terrain as it freezes, so a tile that wakes again finds it in the ground.

use std::collections::BTreeMap;

use bevy::math::{DVec2, Vec2};
use volcano_core::{Boundary, LandCover, Terrain};

/// Cells along a tile's side.
pub const TILE: usize = 32;
/// Cells in a tile.
pub const TILE_CELLS: usize = TILE * TILE;

/// What lies under a cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum CellKind {
    /// Land: lava flows, cools and freezes.
    Land,
    /// Land over a vent's conduit: the ground is as hot as the lava (no loss through the base).
    Vent,
    /// Sea (the terrain's water cover, or ground below sea level): lava entering it quenches.
    Sea,
    /// Beyond the terrain: lava entering it leaves the simulation (booked as outflow).
    Outside,
}

/// The lava cells over a terrain: cell `(a, b)` is the `(a mod r, b mod r)` sub-cell of
/// terrain node `(a / r, b / r)` (`r` = refinement), so each node's area is split into `r²`
/// cells and frozen lava goes back to the node whose area holds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunoutGrid {
    /// World (x, z) of the corner of cell (0, 0).
    pub(crate) corner: DVec2,
    /// Cell size (m).
    pub(crate) cell: f64,
    /// Lava cells per terrain node along each axis.
    pub(crate) refine: usize,
    /// Cells along x and z inside the terrain.
    pub(crate) na: usize,
    pub(crate) nb: usize,
    /// Sea level (m).
    pub(crate) sea_level: f64,
}

impl RunoutGrid {
    /// The grid over `terrain` with `refine` cells per node side.
    pub(crate) fn over(terrain: &Terrain, refine: usize) -> Self {
        let g = terrain.heights();
        let c = g.cell();
        let o = g.origin().as_dvec2();
        Self {
            corner: o - DVec2::splat(0.5 * c),
            cell: c / refine as f64,
            refine,
            na: g.nx() * refine,
            nb: g.ny() * refine,
            sea_level: terrain.sea_level() as f64,
        }
    }

    /// World (x, z) of the centre of cell `(a, b)`.
    pub fn centre(&self, a: i64, b: i64) -> DVec2 {
        self.corner + DVec2::new(a as f64 + 0.5, b as f64 + 0.5) * self.cell
    }

    /// The cell holding world point `p`, if it is on the terrain.
    pub fn cell_of(&self, p: DVec2) -> Option<(i64, i64)> {
        let g = (p - self.corner) / self.cell;
        let (a, b) = (g.x.floor(), g.y.floor());
        let inside = a >= 0.0 && b >= 0.0 && a < self.na as f64 && b < self.nb as f64;
        inside.then_some((a as i64, b as i64))
    }

    /// Cell size (m).
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// Tiles along x and z that hold terrain cells.
    pub(crate) fn tiles(&self) -> (i32, i32) {
        (self.na.div_ceil(TILE) as i32, self.nb.div_ceil(TILE) as i32)
    }
}

/// One tile's cells (row-major, `TILE` per row).
#[derive(Debug, Clone, PartialEq)]
pub struct Tile {
    /// Tile coordinates: cells `key.0 · TILE ..` along x, `key.1 · TILE ..` along z.
    pub(crate) key: (i32, i32),
    /// Lava thickness (m).
    pub(crate) h: Vec<f64>,
    /// Depth-averaged temperature (K).
    pub(crate) t: Vec<f64>,
    /// Mean time since the lava left the vent (s): the age of its crusts.
    pub(crate) age: Vec<f64>,
    /// Depth-averaged velocity (m/s) along x and z over the last substep.
    pub(crate) vel: [Vec<f64>; 2],
    /// Ground under the lava: terrain as sampled at wake + lava frozen since (m).
    pub(crate) ground: Vec<f64>,
    /// Lava frozen here since the tile woke (m).
    pub(crate) solid: Vec<f64>,
    pub(crate) kind: Vec<CellKind>,
    /// Steps since the tile last held lava.
    pub(crate) dry_steps: u32,
    /// Neighbour tiles east, north, west, south (indices into the tile list).
    pub(crate) nbr: [Option<usize>; 4],
}

/// Neighbour slots of [`Tile::nbr`].
pub(crate) const EAST: usize = 0;
pub(crate) const NORTH: usize = 1;
pub(crate) const WEST: usize = 2;
pub(crate) const SOUTH: usize = 3;

impl Tile {
    /// A dry tile `key` of `grid`, its ground sampled from `terrain` at the cell centres.
    pub(crate) fn wake(grid: &RunoutGrid, terrain: &Terrain, key: (i32, i32), air: f64) -> Self {
        let mut ground = vec![0.0; TILE_CELLS];
        let mut kind = vec![CellKind::Outside; TILE_CELLS];
        let heights = terrain.heights();
        for j in 0..TILE {
            for i in 0..TILE {
                let (a, b) = (key.0 as i64 * TILE as i64 + i as i64, key.1 as i64 * TILE as i64 + j as i64);
                let p = grid.centre(a, b);
                let p32 = Vec2::new(p.x as f32, p.y as f32);
                let k = j * TILE + i;
                ground[k] = heights.sample(p32, Boundary::Clamp) as f64;
                let inside = a >= 0 && b >= 0 && a < grid.na as i64 && b < grid.nb as i64;
                kind[k] = if !inside {
                    CellKind::Outside
                } else if ground[k] < grid.sea_level || terrain.cover_at(p32.x, p32.y) == LandCover::Water {
                    CellKind::Sea
                } else {
                    CellKind::Land
                };
            }
        }
        Self {
            key,
            h: vec![0.0; TILE_CELLS],
            t: vec![air; TILE_CELLS],
            age: vec![0.0; TILE_CELLS],
            vel: [vec![0.0; TILE_CELLS], vec![0.0; TILE_CELLS]],
            ground,
            solid: vec![0.0; TILE_CELLS],
            kind,
            dry_steps: 0,
            nbr: [None; 4],
        }
    }

    /// Tile coordinates.
    pub fn key(&self) -> (i32, i32) {
        self.key
    }
    /// Lava thickness per cell (m), row-major.
    pub fn thickness(&self) -> &[f64] {
        &self.h
    }
    /// Lava temperature per cell (K).
    pub fn temperature(&self) -> &[f64] {
        &self.t
    }
    /// Mean time since the lava of each cell left the vent (s): the age of its crusts.
    pub fn age(&self) -> &[f64] {
        &self.age
    }
    /// Depth-averaged velocity per cell (m/s, x and z) over the last substep.
    pub fn velocity(&self) -> (&[f64], &[f64]) {
        (&self.vel[0], &self.vel[1])
    }
    /// Ground per cell, frozen lava included (m).
    pub fn ground(&self) -> &[f64] {
        &self.ground
    }
    /// Lava frozen per cell since the tile woke (m).
    pub fn solid(&self) -> &[f64] {
        &self.solid
    }

    /// Whether any cell on the given side holds lava.
    pub(crate) fn wet_side(&self, side: usize) -> bool {
        let wet = |k: usize| self.h[k] > 0.0;
        match side {
            EAST => (0..TILE).any(|j| wet(j * TILE + TILE - 1)),
            WEST => (0..TILE).any(|j| wet(j * TILE)),
            NORTH => (0..TILE).any(|i| wet((TILE - 1) * TILE + i)),
            _ => (0..TILE).any(wet),
        }
    }

    /// Whether any cell holds lava.
    pub(crate) fn wet(&self) -> bool {
        self.h.iter().any(|&h| h > 0.0)
    }
}

/// The tile list and its index by key; neighbours are re-linked whenever the set changes.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct Tiles {
    pub list: Vec<Tile>,
    index: BTreeMap<(i32, i32), usize>,
}

impl Tiles {
    pub fn get(&self, key: (i32, i32)) -> Option<usize> {
        self.index.get(&key).copied()
    }

    /// Adds the dry tile `key` unless it exists or lies off the grid; returns whether it was
    /// added (the caller re-links).
    pub fn ensure(&mut self, grid: &RunoutGrid, terrain: &Terrain, key: (i32, i32), air: f64) -> bool {
        // One ring of tiles beyond the terrain, all `Outside`: lava crossing its edge leaves.
        let (ta, tb) = grid.tiles();
        if key.0 < -1 || key.1 < -1 || key.0 > ta || key.1 > tb || self.index.contains_key(&key) {
            return false;
        }
        self.index.insert(key, self.list.len());
        self.list.push(Tile::wake(grid, terrain, key, air));
        true
    }

    /// Drops the tiles `drop` says to (in list order, keeping the others' order) and re-links.
    pub fn retain(&mut self, drop: &[bool]) {
        let mut k = 0;
        self.list.retain(|_| {
            k += 1;
            !drop[k - 1]
        });
        self.relink();
    }

    /// Rebuilds the index and every tile's neighbour links.
    pub fn relink(&mut self) {
        self.index = self.list.iter().enumerate().map(|(i, t)| (t.key, i)).collect();
        for i in 0..self.list.len() {
            let (x, y) = self.list[i].key;
            let at = |k| self.index.get(&k).copied();
            self.list[i].nbr = [at((x + 1, y)), at((x, y + 1)), at((x - 1, y)), at((x, y - 1))];
        }
    }
}
