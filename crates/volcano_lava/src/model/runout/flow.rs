//! The flow substeps of a [`super::Runout`]: the same mass-exact lubrication scheme as a
//! lava field's ([`crate::model::flow`], docs/physics/lava.md §6.1), over sparse tiles.
//!
//! Per substep: (0) tiles with lava on a side wake their neighbour there, so lava never
//! reaches a face whose far cell is not stored (a face to a missing tile joins two dry cells
//! and carries nothing); (1) cell mobilities `ρ g h³/(3η(T))`; (2) a flux per face owned by
//! the cell west or south of it (`flux::face_flux`), reading across tile borders; (3) the
//! global stable substep; (4) each cell's outgoing volume scaled to what it holds; (5) one
//! volume per face, subtracted from its donor and added to its receiver as the same f64
//! number, with heat and crust age moving at the donor's values. Lava reaching a cell beyond
//! the terrain leaves (outflow).

use super::tiles::{CellKind, EAST, NORTH, TILE, TILE_CELLS, Tiles};
use crate::model::flow::substep;
use crate::model::flux::{face_flux, mobility};
use crate::model::params::{GRAVITY, LavaParams};

/// What [`advance`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct FlowStep {
    pub substeps: u32,
    pub mobility_capped: bool,
    pub outflow: f64,
    pub rounding: f64,
}

/// Per-tile work arrays of one substep.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Work {
    mob: Vec<Vec<f64>>,
    /// Flux (m²/s) across the east and north face of each cell.
    fe: Vec<Vec<f64>>,
    fn_: Vec<Vec<f64>>,
    lim: Vec<Vec<f64>>,
}

fn resize(v: &mut Vec<Vec<f64>>, n: usize) {
    v.resize_with(n, || vec![0.0; TILE_CELLS]);
}

/// The cell across a tile's east (or north) face of cell `k`: `(tile, cell)` or none.
#[inline]
fn across(tiles: &Tiles, ti: usize, k: usize, side: usize) -> Option<(usize, usize)> {
    let (i, j) = (k % TILE, k / TILE);
    match side {
        EAST if i + 1 < TILE => Some((ti, k + 1)),
        EAST => tiles.list[ti].nbr[EAST].map(|n| (n, j * TILE)),
        _ if j + 1 < TILE => Some((ti, k + TILE)),
        _ => tiles.list[ti].nbr[NORTH].map(|n| (n, i)),
    }
}

/// Advances the tiles' lava by `dt` with CFL-limited substeps (at most `params.max_substeps`,
/// the last one with a capped mobility if they run out). `wake` is called before each substep
/// and must store the neighbours of every tile with lava on a side.
pub(crate) fn advance(
    tiles: &mut Tiles,
    work: &mut Work,
    cell: f64,
    params: &LavaParams,
    dt: f64,
    mut wake: impl FnMut(&mut Tiles),
) -> FlowStep {
    let mut report = FlowStep::default();
    let inv_dx = 1.0 / cell;
    let area = cell * cell;
    let yield_rg = params.yield_strength / (params.density * GRAVITY);
    let rg3 = params.density * GRAVITY / 3.0;
    let mut t_left = dt;
    while t_left > 0.0 && report.substeps < params.max_substeps {
        report.substeps += 1;
        wake(tiles);
        let n = tiles.list.len();
        for v in [&mut work.mob, &mut work.fe, &mut work.fn_, &mut work.lim] {
            resize(v, n);
        }
        // 1. mobilities.
        for (tile, mob) in tiles.list.iter().zip(work.mob.iter_mut()) {
            for ((m, &h), &t) in mob.iter_mut().zip(&tile.h).zip(&tile.t) {
                *m = mobility(params.viscosity, rg3, h, t, 1.0);
            }
        }
        // 2. fluxes of the east and north faces; the largest mobility and wave speed.
        let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
        for ti in 0..n {
            let a = &tiles.list[ti];
            for side in [EAST, NORTH] {
                for k in 0..TILE_CELLS {
                    let q = match across(tiles, ti, k, side) {
                        Some((tb, kb)) => {
                            let b = &tiles.list[tb];
                            let (q, m, w) = face_flux(
                                inv_dx,
                                yield_rg,
                                (a.ground[k], a.h[k], work.mob[ti][k]),
                                (b.ground[kb], b.h[kb], work.mob[tb][kb]),
                            );
                            m_max = m_max.max(m);
                            c_max = c_max.max(w);
                            q
                        }
                        None => 0.0,
                    };
                    if side == EAST { work.fe[ti][k] = q } else { work.fn_[ti][k] = q }
                }
            }
        }
        // 3. substep.
        let sub = substep(cell, (m_max, c_max), params, report.substeps, (t_left, dt));
        let (dt_s, vol) = (sub.dt, sub.face_volume);
        report.mobility_capped |= sub.capped;
        t_left = sub.left;
        let vol = vol * dt_s;
        let last = t_left == 0.0 || report.substeps == params.max_substeps;
        // 4. limiter: a cell's outgoing volume never exceeds what it holds. On the step's last
        //    substep the same four fluxes give the cell's depth-averaged velocity: their mean
        //    along each axis over its thickness (zero where dry).
        for ti in 0..n {
            let nbr = tiles.list[ti].nbr;
            let tile = &mut tiles.list[ti];
            for k in 0..TILE_CELLS {
                let (east, north) = (work.fe[ti][k], work.fn_[ti][k]);
                let west = behind(nbr, ti, k, EAST).map_or(0.0, |(t, c)| work.fe[t][c]);
                let south = behind(nbr, ti, k, NORTH).map_or(0.0, |(t, c)| work.fn_[t][c]);
                let out = east.max(0.0) + north.max(0.0) + (-west).max(0.0) + (-south).max(0.0);
                let h = tile.h[k];
                let (have, give) = (h * area, out * vol);
                work.lim[ti][k] = if give > have { have / give } else { 1.0 };
                if last {
                    let (u, v) = if h > 0.0 {
                        (0.5 * (west + east) / h, 0.5 * (south + north) / h)
                    } else {
                        (0.0, 0.0)
                    };
                    tile.vel[0][k] = u;
                    tile.vel[1][k] = v;
                }
            }
        }
        // 5. face volumes (each computed once, signed a → b), applied to both cells.
        for side in [EAST, NORTH] {
            for ti in 0..n {
                for k in 0..TILE_CELLS {
                    let q = if side == EAST { work.fe[ti][k] } else { work.fn_[ti][k] };
                    if q == 0.0 {
                        continue;
                    }
                    let Some((tb, kb)) = across(tiles, ti, k, side) else { continue };
                    let v = if q > 0.0 { q * vol * work.lim[ti][k] } else { q * vol * work.lim[tb][kb] };
                    move_volume(tiles, (ti, k), (tb, kb), v / area);
                }
            }
        }
        // Round-off negatives are clamped to zero and tallied; lava beyond the terrain leaves.
        for tile in &mut tiles.list {
            for k in 0..TILE_CELLS {
                if tile.h[k] < 0.0 {
                    report.rounding -= tile.h[k] * area;
                    tile.h[k] = 0.0;
                }
                if tile.kind[k] == CellKind::Outside && tile.h[k] > 0.0 {
                    report.outflow += tile.h[k] * area;
                    tile.h[k] = 0.0;
                    tile.t[k] = params.air_temperature;
                    tile.age[k] = 0.0;
                }
            }
        }
    }
    report
}

/// The cell whose east (or north) face is cell `k`'s west (or south) face, in tile `ti`
/// with neighbours `nbr`.
#[inline]
fn behind(nbr: [Option<usize>; 4], ti: usize, k: usize, side: usize) -> Option<(usize, usize)> {
    use super::tiles::{SOUTH, WEST};
    let (i, j) = (k % TILE, k / TILE);
    match side {
        EAST if i > 0 => Some((ti, k - 1)),
        EAST => nbr[WEST].map(|n| (n, j * TILE + TILE - 1)),
        _ if j > 0 => Some((ti, k - TILE)),
        _ => nbr[SOUTH].map(|n| (n, (TILE - 1) * TILE + i)),
    }
}

/// Moves `dh` metres of lava (signed: positive from `a` to `b`) with its heat and age at the
/// donor's values. The thickness change is the same f64 number on both sides.
#[inline]
fn move_volume(tiles: &mut Tiles, (ta, ka): (usize, usize), (tb, kb): (usize, usize), dh: f64) {
    let (donor, receiver) = if dh > 0.0 { ((ta, ka), (tb, kb)) } else { ((tb, kb), (ta, ka)) };
    let d = dh.abs();
    if d.is_nan() || d == 0.0 {
        return;
    }
    let (t_d, age_d) = {
        let t = &tiles.list[donor.0];
        (t.t[donor.1], t.age[donor.1])
    };
    {
        let t = &mut tiles.list[donor.0];
        t.h[donor.1] -= d;
    }
    let r = &mut tiles.list[receiver.0];
    let k = receiver.1;
    // h1 ≥ d > 0: the mix is finite.
    let h0 = r.h[k].max(0.0);
    let h1 = h0 + d;
    r.t[k] = (h0 * r.t[k] + d * t_d) / h1;
    r.age[k] = (h0 * r.age[k] + d * age_d) / h1;
    r.h[k] += d;
}
