//! Pass 2 of the flow substep ([`super::flow`]), per band: the face fluxes of its rows and
//! the rows on either side, computed again by the same row functions as pass 1
//! ([`super::flow_rows`]) into the band's work buffer (so they stay in the cache instead of
//! being stored to and reloaded from whole-grid flux arrays), then the positivity limiter and
//! the cell update. Branch-free rows, vectorised, with the AVX-512F / AVX2 copies of
//! `bands::simd_dispatch`; the same operations on the same numbers as before the fusion, so
//! the results are bit-identical on any CPU and thread count. The round-off tally is summed in
//! cell order, row by row, only over rows that had a negative thickness.

use super::bands::{BAND_ROWS, band_range, simd_dispatch};
use super::field::Edge;
use super::flow_rows::{FluxCtx, MobRows, mobility_rows, x_row, y_face};

/// Read-only inputs of a cell-update pass.
pub(super) struct UpdateCtx<'a> {
    /// The flux inputs (ground, h, T, mobility factor, edges, constants).
    pub flux: &'a FluxCtx<'a>,
    /// Periodic south/north edge face fluxes (face row 0 = face row ny), else empty.
    pub wrap: &'a [f64],
    /// Cell mobilities kept by pass 1 (when they are costly to compute), else `None`.
    pub mob_grid: Option<&'a [f64]>,
    /// Face length × substep: a face's volume is `q · vol`.
    pub vol: f64,
    pub area: f64,
    pub write_velocity: bool,
}

/// One band's work buffer (at least [`work_len`]) and output rows of a cell-update pass.
pub(super) struct UpdateOut<'a> {
    pub work: &'a mut [f64],
    pub hn: &'a mut [f64],
    pub tn: &'a mut [f64],
    pub u: &'a mut [f64],
    pub v: &'a mut [f64],
}

/// What a band of the cell update returns besides its rows.
pub(super) struct BandTally {
    /// Volume clamped away where a cell went negative, summed in cell order.
    pub rounding: f64,
    /// Per row of the band (when the west or east edge is open): the signed volumes through
    /// the west face (`min(0)`) and the east face (`max(0)`).
    pub west_east: Vec<[f64; 2]>,
    /// Per cell of row 0 (first band, open south edge): volume through the south face, `min(0)`.
    pub south: Vec<f64>,
    /// Per cell of row ny − 1 (last band, open north edge): through the north face, `max(0)`.
    pub north: Vec<f64>,
}

/// Length of the work buffer of a band of `rows` rows: mobilities of `rows + 4` rows, x faces
/// of `rows + 2` rows, up to `2 (rows + 2)` y-face rows, limiters of `rows + 2` rows.
pub(super) fn work_len(nx: usize, rows: usize) -> usize {
    (rows + 4) * nx + (rows + 2) * (nx + 1) + 2 * (rows + 2) * nx + (rows + 2) * nx
}

/// Limiter factors of one cell row into `out` from its x faces `fxr` (`nx + 1`), its south and
/// north face rows and its thickness: a cell's outgoing volume (`vol` = face length ×
/// substep) never exceeds what it holds.
#[inline(always)]
fn limiter_row(
    (vol, area): (f64, f64),
    fxr: &[f64],
    (south, north): (&[f64], &[f64]),
    h: &[f64],
    out: &mut [f64],
) {
    let nx = out.len();
    let (west, east) = (&fxr[..nx], &fxr[1..nx + 1]);
    let (south, north, h) = (&south[..nx], &north[..nx], &h[..nx]);
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

simd_dispatch! {
    /// Pass 2 for band `b`: the face fluxes of its rows and the rows on either side (local row
    /// 0 is the row below, wrapping; the last local row the row above), their limiters, then
    /// the new `h`, `T` (and velocity) of its rows, and its round-off tally and edge outflow.
    pub(super) fn band_update(c: &UpdateCtx, b: usize, out: UpdateOut) -> BandTally => band_update_rows
}

#[inline(always)]
fn band_update_rows(c: &UpdateCtx, b: usize, out: UpdateOut) -> BandTally {
    match (c.flux.yield_rg > 0.0, c.write_velocity) {
        (true, true) => band_update_impl::<true, true>(c, b, out),
        (true, false) => band_update_impl::<true, false>(c, b, out),
        (false, true) => band_update_impl::<false, true>(c, b, out),
        (false, false) => band_update_impl::<false, false>(c, b, out),
    }
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
fn band_update_impl<const YIELD: bool, const VEL: bool>(
    c: &UpdateCtx,
    b: usize,
    out: UpdateOut,
) -> BandTally {
    let f = c.flux;
    let (nx, ny) = (f.nx, f.ny);
    let rows = band_range(b, ny);
    let (start, n) = (rows.start, rows.len());
    let below = if start > 0 { start - 1 } else { ny - 1 };
    let above = if rows.end < ny { rows.end } else { 0 };
    let local = |r: usize| {
        if r == 0 {
            below
        } else if r > n {
            above
        } else {
            start + r - 1
        }
    };
    let nfx = nx + 1;
    let (mob, rest) = out.work.split_at_mut((n + 4) * nx);
    let (fx, rest) = rest.split_at_mut((n + 2) * nfx);
    let (fy, rest) = rest.split_at_mut(2 * (n + 2) * nx);
    let lim = &mut rest[..(n + 2) * nx];
    // Mobilities of rows start − 2 ..= end + 1 (wrapping): every face the limiters need.
    let base = (start + 2 * ny - 2) % ny;
    for (k, mrow) in mob.chunks_mut(nx).enumerate() {
        let j = (base + k) % ny;
        match c.mob_grid {
            Some(m) => mrow.copy_from_slice(&m[j * nx..(j + 1) * nx]),
            None => mobility_rows(f, j, mrow),
        }
    }
    let mob = MobRows { buf: mob, base, nx, ny };
    let mut q_only = |(q, _, _): (f64, f64, f64)| q;
    for (r, frow) in fx.chunks_mut(nfx).enumerate() {
        x_row::<YIELD, false>(f, mob, local(r), frow, &mut q_only);
    }
    // y-face rows: local row r has its south face in row south_of[r] of `fy` and its north
    // face in the next (shared with the next local row unless the rows wrap).
    let mut south_of = [0usize; BAND_ROWS + 2];
    let (mut count, mut last) = (0, usize::MAX);
    for (r, s) in south_of.iter_mut().take(n + 2).enumerate() {
        let j = local(r);
        if j != last {
            y_face::<YIELD, false>(f, mob, j, &mut fy[count * nx..(count + 1) * nx], &mut q_only, c.wrap);
            count += 1;
        }
        *s = count - 1;
        y_face::<YIELD, false>(f, mob, j + 1, &mut fy[count * nx..(count + 1) * nx], &mut q_only, c.wrap);
        (count, last) = (count + 1, j + 1);
    }
    fn row(a: &[f64], nx: usize, j: usize) -> &[f64] {
        &a[j * nx..(j + 1) * nx]
    }
    let faces = |r: usize| (row(fy, nx, south_of[r]), row(fy, nx, south_of[r] + 1));
    let (vol, area) = (c.vol, c.area);
    for (r, lrow) in lim.chunks_mut(nx).enumerate() {
        limiter_row((vol, area), &fx[r * nfx..(r + 1) * nfx], faces(r), row(f.h, nx, local(r)), lrow);
    }
    let lim = &*lim;
    let inv_area = 1.0 / area;
    let (hn_all, tn_all, u_all, v_all) = (out.hn, out.tn, out.u, out.v);
    let mut rounding = 0.0;
    for j in rows.clone() {
        let r = j - start + 1; // local row of j
        let jm = if j > 0 { j - 1 } else { ny - 1 };
        let jp = if j + 1 < ny { j + 1 } else { 0 };
        let (lh, ld, lu) = (row(lim, nx, r), row(lim, nx, r - 1), row(lim, nx, r + 1));
        let fxr = &fx[r * nfx..(r + 1) * nfx];
        let (fs, fnn) = faces(r);
        let (h, t, tm, tp) = (row(f.h, nx, j), row(f.t, nx, j), row(f.t, nx, jm), row(f.t, nx, jp));
        let l = (j - start) * nx..(j - start + 1) * nx;
        let (hn, tn) = (&mut hn_all[l.clone()], &mut tn_all[l.clone()]);
        let (u, v) = (&mut u_all[l.clone()], &mut v_all[l]);
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
    // Volumes through open edges (the same expressions as a cell-by-cell loop over the edges).
    let e = f.edges;
    let mut west_east = Vec::new();
    if e.west == Edge::Open || e.east == Edge::Open {
        for r in 1..=n {
            let (q, l) = (&fx[r * nfx..(r + 1) * nfx], row(lim, nx, r));
            west_east.push([(q[0] * vol * l[0]).min(0.0), (q[nx] * vol * l[nx - 1]).max(0.0)]);
        }
    }
    let edge_row = |q: &[f64], r: usize, north: bool| -> Vec<f64> {
        let l = row(lim, nx, r);
        q.iter()
            .zip(l)
            .map(|(&q, &l)| if north { (q * vol * l).max(0.0) } else { (q * vol * l).min(0.0) })
            .collect()
    };
    let south = if start == 0 && e.south == Edge::Open { edge_row(faces(1).0, 1, false) } else { Vec::new() };
    let north =
        if rows.end == ny && e.north == Edge::Open { edge_row(faces(n).1, n, true) } else { Vec::new() };
    BandTally { rounding, west_east, south, north }
}
