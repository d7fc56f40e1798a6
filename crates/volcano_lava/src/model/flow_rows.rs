//! The row loops of the flow substep ([`super::flow`]): per band, the cell mobilities and face
//! fluxes (pass 1), then the limiter and the cell update (pass 2).
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
/// the same length as `out`), into `out`; returns the largest face mobility and wave speed.
#[inline(always)]
fn flux_pairs<const YIELD: bool>(
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
        m_max = m_max.max(key(m));
        c_max = c_max.max(key(w));
    }
    (f64::from_bits(m_max as u64), f64::from_bits(c_max as u64))
}

simd_dispatch! {
    /// Pass 1 for band `b`: mobilities of its rows and the row below (into `mob`), x-face
    /// fluxes of its rows (`fx`, rows of `nx + 1`), the y faces south of its rows (`fy`, face
    /// row `start` first; face row 0 is the south edge) and, for the last band, the north edge
    /// faces (`north`). Returns the band's largest face mobility and wave speed.
    pub(super) fn band_fluxes(
        c: &FluxCtx,
        b: usize,
        mob: &mut [f64],
        fx: &mut [f64],
        fy: &mut [f64],
        north: Option<&mut [f64]>,
    ) -> (f64, f64) => band_fluxes_rows
}

#[inline(always)]
fn band_fluxes_rows(
    c: &FluxCtx,
    b: usize,
    mob: &mut [f64],
    fx: &mut [f64],
    fy: &mut [f64],
    north: Option<&mut [f64]>,
) -> (f64, f64) {
    if c.yield_rg > 0.0 {
        band_fluxes_impl::<true>(c, b, mob, fx, fy, north)
    } else {
        band_fluxes_impl::<false>(c, b, mob, fx, fy, north)
    }
}

#[inline(always)]
fn band_fluxes_impl<const YIELD: bool>(
    c: &FluxCtx,
    b: usize,
    mob: &mut [f64],
    fx: &mut [f64],
    fy: &mut [f64],
    north: Option<&mut [f64]>,
) -> (f64, f64) {
    let (nx, ny, g, h) = (c.nx, c.ny, c.g, c.h);
    let rows = band_range(b, ny);
    let lo = rows.start.saturating_sub(1);
    let span = lo * nx..rows.end * nx;
    match c.viscosity {
        // The same expression as `mobility`, with `rg3/η` taken out of the loop.
        ViscosityModel::Constant(eta) => {
            let k = c.rg3 / eta;
            for ((m, &hh), &f) in mob.iter_mut().zip(&h[span.clone()]).zip(&c.fac[span]) {
                *m = k * f * hh * hh * hh;
            }
        }
        _ => {
            for (m, k) in mob.iter_mut().zip(span) {
                *m = c.mob(k);
            }
        }
    }
    let mob = &*mob;
    let row_of = |j: usize| {
        let (r, l) = (j * nx..(j + 1) * nx, (j - lo) * nx..(j - lo + 1) * nx);
        (&g[r.clone()], &h[r], &mob[l])
    };
    let cell = |k: usize| (g[k], h[k], mob[k - lo * nx]);
    let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
    let mut take = |(q, m, w): (f64, f64, f64)| {
        m_max = m_max.max(m);
        c_max = c_max.max(w);
        q
    };
    let nfx = nx + 1;
    let open = |edge: Edge, e: usize, inner: usize| {
        if edge != Edge::Open {
            return (0.0, 0.0, 0.0);
        }
        let ghost = 2.0 * g[e] - g[inner];
        let (q, m, w) = face_flux(c.inv_dx, c.yield_rg, cell(e), (ghost, h[e], mob[e - lo * nx]));
        (q.max(0.0), m, w)
    };
    for (frow, j) in fx.chunks_mut(nfx).zip(rows.clone()) {
        let (rg, rh, rm) = row_of(j);
        let n = nx - 1;
        let a = (&rg[..n], &rh[..n], &rm[..n]);
        let bb = (&rg[1..], &rh[1..], &rm[1..]);
        let lim = flux_pairs::<YIELD>(c.inv_dx, c.yield_rg, a, bb, &mut frow[1..nx]);
        take((0.0, lim.0, lim.1));
        let row = j * nx;
        let (w, e) = (row, row + nx - 1);
        let (q0, qn) = if c.edges.west == Edge::Periodic {
            let q = take(face_flux(c.inv_dx, c.yield_rg, cell(e), cell(w)));
            (q, q)
        } else {
            let qw = take(open(c.edges.west, w, (w + 1).min(e)));
            let qe = take(open(c.edges.east, e, if nx > 1 { e - 1 } else { e }));
            (-qw, qe)
        };
        frow[0] = q0;
        frow[nx] = qn;
    }
    // Face row j (≥ 1) lies between cell rows j−1 and j.
    for (frow, j) in fy.chunks_mut(nx).zip(rows.clone()) {
        if j == 0 {
            continue; // the south edge, below
        }
        let lim = flux_pairs::<YIELD>(c.inv_dx, c.yield_rg, row_of(j - 1), row_of(j), frow);
        take((0.0, lim.0, lim.1));
    }
    // Open or wall edges south and north (periodic ones are done by the caller: they need
    // the far row).
    if c.edges.south != Edge::Periodic {
        if rows.start == 0 {
            for (i, f) in fy.iter_mut().take(nx).enumerate() {
                let inner = if ny > 1 { i + nx } else { i };
                *f = -take(open(c.edges.south, i, inner));
            }
        }
        if let Some(north) = north {
            for (i, f) in north.iter_mut().enumerate() {
                let e = (ny - 1) * nx + i;
                let inner = if ny > 1 { e - nx } else { e };
                *f = take(open(c.edges.north, e, inner));
            }
        }
    }
    (m_max, c_max)
}

/// Read-only inputs of a cell-update pass.
pub(super) struct UpdateCtx<'a> {
    pub nx: usize,
    pub ny: usize,
    pub edges: Edges,
    pub fx: &'a [f64],
    pub fy: &'a [f64],
    pub h: &'a [f64],
    pub t: &'a [f64],
    /// Face length × substep: a face's volume is `q · vol`.
    pub vol: f64,
    pub area: f64,
    pub write_velocity: bool,
}

/// One band's limiter buffer (its rows and one each side, `(rows + 2) × nx`) and output rows
/// of a cell-update pass.
pub(super) struct UpdateOut<'a> {
    pub lim: &'a mut [f64],
    pub hn: &'a mut [f64],
    pub tn: &'a mut [f64],
    pub u: &'a mut [f64],
    pub v: &'a mut [f64],
}

/// Limiter factors of cell row `j` into `out`: a cell's outgoing volume (`vol` = face length
/// × substep) never exceeds what it holds.
#[inline(always)]
fn limiter_row(c: &UpdateCtx, j: usize, out: &mut [f64]) {
    let (nx, vol, area) = (c.nx, c.vol, c.area);
    let fxr = &c.fx[j * (nx + 1)..(j + 1) * (nx + 1)];
    let (west, east) = (&fxr[..nx], &fxr[1..nx + 1]);
    let (south, north) = (&c.fy[j * nx..(j + 1) * nx], &c.fy[(j + 1) * nx..(j + 2) * nx]);
    let (h, out) = (&c.h[j * nx..(j + 1) * nx], &mut out[..nx]);
    for i in 0..nx {
        let (w, e, so, no) = (west[i], east[i], south[i], north[i]);
        let o = (e.max(0.0) - w.min(0.0) + no.max(0.0) - so.min(0.0)) * vol;
        let avail = h[i] * area;
        out[i] = if o > avail { avail / o } else { 1.0 };
    }
}

/// The new state of one cell from its four raw face fluxes (west, east, south, north; +x / +y
/// positive) and the limiter factors and temperatures of the cell and its four neighbours (in
/// the same order after the cell's own): the signed face volumes, each scaled by its donor's
/// factor, give `(h' before the clamp, T', v_w, v_e, v_s, v_n)`. `T'` uses the clamped `h'`.
#[inline(always)]
fn cell_update(
    (vol, inv_area): (f64, f64),
    [qw, qe, qs, qn]: [f64; 4],
    [lk, lw, le, ls, ln]: [f64; 5],
    hk0: f64,
    [tk, tw, te, ts, tn]: [f64; 5],
) -> (f64, f64, [f64; 4]) {
    let (qw, qe, qs, qn) = (qw * vol, qe * vol, qs * vol, qn * vol);
    let vw = qw * if qw > 0.0 { lw } else { lk };
    let ve = qe * if qe > 0.0 { lk } else { le };
    let vs = qs * if qs > 0.0 { ls } else { lk };
    let vn = qn * if qn > 0.0 { lk } else { ln };
    let vin = vw.max(0.0) - ve.min(0.0) + vs.max(0.0) - vn.min(0.0);
    let vout = ve.max(0.0) - vw.min(0.0) + vn.max(0.0) - vs.min(0.0);
    let ein = vw.max(0.0) * tw - ve.min(0.0) * te + vs.max(0.0) * ts - vn.min(0.0) * tn;
    let raw = hk0 + (vin - vout) * inv_area;
    let hk = if raw < 0.0 { 0.0 } else { raw };
    let remain = (hk0 - vout * inv_area).max(0.0);
    let t_new = if hk > 0.0 { (remain * tk + ein * inv_area) / hk } else { tk };
    (raw, t_new, [vw, ve, vs, vn])
}

/// What a band of the cell update returns besides its rows.
pub(super) struct BandTally {
    /// Volume clamped away where a cell went negative, summed in cell order.
    pub rounding: f64,
    /// Per row of the band (when the west or east edge is open): the volumes through the west
    /// face (`min(0)`) and the east face (`max(0)`).
    pub west_east: Vec<[f64; 2]>,
    /// Per cell of row 0 (first band, open south edge): through the south face, `min(0)`.
    pub south: Vec<f64>,
    /// Per cell of row ny − 1 (last band, open north edge): through the north face, `max(0)`.
    pub north: Vec<f64>,
}

simd_dispatch! {
    /// Pass 2 for band `b`: the limiter of its rows and the rows on either side (local row 0
    /// is the row below, wrapping; the last local row the row above), then the new `h`, `T`
    /// (and velocity) of its rows. Returns the band's round-off tally (volume clamped away
    /// where a cell went negative, summed in cell order) and the volumes through open edges
    /// of its rows (the limiter buffer is the thread's, not kept after the band).
    pub(super) fn band_update(c: &UpdateCtx, b: usize, out: UpdateOut) -> BandTally => band_update_rows
}

#[inline(always)]
fn band_update_rows(c: &UpdateCtx, b: usize, out: UpdateOut) -> BandTally {
    if c.write_velocity { band_update_impl::<true>(c, b, out) } else { band_update_impl::<false>(c, b, out) }
}

/// Stores cell `i`'s update into the output rows; true if its thickness went negative.
#[inline(always)]
fn store<const VEL: bool>(
    i: usize,
    (raw, t_new, [vw, ve, vs, vn]): (f64, f64, [f64; 4]),
    vol: f64,
    (hn, tn, u, v): (&mut [f64], &mut [f64], &mut [f64], &mut [f64]),
) -> bool {
    let hk = if raw < 0.0 { 0.0 } else { raw };
    hn[i] = hk;
    tn[i] = t_new;
    if VEL {
        let ok = hk > 0.0;
        u[i] = if ok { 0.5 * (vw + ve) / (vol * hk) } else { 0.0 };
        v[i] = if ok { 0.5 * (vs + vn) / (vol * hk) } else { 0.0 };
    }
    raw < 0.0
}

#[inline(always)]
fn band_update_impl<const VEL: bool>(c: &UpdateCtx, b: usize, out: UpdateOut) -> BandTally {
    let (nx, ny) = (c.nx, c.ny);
    let rows = band_range(b, ny);
    let (start, n) = (rows.start, rows.len());
    let below = if start > 0 { start - 1 } else { ny - 1 };
    let above = if rows.end < ny { rows.end } else { 0 };
    for (r, lrow) in out.lim.chunks_mut(nx).enumerate() {
        let j = if r == 0 {
            below
        } else if r > n {
            above
        } else {
            start + r - 1
        };
        limiter_row(c, j, lrow);
    }
    let lim = &*out.lim;
    let nfx = nx + 1;
    let (vol, inv_area) = (c.vol, 1.0 / c.area);
    fn row(a: &[f64], nx: usize, j: usize) -> &[f64] {
        &a[j * nx..(j + 1) * nx]
    }
    let mut rounding = 0.0;
    for j in rows {
        let r = j - start + 1; // local row of j
        let jm = if j > 0 { j - 1 } else { ny - 1 };
        let jp = if j + 1 < ny { j + 1 } else { 0 };
        let (lh, ld, lu) = (row(lim, nx, r), row(lim, nx, r - 1), row(lim, nx, r + 1));
        let fxr = &c.fx[j * nfx..(j + 1) * nfx];
        let (fs, fnn) = (row(c.fy, nx, j), row(c.fy, nx, j + 1));
        let (h, t, tm, tp) = (row(c.h, nx, j), row(c.t, nx, j), row(c.t, nx, jm), row(c.t, nx, jp));
        let l = (j - start) * nx..(j - start + 1) * nx;
        let (hn, tn) = (&mut out.hn[l.clone()], &mut out.tn[l.clone()]);
        let (u, v) = (&mut out.u[l.clone()], &mut out.v[l]);
        // Cell i of the row with its west and east neighbours iw, ie (wrapping at the ends).
        let at = |i: usize, iw: usize, ie: usize| {
            cell_update(
                (vol, inv_area),
                [fxr[i], fxr[i + 1], fs[i], fnn[i]],
                [lh[i], lh[iw], lh[ie], ld[i], lu[i]],
                h[i],
                [t[i], t[iw], t[ie], tm[i], tp[i]],
            )
        };
        let mut neg = store::<VEL>(0, at(0, nx - 1, if nx > 1 { 1 } else { 0 }), vol, (hn, tn, u, v));
        if nx > 1 {
            // The interior cells, whose neighbours are i − 1 and i + 1 (vectorisable).
            let m = nx - 2;
            let (fw, fe, fsm, fnm) = (&fxr[1..m + 1], &fxr[2..m + 2], &fs[1..m + 1], &fnn[1..m + 1]);
            let (lw, lc, le, ldm, lum) =
                (&lh[..m], &lh[1..m + 1], &lh[2..m + 2], &ld[1..m + 1], &lu[1..m + 1]);
            let (hm, tw, tc, te, tsm, tnm) =
                (&h[1..m + 1], &t[..m], &t[1..m + 1], &t[2..m + 2], &tm[1..m + 1], &tp[1..m + 1]);
            let outs = (&mut hn[1..m + 1], &mut tn[1..m + 1], &mut u[1..m + 1], &mut v[1..m + 1]);
            let (hno, tno, uo, vo) = (&mut outs.0[..m], &mut outs.1[..m], &mut outs.2[..m], &mut outs.3[..m]);
            let mut neg_in = false;
            for i in 0..m {
                let res = cell_update(
                    (vol, inv_area),
                    [fw[i], fe[i], fsm[i], fnm[i]],
                    [lc[i], lw[i], le[i], ldm[i], lum[i]],
                    hm[i],
                    [tc[i], tw[i], te[i], tsm[i], tnm[i]],
                );
                neg_in |= store::<VEL>(i, res, vol, (&mut *hno, &mut *tno, &mut *uo, &mut *vo));
            }
            neg |= neg_in;
            neg |= store::<VEL>(nx - 1, at(nx - 1, nx - 2, 0), vol, (hn, tn, u, v));
        }
        if neg {
            // The tally in cell order, as a cell-by-cell loop adds it.
            for i in 0..nx {
                let (iw, ie) = (if i > 0 { i - 1 } else { nx - 1 }, if i + 1 < nx { i + 1 } else { 0 });
                let raw = at(i, iw, ie).0;
                if raw < 0.0 {
                    rounding -= raw * c.area;
                }
            }
        }
    }
    // Volumes through open edges (the expressions of a cell-by-cell loop over the edges).
    let e = c.edges;
    let mut west_east = Vec::new();
    if e.west == Edge::Open || e.east == Edge::Open {
        for j in band_range(b, ny) {
            let (q, l) = (&c.fx[j * nfx..(j + 1) * nfx], row(lim, nx, j - start + 1));
            west_east.push([(q[0] * vol * l[0]).min(0.0), (q[nx] * vol * l[nx - 1]).max(0.0)]);
        }
    }
    let edge_row = |f: usize, r: usize, north: bool| -> Vec<f64> {
        let q = row(c.fy, nx, f).iter().zip(row(lim, nx, r));
        q.map(|(&q, &l)| if north { (q * vol * l).max(0.0) } else { (q * vol * l).min(0.0) }).collect()
    };
    let south = if start == 0 && e.south == Edge::Open { edge_row(0, 1, false) } else { Vec::new() };
    let north = if start + n == ny && e.north == Edge::Open { edge_row(ny, n, true) } else { Vec::new() };
    BandTally { rounding, west_east, south, north }
}
