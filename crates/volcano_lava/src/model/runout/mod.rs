//! Lava over a whole terrain (docs/physics/lava.md §7): a volcano's own flows, fed at a vent
//! and running kilometres, on a grid aligned with the terrain's nodes and stored as sparse
//! tiles that wake where lava arrives and sleep where it froze (docs/ARCHITECTURE.md, "Lava
//! over the whole terrain"). One [`Runout::step`] advances it: vents emit, the lava flows
//! (the lava field's mass-exact lubrication scheme across tile borders), cools through its
//! crusts, freezes into the ground (written into the terrain by [`Runout::write_frozen`]) and
//! quenches where it enters the sea.
//!
//! A cell is a few metres: the flow's width is resolved, the crust is not. The crusts are a
//! law of the lava's age, the mean time since it left the vent, carried with the lava:
//! `δ = 2√(κ t)` on top (thesis eq 5.1) and the same against the ground. The top's crust
//! insulates the core (`thermal::heat_loss_through_crust`); the column freezes when the two
//! crusts meet or the core falls below the solidus. This is the conductive cooling behind the
//! Graetz-number limit of lava-flow length (Pinkerton & Wilson 1994).

mod flow;
mod stats;
#[cfg(test)]
mod tests;
pub mod tiles;

use bevy::math::DVec2;
use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::error::in_range;
use volcano_core::{ConfigError, NodeRegion, Terrain};

use super::budget::VolumeBudget;
use super::crust::crust_from_contact;
use super::params::LavaParams;
use super::thermal::{effective_heat_capacity, heat_loss_through_crust};
pub use stats::RunoutStats;
use tiles::{CellKind, EAST, NORTH, RunoutGrid, SOUTH, TILE, TILE_CELLS, Tile, Tiles, WEST};

/// How finely a [`Runout`] resolves the terrain and how soon dry tiles sleep.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunoutSettings {
    /// Lava cells per terrain node along each axis (1..=16): a 40 m terrain with 4 has 10 m
    /// cells.
    pub refine: u32,
    /// Seconds a tile stays stored after its last lava froze or left (≥ 0).
    pub sleep_after: f64,
}

impl Default for RunoutSettings {
    fn default() -> Self {
        Self { refine: 4, sleep_after: 2.0 }
    }
}

impl RunoutSettings {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("runout refine", self.refine as f64, 1.0, 16.0)?;
        in_range("runout sleep_after", self.sleep_after, 0.0, 1e6)?;
        Ok(())
    }
}

/// A vent feeding a [`Runout`]: lava at `rate` m³/s and `temperature` K, spread evenly over
/// the cells whose centres lie within `radius` of the vent (at least the cell holding its
/// centre). The vent is the point `centre`, or for a fissure the segment from
/// `centre − fissure` to `centre + fissure`.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
pub struct Vent {
    /// World (x, z) of the vent (m).
    pub centre: DVec2,
    /// Radius of the fed area (m, ≥ 0).
    pub radius: f64,
    /// Volume rate (m³/s of dense lava, ≥ 0).
    pub rate: f64,
    /// Temperature of the lava (K).
    pub temperature: f64,
    /// Half the fissure, from its centre to one end (world x, z; m); zero for a point vent.
    #[serde(default)]
    pub fissure: DVec2,
}

impl Vent {
    /// A point vent.
    pub fn point(centre: DVec2, radius: f64, rate: f64, temperature: f64) -> Self {
        Self { centre, radius, rate, temperature, fissure: DVec2::ZERO }
    }

    /// Distance (m) from world (x, z) `p` to the vent (its point or its fissure's segment).
    pub fn distance(&self, p: DVec2) -> f64 {
        let d = p - self.centre;
        let len2 = self.fissure.length_squared();
        if len2 == 0.0 {
            return d.length();
        }
        let s = (d.dot(self.fissure) / len2).clamp(-1.0, 1.0);
        (d - self.fissure * s).length()
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !self.centre.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "vent centre",
                value: f64::NAN,
                reason: "must be finite".into(),
            });
        }
        in_range("vent radius", self.radius, 0.0, 5_000.0)?;
        in_range("vent rate", self.rate, 0.0, 1e6)?;
        in_range("vent temperature", self.temperature, 300.0, 2500.0)?;
        in_range("vent fissure half-length", self.fissure.length(), 0.0, 5_000.0)?;
        Ok(())
    }
}

/// What one [`Runout::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunoutReport {
    /// Flow substeps taken.
    pub substeps: u32,
    /// The substep cap was reached and the flow slowed (a limiter).
    pub mobility_capped: bool,
    /// Volume emitted by the vents (m³).
    pub emitted: f64,
    /// Volume frozen into the ground (m³), quenched lava included.
    pub frozen: f64,
    /// Volume quenched by the sea (m³).
    pub quenched: f64,
    /// Heat given to the sea and the air above it by quenched lava (J).
    pub quench_heat: f64,
    /// World (x, z) of the quenched lava's centre of volume (where the laze rises).
    pub quench_at: Option<DVec2>,
    /// Volume that left the terrain (m³).
    pub outflow: f64,
    /// Vent volume that fell off the terrain or into the sea and was not emitted (m³).
    pub vent_lost: f64,
    /// Vents that failed [`Vent::validate`] and emitted nothing.
    pub vents_rejected: u32,
    /// Cells whose state was no longer finite, reset to dry ground before the step (a fault).
    pub repaired_cells: u32,
    /// The lava the accounts held in them, booked as `faulted` (m³).
    pub lost_m3: f64,
    /// Tiles woken this step.
    pub woke: u32,
    /// Tiles put to sleep this step.
    pub slept: u32,
}

/// Lava over a whole terrain. Create with [`Runout::new`]; advance with [`Runout::step`].
#[derive(Debug, Clone, PartialEq)]
pub struct Runout {
    grid: RunoutGrid,
    settings: RunoutSettings,
    tiles: Tiles,
    work: flow::Work,
    /// What each vent of the last step emitted (m³), in the order given.
    emitted: Vec<f64>,
    budget: VolumeBudget,
    /// Frozen thickness not yet handed to the terrain, per terrain node (m), keyed (row,
    /// column) so it iterates row-major.
    pending: std::collections::BTreeMap<(usize, usize), f64>,
    /// Simulated time (s).
    time: f64,
    /// Air temperature (K): the temperature of dry cells.
    air: f64,
}

impl Runout {
    /// An empty runout over `terrain`. Errors on invalid settings.
    pub fn new(
        terrain: &Terrain,
        settings: RunoutSettings,
        params: &LavaParams,
    ) -> Result<Self, ConfigError> {
        settings.validate()?;
        params.validate()?;
        Ok(Self {
            grid: RunoutGrid::over(terrain, settings.refine as usize),
            settings,
            tiles: Tiles::default(),
            work: flow::Work::default(),
            emitted: Vec::new(),
            budget: VolumeBudget::default(),
            pending: Default::default(),
            time: 0.0,
            air: params.air_temperature,
        })
    }

    /// The grid (cell size, placement).
    pub fn grid(&self) -> &RunoutGrid {
        &self.grid
    }
    /// The settings.
    pub fn settings(&self) -> RunoutSettings {
        self.settings
    }
    /// The stored tiles (in the order they woke).
    pub fn tiles(&self) -> &[Tile] {
        &self.tiles.list
    }
    /// The volume accounts.
    pub fn budget(&self) -> &VolumeBudget {
        &self.budget
    }
    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Liquid lava volume (m³), summed tile by tile in order.
    pub fn lava_volume(&self) -> f64 {
        let a = self.grid.cell * self.grid.cell;
        self.tiles.list.iter().map(|t| t.h.iter().sum::<f64>()).sum::<f64>() * a
    }

    /// Advances `dt` seconds: `vents` emit, the lava flows, cools and freezes. `terrain` is
    /// where new tiles sample their ground: write what froze into it
    /// ([`Runout::write_frozen`]) before the next step. Parameters must have passed their `validate`; an invalid vent
    /// emits nothing and is counted in [`RunoutReport::vents_rejected`]; a non-positive or
    /// non-finite `dt` does nothing.
    pub fn step(&mut self, terrain: &Terrain, params: &LavaParams, vents: &[Vent], dt: f64) -> RunoutReport {
        let mut report = RunoutReport::default();
        if !(dt.is_finite() && dt > 0.0) {
            return report;
        }
        (report.repaired_cells, report.lost_m3) = self.repair(terrain);
        let before = self.tiles.list.len();
        self.emitted.clear();
        for vent in vents {
            let v = if vent.validate().is_ok() {
                self.emit(terrain, vent, dt, &mut report)
            } else {
                report.vents_rejected += 1;
                0.0
            };
            self.emitted.push(v);
        }
        let (grid, air) = (self.grid, self.air);
        let flow = flow::advance(&mut self.tiles, &mut self.work, grid.cell, params, dt, |tiles| {
            wake_neighbours(tiles, &grid, terrain, air)
        });
        report.substeps = flow.substeps;
        report.mobility_capped = flow.mobility_capped;
        report.outflow = flow.outflow;
        self.budget.outflow += flow.outflow;
        self.budget.rounding += flow.rounding;
        self.cool_and_freeze(params, dt, &mut report);
        report.woke = (self.tiles.list.len() - before) as u32;
        report.slept = self.sleep(dt);
        self.time += dt;
        report
    }

    /// Finds cells whose state is no longer finite (every step, in every build: a pass over the
    /// stored cells) and resets them to dry ground, resampled from `terrain` if the ground
    /// itself was lost; what the accounts then miss is booked as `faulted`, so they close.
    /// Returns the cells reset and the volume booked.
    fn repair(&mut self, terrain: &Terrain) -> (u32, f64) {
        let mut cells = 0;
        let heights = terrain.heights();
        for tile in &mut self.tiles.list {
            for k in 0..TILE_CELLS {
                // One test per cell: a sum is finite only if every term is.
                let sum = tile.h[k]
                    + tile.t[k]
                    + tile.age[k]
                    + tile.ground[k]
                    + tile.solid[k]
                    + tile.vel[0][k]
                    + tile.vel[1][k];
                if sum.is_finite() {
                    continue;
                }
                cells += 1;
                tile.h[k] = 0.0;
                tile.t[k] = self.air;
                tile.age[k] = 0.0;
                tile.vel[0][k] = 0.0;
                tile.vel[1][k] = 0.0;
                if !(tile.ground[k].is_finite() && tile.solid[k].is_finite()) {
                    let (a, b) = global(tile.key, k);
                    let c = self.grid.centre(a, b);
                    let p = bevy::math::Vec2::new(c.x as f32, c.y as f32);
                    tile.ground[k] = heights.sample(p, volcano_core::Boundary::Clamp) as f64;
                    tile.solid[k] = 0.0;
                }
            }
        }
        if cells == 0 {
            return (0, 0.0);
        }
        let lost = self.budget.expected() - self.lava_volume();
        self.budget.faulted += lost;
        (cells, lost)
    }

    /// Emits one vent's lava for `dt` into its cells (waking their tiles); returns the volume
    /// emitted.
    fn emit(&mut self, terrain: &Terrain, vent: &Vent, dt: f64, report: &mut RunoutReport) -> f64 {
        let v = vent.rate * dt;
        if v <= 0.0 {
            return 0.0;
        }
        let cells = self.vent_cells(vent);
        let mut woke = false;
        for &(a, b) in &cells {
            woke |= self.tiles.ensure(&self.grid, terrain, tile_of(a, b), self.air);
        }
        if woke {
            self.tiles.relink();
        }
        let land: Vec<(usize, usize)> = cells
            .iter()
            .filter_map(|&(a, b)| {
                let ti = self.tiles.get(tile_of(a, b))?;
                let k = local(a, b);
                matches!(self.tiles.list[ti].kind[k], CellKind::Land | CellKind::Vent).then_some((ti, k))
            })
            .collect();
        if land.is_empty() {
            report.vent_lost += v;
            return 0.0;
        }
        let area = self.grid.cell * self.grid.cell;
        let dh = v / (land.len() as f64 * area);
        for (ti, k) in land {
            let t = &mut self.tiles.list[ti];
            t.kind[k] = CellKind::Vent;
            let h1 = t.h[k] + dh;
            t.t[k] = (t.h[k] * t.t[k] + dh * vent.temperature) / h1;
            t.age[k] = t.h[k] * t.age[k] / h1;
            t.h[k] = h1;
        }
        self.budget.sources += v;
        report.emitted += v;
        v
    }

    /// The volume (m³) each vent given to the last [`Runout::step`] emitted, in that order (0
    /// for a vent off the terrain, over the sea or invalid).
    pub fn emitted_by_vent(&self) -> &[f64] {
        &self.emitted
    }

    /// The cells a vent feeds.
    pub fn vent_cells(&self, vent: &Vent) -> Vec<(i64, i64)> {
        let g = &self.grid;
        let Some((ca, cb)) = g.cell_of(vent.centre) else { return Vec::new() };
        let (ra, rb) = (
            ((vent.radius + vent.fissure.x.abs()) / g.cell).ceil() as i64 + 1,
            ((vent.radius + vent.fissure.y.abs()) / g.cell).ceil() as i64 + 1,
        );
        let mut cells: Vec<(i64, i64)> = (cb - rb..=cb + rb)
            .flat_map(|b| (ca - ra..=ca + ra).map(move |a| (a, b)))
            .filter(|&(a, b)| {
                a >= 0
                    && b >= 0
                    && (a as usize) < g.na
                    && (b as usize) < g.nb
                    && vent.distance(g.centre(a, b)) <= vent.radius
            })
            .collect();
        if cells.is_empty() {
            cells.push((ca, cb));
        }
        cells
    }

    /// Cools every lava cell for `dt`, freezes the solidified ones into the ground and
    /// quenches lava in the sea.
    fn cool_and_freeze(&mut self, params: &LavaParams, dt: f64, report: &mut RunoutReport) {
        let area = self.grid.cell * self.grid.cell;
        let kappa = params.kappa();
        let te = params.air_temperature;
        let mut quench_at = DVec2::ZERO;
        for tile in &mut self.tiles.list {
            for k in 0..TILE_CELLS {
                let h = tile.h[k];
                if h <= 0.0 {
                    continue;
                }
                let age = tile.age[k];
                tile.age[k] += dt;
                let sea = tile.kind[k] == CellKind::Sea;
                let mut frozen = sea;
                if !frozen && params.cooling {
                    let t = tile.t[k];
                    let top = heat_loss_through_crust(params, t, crust_from_contact(kappa, age + 0.5 * dt));
                    let base = if tile.kind[k] == CellKind::Vent {
                        0.0
                    } else {
                        base_conduction(params, t, age, dt)
                    };
                    let loss = top + base + params.base_heat_transfer * (t - te);
                    let rho_c = params.density * effective_heat_capacity(params, t);
                    tile.t[k] = (t - loss * dt / (rho_c * h)).max(te);
                    frozen = tile.t[k] < params.solidus;
                }
                if !frozen {
                    continue;
                }
                let v = h * area;
                if sea {
                    report.quenched += v;
                    let cooled = tile.t[k] - te;
                    report.quench_heat += params.density
                        * v
                        * (params.heat_capacity * cooled
                            + if tile.t[k] > params.solidus { params.latent_heat } else { 0.0 });
                    let (a, b) = global(tile.key, k);
                    quench_at += self.grid.centre(a, b) * v;
                }
                report.frozen += v;
                tile.solid[k] += h;
                tile.ground[k] += h;
                tile.h[k] = 0.0;
                tile.t[k] = te;
                tile.age[k] = 0.0;
                tile.vel[0][k] = 0.0;
                tile.vel[1][k] = 0.0;
                let (a, b) = global(tile.key, k);
                let r = self.grid.refine;
                let node = (b as usize / r, a as usize / r);
                *self.pending.entry(node).or_insert(0.0) += h / (r * r) as f64;
            }
        }
        if report.quenched > 0.0 {
            report.quench_at = Some(quench_at / report.quenched);
        }
        self.budget.solidified += report.frozen;
    }

    /// Drops tiles dry for `sleep_after` whose neighbours hold no lava on the shared side.
    fn sleep(&mut self, dt: f64) -> u32 {
        let steps = (self.settings.sleep_after / dt).ceil() as u32;
        let n = self.tiles.list.len();
        let mut drop = vec![false; n];
        for (i, tile) in self.tiles.list.iter_mut().enumerate() {
            if tile.wet() {
                tile.dry_steps = 0;
                continue;
            }
            tile.dry_steps = tile.dry_steps.saturating_add(1);
            drop[i] = tile.dry_steps > steps;
        }
        for (tile, drop) in self.tiles.list.iter().zip(drop.iter_mut()) {
            // The neighbour's side facing this tile.
            let facing = [WEST, SOUTH, EAST, NORTH];
            *drop =
                *drop && (0..4).all(|s| tile.nbr[s].is_none_or(|j| !self.tiles.list[j].wet_side(facing[s])));
        }
        let slept = drop.iter().filter(|&&d| d).count() as u32;
        if slept > 0 {
            self.tiles.retain(&drop);
        }
        slept
    }

    /// Writes the lava frozen since the last call into `terrain`'s added layer (the terrain
    /// the runout was made over; [`Terrain::add_thickness`]) and returns the nodes whose
    /// height moved (empty if none). On an error the frozen thickness is dropped, not written.
    pub fn write_frozen(&mut self, terrain: &mut Terrain) -> Result<NodeRegion, ConfigError> {
        match self.take_frozen() {
            Some((region, dh)) => terrain.add_thickness(region, &dh),
            None => Ok(NodeRegion::default()),
        }
    }

    /// Takes the lava frozen since the last call, as thickness per terrain node over the
    /// smallest rectangle holding it (row-major, as [`Terrain::add_thickness`] wants), or
    /// `None` if nothing froze. Its sum times the node area is the volume frozen.
    fn take_frozen(&mut self) -> Option<(NodeRegion, Vec<f64>)> {
        if self.pending.is_empty() {
            return None;
        }
        let (mut lo, mut hi) = ((usize::MAX, usize::MAX), (0, 0));
        for &(j, i) in self.pending.keys() {
            lo = (lo.0.min(i), lo.1.min(j));
            hi = (hi.0.max(i), hi.1.max(j));
        }
        let region = NodeRegion { i0: lo.0, j0: lo.1, ni: hi.0 + 1 - lo.0, nj: hi.1 + 1 - lo.1 };
        let mut out = vec![0.0; region.len()];
        for ((j, i), v) in std::mem::take(&mut self.pending) {
            out[(j - region.j0) * region.ni + (i - region.i0)] = v;
        }
        Some((region, out))
    }

    /// Whether any cell whose centre lies within `radius` m of world (x, z) `centre` holds
    /// lava thicker than `min_h` m.
    pub fn covered(&self, centre: DVec2, radius: f64, min_h: f64) -> bool {
        let g = &self.grid;
        let lo = ((centre - DVec2::splat(radius) - g.corner) / g.cell).floor();
        let hi = ((centre + DVec2::splat(radius) - g.corner) / g.cell).floor();
        if !(lo.is_finite() && hi.is_finite()) {
            return false;
        }
        // Only the stored tiles can hold lava: visit those the disc touches.
        self.tiles.list.iter().any(|tile| {
            let (a0, b0) = (tile.key.0 as f64 * TILE as f64, tile.key.1 as f64 * TILE as f64);
            let (a1, b1) = (a0 + TILE as f64 - 1.0, b0 + TILE as f64 - 1.0);
            if a1 < lo.x || b1 < lo.y || a0 > hi.x || b0 > hi.y {
                return false;
            }
            (0..TILE_CELLS).any(|k| {
                let (a, b) = global(tile.key, k);
                tile.h[k] > min_h && g.centre(a, b).distance(centre) <= radius
            })
        })
    }

    /// Cell `(a, b)`'s depth-averaged lava speed (m/s) over the last substep, or `None` if its
    /// tile is not stored.
    pub fn speed(&self, a: i64, b: i64) -> Option<f64> {
        let tile = &self.tiles.list[self.tiles.get(tile_of(a, b))?];
        let k = local(a, b);
        Some(tile.vel[0][k].hypot(tile.vel[1][k]))
    }

    /// Cell `(a, b)`'s lava thickness (m), temperature (K), ground (m) and age (s), or `None`
    /// if its tile is not stored (dry, its ground the terrain's).
    pub fn cell_state(&self, a: i64, b: i64) -> Option<(f64, f64, f64, f64)> {
        let tile = &self.tiles.list[self.tiles.get(tile_of(a, b))?];
        let k = local(a, b);
        Some((tile.h[k], tile.t[k], tile.ground[k], tile.age[k]))
    }

    /// Lava thickness (m) and temperature (K) at world (x, z), or `None` where no lava is.
    pub fn lava_at(&self, p: DVec2) -> Option<(f64, f64)> {
        let (a, b) = self.grid.cell_of(p)?;
        let tile = &self.tiles.list[self.tiles.get(tile_of(a, b))?];
        let k = local(a, b);
        (tile.h[k] > 0.0).then(|| (tile.h[k], tile.t[k]))
    }
}

/// Mean heat flux (W/m²) from lava at `t` (K) into cold ground through its chilled base over
/// the step `[age, age + dt]`: the base crust is `2√(κ s)` thick at age `s` (thesis eq 5.1, as
/// on top) with the ground at the air temperature, `k (T − T_e)/(2√(κ s))`, averaged over the
/// step so the contact's `1/√s` start stays finite: `k (T − T_e)(√(age + dt) − √age)/(dt √κ)`.
fn base_conduction(params: &LavaParams, t: f64, age: f64, dt: f64) -> f64 {
    let kappa = params.kappa();
    params.conductivity * (t - params.air_temperature).max(0.0) * ((age + dt).sqrt() - age.sqrt())
        / (dt * kappa.sqrt())
}

/// Wakes the neighbour of every tile with lava on the side they share.
fn wake_neighbours(tiles: &mut Tiles, grid: &RunoutGrid, terrain: &Terrain, air: f64) {
    let mut want = Vec::new();
    for t in &tiles.list {
        for (side, d) in [(EAST, (1, 0)), (NORTH, (0, 1)), (WEST, (-1, 0)), (SOUTH, (0, -1))] {
            if t.nbr[side].is_none() && t.wet_side(side) {
                want.push((t.key.0 + d.0, t.key.1 + d.1));
            }
        }
    }
    let mut woke = false;
    for key in want {
        woke |= tiles.ensure(grid, terrain, key, air);
    }
    if woke {
        tiles.relink();
    }
}

/// The tile holding cell `(a, b)`.
fn tile_of(a: i64, b: i64) -> (i32, i32) {
    (a.div_euclid(TILE as i64) as i32, b.div_euclid(TILE as i64) as i32)
}

/// Cell `(a, b)`'s index in its tile.
fn local(a: i64, b: i64) -> usize {
    b.rem_euclid(TILE as i64) as usize * TILE + a.rem_euclid(TILE as i64) as usize
}

/// Global cell of index `k` in tile `key`.
fn global(key: (i32, i32), k: usize) -> (i64, i64) {
    (key.0 as i64 * TILE as i64 + (k % TILE) as i64, key.1 as i64 * TILE as i64 + (k / TILE) as i64)
}
