//! The row loops of the flow substep ([`super::flow`]): the cell mobilities and face fluxes of
//! a row or face row, and pass 1 (per band, the mobilities and fluxes for the stable substep's
//! maxima only; pass 2, in `flow_update`, computes the same fluxes again next to the cells that
//! use them, so no flux grid makes a round trip through memory).
//!
//! The loops are written branch-free over whole rows (selects instead of early returns, the
//! wrapping first and last cells of a row apart), so the compiler can vectorise them. On
//! x86-64 CPUs with AVX-512F or AVX2 each band runs a copy compiled for it (checked at run
//! time), else the baseline (SSE2) copy: all evaluate the same IEEE operations on the same
//! numbers in the same order per cell (no fused multiply-add, no reassociation), so the
//! results are bit-identical on any machine. The maxima of pass 1 are taken over the bit patterns of the
//! non-negative mobilities and wave speeds (the same order as the values, exact in any order),
//! and the round-off tally of pass 2 is summed in cell order, row by row, only over rows that
//! had a negative thickness.

use super::bands::{band_range, simd_dispatch};
use super::field::{Edge, Edges};
use super::flux::{face_flux, mobility};
use super::params::ViscosityModel;

/// Read-only inputs of a flux pass.
pub(super) struct FluxCtx<'a> {
    pub nx: usize,
    pub ny: usize,
    pub inv_dx: f64,
    pub yield_rg: f64,
    pub rg3: f64,
    pub viscosity: ViscosityModel,
    pub edges: Edges,
    pub g: &'a [f64],
    pub h: &'a [f64],
    pub t: &'a [f64],
    pub fac: &'a [f64],
}

impl FluxCtx<'_> {
    pub fn mob(&self, k: usize) -> f64 {
        mobility(self.viscosity, self.rg3, self.h[k], self.t[k], self.fac[k])
    }
}

/// A non-negative value's bit pattern as an ordered integer (0 for zero, negative or NaN, so
/// the maximum ignores NaN as `f64::max` does).
#[inline(always)]
fn key(x: f64) -> i64 {
    if x > 0.0 { x.to_bits() as i64 } else { 0 }
}

/// Fluxes of the faces between cells `a[i]` and `b[i]` (each `(ground, h, mobility)` rows of
/// the same length as `out`), into `out`; returns the largest face mobility and wave speed
/// (zeros unless `MAX`).
#[inline(always)]
fn flux_pairs<const YIELD: bool, const MAX: bool>(
    inv_dx: f64,
    yield_rg: f64,
    (ga, ha, ma): (&[f64], &[f64], &[f64]),
    (gb, hb, mb): (&[f64], &[f64], &[f64]),
    out: &mut [f64],
) -> (f64, f64) {
    let n = out.len();
    let (ga, ha, ma, gb, hb, mb) = (&ga[..n], &ha[..n], &ma[..n], &gb[..n], &hb[..n], &mb[..n]);
    let yrg = if YIELD { yield_rg } else { 0.0 };
    let (mut m_max, mut c_max) = (0i64, 0i64);
    for i in 0..n {
        let (q, m, w) = face_flux(inv_dx, yrg, (ga[i], ha[i], ma[i]), (gb[i], hb[i], mb[i]));
        out[i] = q;
        if MAX {
            m_max = m_max.max(key(m));
            c_max = c_max.max(key(w));
        }
    }
    (f64::from_bits(m_max as u64), f64::from_bits(c_max as u64))
}

/// The mobility rows a band holds: local row `k` is grid row `(base + k) mod ny`.
#[derive(Clone, Copy)]
pub(super) struct MobRows<'a> {
    pub buf: &'a [f64],
    pub base: usize,
    pub nx: usize,
    pub ny: usize,
}

impl<'a> MobRows<'a> {
    #[inline(always)]
    fn row(&self, j: usize) -> &'a [f64] {
        let k = (j + self.ny - self.base) % self.ny;
        &self.buf[k * self.nx..(k + 1) * self.nx]
    }

    #[inline(always)]
    fn at(&self, k: usize) -> f64 {
        self.row(k / self.nx)[k % self.nx]
    }
}

/// Cell mobilities of grid rows `first..first + out.len() / nx` into `out` (the same expression
/// as [`mobility`], with `rg3/η` taken out of the loop for a constant viscosity).
#[inline(always)]
pub(super) fn mobility_rows(c: &FluxCtx, first: usize, out: &mut [f64]) {
    let span = first * c.nx..first * c.nx + out.len();
    match c.viscosity {
        ViscosityModel::Constant(eta) => {
            let k = c.rg3 / eta;
            for ((m, &hh), &f) in out.iter_mut().zip(&c.h[span.clone()]).zip(&c.fac[span]) {
                *m = k * f * hh * hh * hh;
            }
        }
        _ => {
            for (m, k) in out.iter_mut().zip(span) {
                *m = c.mob(k);
            }
        }
    }
}

/// The flux out of edge cell `e` through an open edge (`inner` its neighbour inside; the
/// ghost cell beyond mirrors the ground slope and has the same thickness); zeros at a wall.
#[inline(always)]
fn open_face(c: &FluxCtx, mob: MobRows, edge: Edge, e: usize, inner: usize) -> (f64, f64, f64) {
    if edge != Edge::Open {
        return (0.0, 0.0, 0.0);
    }
    let (g, h) = (c.g, c.h);
    let ghost = 2.0 * g[e] - g[inner];
    let (q, m, w) = face_flux(c.inv_dx, c.yield_rg, (g[e], h[e], mob.at(e)), (ghost, h[e], mob.at(e)));
    (q.max(0.0), m, w)
}

/// The x-face fluxes of cell row `j` into `frow` (`nx + 1`; face `i` west of cell `i`), each
/// face's `(q, mobility, wave speed)` passed through `take`.
#[inline(always)]
pub(super) fn x_row<const YIELD: bool, const MAX: bool>(
    c: &FluxCtx,
    mob: MobRows,
    j: usize,
    frow: &mut [f64],
    take: &mut impl FnMut((f64, f64, f64)) -> f64,
) {
    let nx = c.nx;
    let r = j * nx..(j + 1) * nx;
    let (rg, rh, rm) = (&c.g[r.clone()], &c.h[r], mob.row(j));
    let n = nx - 1;
    let a = (&rg[..n], &rh[..n], &rm[..n]);
    let bb = (&rg[1..], &rh[1..], &rm[1..]);
    let lim = flux_pairs::<YIELD, MAX>(c.inv_dx, c.yield_rg, a, bb, &mut frow[1..nx]);
    take((0.0, lim.0, lim.1));
    let (w, e) = (j * nx, j * nx + nx - 1);
    let cell = |k: usize| (c.g[k], c.h[k], mob.at(k));
    let (q0, qn) = if c.edges.west == Edge::Periodic {
        let q = take(face_flux(c.inv_dx, c.yield_rg, cell(e), cell(w)));
        (q, q)
    } else {
        let qw = take(open_face(c, mob, c.edges.west, w, (w + 1).min(e)));
        let qe = take(open_face(c, mob, c.edges.east, e, if nx > 1 { e - 1 } else { e }));
        (-qw, qe)
    };
    frow[0] = q0;
    frow[nx] = qn;
}

/// The fluxes of y-face row `f` (between cell rows `f − 1` and `f`; 0 is the south edge, `ny`
/// the north edge) into `frow` (`nx`). Periodic edge faces are copied from `wrap` (computed by
/// the caller, which needs the far row).
#[inline(always)]
pub(super) fn y_face<const YIELD: bool, const MAX: bool>(
    c: &FluxCtx,
    mob: MobRows,
    f: usize,
    frow: &mut [f64],
    take: &mut impl FnMut((f64, f64, f64)) -> f64,
    wrap: &[f64],
) {
    let (nx, ny) = (c.nx, c.ny);
    if f > 0 && f < ny {
        let row_of = |j: usize| {
            let r = j * nx..(j + 1) * nx;
            (&c.g[r.clone()], &c.h[r], mob.row(j))
        };
        let lim = flux_pairs::<YIELD, MAX>(c.inv_dx, c.yield_rg, row_of(f - 1), row_of(f), frow);
        take((0.0, lim.0, lim.1));
    } else if c.edges.south == Edge::Periodic {
        frow.copy_from_slice(wrap);
    } else if f == 0 {
        for (i, x) in frow.iter_mut().enumerate() {
            let inner = if ny > 1 { i + nx } else { i };
            *x = -take(open_face(c, mob, c.edges.south, i, inner));
        }
    } else {
        for (i, x) in frow.iter_mut().enumerate() {
            let e = (ny - 1) * nx + i;
            let inner = if ny > 1 { e - nx } else { e };
            *x = take(open_face(c, mob, c.edges.north, e, inner));
        }
    }
}

simd_dispatch! {
    /// Pass 1 for band `b`: mobilities of its rows and the row below (into `mob`, at least
    /// `(rows + 1) × nx`), the x-face fluxes of its rows and the y faces south of its rows (and, for the
    /// last band, the north edge), each row into `row` (`nx + 1`, overwritten: only the maxima
    /// are kept). Periodic south/north edge faces are left to the caller. With `keep`, the
    /// mobilities of the band's rows are also copied there (for pass 2, when they are costly).
    /// Returns the band's largest face mobility and wave speed.
    pub(super) fn band_fluxes(
        c: &FluxCtx,
        b: usize,
        mob: &mut [f64],
        row: &mut [f64],
        keep: Option<&mut [f64]>,
    ) -> (f64, f64) => band_fluxes_rows
}

#[inline(always)]
fn band_fluxes_rows(
    c: &FluxCtx,
    b: usize,
    mob: &mut [f64],
    row: &mut [f64],
    keep: Option<&mut [f64]>,
) -> (f64, f64) {
    if c.yield_rg > 0.0 {
        band_fluxes_impl::<true>(c, b, mob, row, keep)
    } else {
        band_fluxes_impl::<false>(c, b, mob, row, keep)
    }
}

#[inline(always)]
fn band_fluxes_impl<const YIELD: bool>(
    c: &FluxCtx,
    b: usize,
    mob: &mut [f64],
    row: &mut [f64],
    keep: Option<&mut [f64]>,
) -> (f64, f64) {
    let (nx, ny) = (c.nx, c.ny);
    let rows = band_range(b, ny);
    let lo = rows.start.saturating_sub(1);
    let mob = &mut mob[..(rows.end - lo) * nx];
    mobility_rows(c, lo, mob);
    if let Some(keep) = keep {
        keep.copy_from_slice(&mob[(rows.start - lo) * nx..]);
    }
    let mob = MobRows { buf: mob, base: lo, nx, ny };
    let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
    let mut take = |(q, m, w): (f64, f64, f64)| {
        m_max = m_max.max(m);
        c_max = c_max.max(w);
        q
    };
    for j in rows.clone() {
        x_row::<YIELD, true>(c, mob, j, row, &mut take);
    }
    let periodic = c.edges.south == Edge::Periodic;
    for j in rows.clone() {
        if j > 0 || !periodic {
            y_face::<YIELD, true>(c, mob, j, &mut row[..nx], &mut take, &[]);
        }
    }
    if rows.end == ny && !periodic {
        y_face::<YIELD, true>(c, mob, ny, &mut row[..nx], &mut take, &[]);
    }
    (m_max, c_max)
}
