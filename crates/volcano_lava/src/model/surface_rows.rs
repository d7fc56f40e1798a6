//! The row loops of the crust update ([`super::surface::update_surface`]): step 1, the surface
//! velocity smoothed by the crust, and steps 2–5, divergence, upwind advection, radiation,
//! eq 5.3 and thresholds. Branch-free over whole rows so the compiler can vectorise them, with
//! AVX-512 and AVX2 copies chosen at run time (see [`super::flow_rows`] for why the copies
//! give bit-identical results).
//!
//! Every cell evaluates the whole update and selects the outcome. The loop leaves out what
//! only rare cells need and flags those cells, which are redone one by one with the scalar
//! rule after the row, so every cell gets exactly the value of the scalar rule: the
//! divergence factor `exp(−∇·v dt)` is the Taylor polynomial of [`exp_small`] (flagged:
//! `|∇·v dt| ≥ 10⁻²`, where [`exp_small`] calls `f64::exp`); the upwind weights assume a
//! Courant sum ≤ 1 (flagged: larger, where they are divided by it); and the reset rule's test
//! `h_c < ratio × 2√(κt)` is decided without its square root, as `h_c² > 4 ratio² κ t`
//! with a 10⁻¹² relative margin (far more than the round-off of either side), so only cells
//! that may reset (flagged: they need the division of `t = h_c²/(4κ)`) or lie within the
//! margin are redone. The divider (square roots and divisions) would be the loop's
//! bottleneck.

use std::ops::Range;

use super::bands::simd_dispatch;

use super::crust::{
    DIVERGENCE_MIN_CRUST, MOVING_SPEED, NO_CRUST_BELOW, SURFACE_TO_MEAN, contact_from_crust,
    crust_from_contact, exp_small, exp_taylor,
};

/// Row `r` of a row-major grid of rows of `nx`.
#[inline(always)]
fn row(a: &[f64], nx: usize, r: usize) -> &[f64] {
    &a[r * nx..(r + 1) * nx]
}

/// Read-only inputs of the crust pass (row-major grids of `nx × ny`).
pub(super) struct CrustCtx<'a> {
    pub nx: usize,
    pub ny: usize,
    pub h: &'a [f64],
    pub vx: &'a [f64],
    pub vy: &'a [f64],
    pub crust: &'a [f64],
    pub contact: &'a [f64],
    pub min_h: f64,
    pub inv_dx: f64,
    pub dt: f64,
    pub kappa: f64,
    pub four_kdt: f64,
    pub reset_ratio: f64,
    /// `4 ratio² κ`: `h_c² > four_r2_kappa · t` (with a margin) means no reset.
    pub four_r2_kappa: f64,
}

/// Relative margin of the reset rule's test without its square root (see the module doc): the
/// two sides' round-off is below 10⁻¹⁵.
const RESET_MARGIN: f64 = 1.0 + 1e-12;

/// One cell's neighbourhood: this cell, then west, east, south, north (a missing neighbour at
/// the grid edge is the cell itself).
type Five = [f64; 5];

/// The update of one cell (steps 2–5 of `update_surface`): `(crust, contact, divergence,
/// redo)`. With `EXACT` it is the scalar rule (`redo` false). Without, the rare branches are
/// left out (see the module doc) and `redo` says this cell took one of them, so its values
/// are wrong and it must be recomputed with `EXACT`; the other cells get the same bits.
#[inline(always)]
fn crust_cell<const EXACT: bool>(
    c: &CrustCtx,
    (h, vx, vy, crust, contact): (Five, Five, Five, Five, Five),
    (span_x, span_y): (f64, f64),
) -> (f64, f64, f64, bool) {
    let (dt, inv_dx, min_h) = (c.dt, c.inv_dx, c.min_h);
    let hk = h[0];
    let speed2 = vx[0] * vx[0] + vy[0] * vy[0];
    let none = hk < min_h || (hk < NO_CRUST_BELOW && speed2 > MOVING_SPEED * MOVING_SPEED);
    // Divergence by central differences; a dry neighbour counts as this cell.
    let pick = |n: usize, a: &Five| if h[n] >= min_h { a[n] } else { a[0] };
    let ddx = (pick(2, &vx) - pick(1, &vx)) * inv_dx * span_x;
    let ddy = (pick(4, &vy) - pick(3, &vy)) * inv_dx * span_y;
    let div = ddx + ddy;
    // Upwind advection of crust and contact time (dry upwind cells carry none).
    let cx = (vx[0] * dt * inv_dx).clamp(-1.0, 1.0);
    let cy = (vy[0] * dt * inv_dx).clamp(-1.0, 1.0);
    let (ux, uy) = (if cx > 0.0 { 1 } else { 2 }, if cy > 0.0 { 3 } else { 4 });
    let (ax, ay) = (cx.abs(), cy.abs());
    let courant_ok = ax + ay <= 1.0;
    let (keep, ax, ay) = if EXACT && !courant_ok {
        let inv = 1.0 / (ax + ay);
        (0.0, ax * inv, ay * inv)
    } else {
        (1.0 - ax - ay, ax, ay)
    };
    let c0 = keep * crust[0] + ax * crust[ux] + ay * crust[uy];
    let t0 = keep * contact[0] + ax * contact[ux] + ay * contact[uy];
    // Radiation (eq 5.1, incremental) and divergence (eq 5.3).
    let mut t_c = t0 + dt;
    let mut cr = (c0 * c0 + c.four_kdt).sqrt();
    let x = -div * dt;
    let stretch = cr > DIVERGENCE_MIN_CRUST && div != 0.0;
    if EXACT {
        if stretch {
            cr *= exp_small(x);
            if div > 0.0 && cr < c.reset_ratio * crust_from_contact(c.kappa, t_c) {
                t_c = contact_from_crust(c.kappa, cr);
            }
        }
        return if none { (0.0, 0.0, 0.0, false) } else { (cr.min(hk), t_c, div, false) };
    }
    let in_taylor_range = x.abs() < 1e-2; // false for NaN, as in `exp_small`
    let stretched = cr * exp_taylor(x);
    // No reset for sure (false for NaN): see the module doc.
    let no_reset = stretched * stretched > c.four_r2_kappa * t_c * RESET_MARGIN;
    let redo = !none && (!courant_ok || (stretch && (!in_taylor_range || (div > 0.0 && !no_reset))));
    let cr = if stretch { stretched } else { cr };
    if none { (0.0, 0.0, 0.0, false) } else { (cr.min(hk), t_c, div, redo) }
}

simd_dispatch! {
    /// Steps 2–5 for the rows `rows` of a band, into the band's `new_c`, `new_t`, `divergence`
    /// (which start at row `rows.start`).
    pub(super) fn crust_rows(
        c: &CrustCtx,
        rows: Range<usize>,
        out: (&mut [f64], &mut [f64], &mut [f64]),
    ) => crust_rows_impl
}

#[inline(always)]
fn crust_rows_impl(c: &CrustCtx, rows: Range<usize>, out: (&mut [f64], &mut [f64], &mut [f64])) {
    let (nx, ny) = (c.nx, c.ny);
    let o = rows.start;
    let (new_c, new_t, divergence) = out;
    // Per cell of the row: 1 if the cell must be redone with the scalar rule.
    let mut flags = vec![0u8; nx];
    for j in rows {
        let (jm, jp) = (j.saturating_sub(1), (j + 1).min(ny - 1));
        // One-sided (span 1) at the grid edges, central (span 2) inside: × 1/span.
        let span_y = if jp - jm == 2 { 0.5 } else { 1.0 };
        let grids = [c.h, c.vx, c.vy, c.crust, c.contact];
        let here = grids.map(|a| row(a, nx, j));
        let south = grids.map(|a| row(a, nx, jm));
        let north = grids.map(|a| row(a, nx, jp));
        let l = (j - o) * nx..(j - o + 1) * nx;
        let (oc, ot, od) = (&mut new_c[l.clone()], &mut new_t[l.clone()], &mut divergence[l]);
        // Cell i with west and east neighbours iw, ie (the cell itself at the edges).
        let at = |i: usize, iw: usize, ie: usize, exact: bool| {
            let five = |q: usize| [here[q][i], here[q][iw], here[q][ie], south[q][i], north[q][i]];
            let span_x = if ie - iw == 2 { 0.5 } else { 1.0 };
            let cells = (five(0), five(1), five(2), five(3), five(4));
            if exact {
                crust_cell::<true>(c, cells, (span_x, span_y))
            } else {
                crust_cell::<false>(c, cells, (span_x, span_y))
            }
        };
        let mut redo = false;
        let mut put = |i: usize, (cr, t, d, r): (f64, f64, f64, bool)| {
            oc[i] = cr;
            ot[i] = t;
            od[i] = d;
            flags[i] = r as u8;
            redo |= r;
        };
        put(0, at(0, 0, 1.min(nx - 1), false));
        if nx > 1 {
            put(nx - 1, at(nx - 1, nx - 2, nx - 1, false));
        }
        if nx > 2 {
            // The interior cells, whose neighbours are i − 1 and i + 1 (vectorisable).
            let m = nx - 2;
            let w = here.map(|a| &a[..m]);
            let e = here.map(|a| &a[2..m + 2]);
            let cc = here.map(|a| &a[1..m + 1]);
            let s = south.map(|a| &a[1..m + 1]);
            let n = north.map(|a| &a[1..m + 1]);
            let (ocm, otm, odm) = (&mut oc[1..m + 1], &mut ot[1..m + 1], &mut od[1..m + 1]);
            let fm = &mut flags[1..m + 1];
            let mut redo_in = false;
            for i in 0..m {
                let five = |q: usize| [cc[q][i], w[q][i], e[q][i], s[q][i], n[q][i]];
                let (cr, t, d, r) =
                    crust_cell::<false>(c, (five(0), five(1), five(2), five(3), five(4)), (0.5, span_y));
                ocm[i] = cr;
                otm[i] = t;
                odm[i] = d;
                fm[i] = r as u8;
                redo_in |= r;
            }
            redo |= redo_in;
        }
        if redo {
            for i in 0..nx {
                if flags[i] != 0 {
                    let (iw, ie) = (i.saturating_sub(1), (i + 1).min(nx - 1));
                    let (cr, t, d, _) = at(i, iw, ie, true);
                    oc[i] = cr;
                    ot[i] = t;
                    od[i] = d;
                }
            }
        }
    }
}

/// Read-only inputs of the surface-velocity pass (step 1 of `update_surface`).
pub(super) struct VelocityCtx<'a> {
    pub nx: usize,
    pub ny: usize,
    pub h: &'a [f64],
    pub u: &'a [f64],
    pub v: &'a [f64],
    pub crust: &'a [f64],
    pub min_h: f64,
    pub inv_rigid: f64,
}

simd_dispatch! {
    /// Step 1 for the rows `rows` of a band, into the band's `vsx`, `vsy` (which start at row
    /// `rows.start`); `hsum` is the band's scratch for the horizontal 3-sums of `(u, v, 1)`
    /// over wet cells (one plane each) of its rows and the rows above and below.
    pub(super) fn velocity_rows(
        c: &VelocityCtx,
        rows: Range<usize>,
        hsum: &mut [Vec<f64>; 3],
        out: (&mut [f64], &mut [f64]),
    ) => velocity_rows_impl
}

/// `x` where `keep`, else `+0.0`: a select written as a bit mask, so the compiler keeps
/// plain loads and stores instead of masked ones (slow on some CPUs).
#[inline(always)]
fn keep_or_zero(keep: bool, x: f64) -> f64 {
    f64::from_bits(x.to_bits() & (keep as u64).wrapping_neg())
}

/// `(u, v, 1)` of a wet cell, zeros for a dry one.
#[inline(always)]
fn wet(h: f64, u: f64, v: f64, min_h: f64) -> [f64; 3] {
    let w = h >= min_h;
    [keep_or_zero(w, u), keep_or_zero(w, v), keep_or_zero(w, 1.0)]
}

#[inline(always)]
fn velocity_rows_impl(
    c: &VelocityCtx,
    rows: Range<usize>,
    hsum: &mut [Vec<f64>; 3],
    out: (&mut [f64], &mut [f64]),
) {
    let (nx, ny, min_h) = (c.nx, c.ny, c.min_h);
    // Horizontal 3-sums `(left + here) + right` (zero beyond the row ends), then vertical
    // 3-sums: the 3×3 wet mean without 9 branchy reads.
    let (r0, r1) = (rows.start.saturating_sub(1), (rows.end + 1).min(ny));
    for p in hsum.iter_mut() {
        p.resize((r1 - r0) * nx, 0.0);
    }
    for j in r0..r1 {
        let (h, u, v) = (row(c.h, nx, j), row(c.u, nx, j), row(c.v, nx, j));
        let l = (j - r0) * nx..(j - r0 + 1) * nx;
        let [su, sv, sn] = hsum;
        let (su, sv, sn) = (&mut su[l.clone()], &mut sv[l.clone()], &mut sn[l]);
        let at = |i: usize| wet(h[i], u[i], v[i], min_h);
        let mut put = |i: usize, [a, b, d]: [f64; 3], [e, f, g]: [f64; 3], [x, y, z]: [f64; 3]| {
            su[i] = a + e + x;
            sv[i] = b + f + y;
            sn[i] = d + g + z;
        };
        put(0, [0.0; 3], at(0), if nx > 1 { at(1) } else { [0.0; 3] });
        if nx > 1 {
            put(nx - 1, at(nx - 2), at(nx - 1), [0.0; 3]);
        }
        if nx > 2 {
            let m = nx - 2;
            let (hw, hc, he) = (&h[..m], &h[1..m + 1], &h[2..m + 2]);
            let (uw, uc, ue) = (&u[..m], &u[1..m + 1], &u[2..m + 2]);
            let (vw, vc, ve) = (&v[..m], &v[1..m + 1], &v[2..m + 2]);
            let (su, sv, sn) = (&mut su[1..m + 1], &mut sv[1..m + 1], &mut sn[1..m + 1]);
            for i in 0..m {
                let [a, b, d] = wet(hw[i], uw[i], vw[i], min_h);
                let [e, f, g] = wet(hc[i], uc[i], vc[i], min_h);
                let [x, y, z] = wet(he[i], ue[i], ve[i], min_h);
                su[i] = a + e + x;
                sv[i] = b + f + y;
                sn[i] = d + g + z;
            }
        }
    }
    let o = rows.start;
    let (vsx, vsy) = out;
    for j in rows {
        let l = (j - o) * nx..(j - o + 1) * nx;
        let (ox, oy) = (&mut vsx[l.clone()], &mut vsy[l]);
        let plane = |p: usize, r: usize| row(&hsum[p], nx, r - r0);
        let rows3 = |r: usize| [plane(0, r), plane(1, r), plane(2, r)];
        let (down, up) = ((j > 0).then(|| rows3(j - 1)), (j + 1 < ny).then(|| rows3(j + 1)));
        let cells = (row(c.h, nx, j), row(c.u, nx, j), row(c.v, nx, j), row(c.crust, nx, j));
        let here = rows3(j);
        match (down, up) {
            (Some(d), Some(u)) => smooth_row::<true, true>(c, cells, [d, here, u], (ox, oy)),
            (Some(d), None) => smooth_row::<true, false>(c, cells, [d, here, here], (ox, oy)),
            (None, Some(u)) => smooth_row::<false, true>(c, cells, [here, here, u], (ox, oy)),
            (None, None) => smooth_row::<false, false>(c, cells, [here, here, here], (ox, oy)),
        }
    }
}

/// One row of surface velocities: `3/2 ×` the depth-averaged velocity blended toward the wet
/// 3×3 mean (`sums` = horizontal sums of the rows below, here and above; the row below or
/// above only if `DOWN` / `UP`, summed from zero in that order).
#[inline(always)]
fn smooth_row<const DOWN: bool, const UP: bool>(
    c: &VelocityCtx,
    (h, u, v, crust): (&[f64], &[f64], &[f64], &[f64]),
    sums: [[&[f64]; 3]; 3],
    (ox, oy): (&mut [f64], &mut [f64]),
) {
    let n = c.nx;
    let (h, u, v, crust, ox, oy) = (&h[..n], &u[..n], &v[..n], &crust[..n], &mut ox[..n], &mut oy[..n]);
    let [d, m, p] = sums.map(|r| r.map(|a| &a[..n]));
    for i in 0..n {
        let (rx, ry) = (SURFACE_TO_MEAN * u[i], SURFACE_TO_MEAN * v[i]);
        let w = (crust[i] * c.inv_rigid).min(1.0);
        let (mut mx, mut my, mut cnt) = (0.0, 0.0, 0.0);
        if DOWN {
            mx += d[0][i];
            my += d[1][i];
            cnt += d[2][i];
        }
        mx += m[0][i];
        my += m[1][i];
        cnt += m[2][i];
        if UP {
            mx += p[0][i];
            my += p[1][i];
            cnt += p[2][i];
        }
        let f = SURFACE_TO_MEAN / cnt;
        let (sx, sy) = ((1.0 - w) * rx + w * mx * f, (1.0 - w) * ry + w * my * f);
        let (dry, free) = (h[i] < c.min_h, w == 0.0);
        ox[i] = keep_or_zero(!dry, f64::from_bits(if free { rx.to_bits() } else { sx.to_bits() }));
        oy[i] = keep_or_zero(!dry, f64::from_bits(if free { ry.to_bits() } else { sy.to_bits() }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vectorised loop's cell update gives the scalar rule's bits wherever it does not
    /// flag the cell, over random neighbourhoods that take every left-out branch (Courant sums
    /// above 1, large divergence, resets and crust at the reset threshold within round-off).
    #[test]
    fn unflagged_cells_match_the_scalar_rule() {
        let (kappa, dt, ratio) = (8e-7, 0.02, 0.9);
        let c = CrustCtx {
            nx: 0,
            ny: 0,
            h: &[],
            vx: &[],
            vy: &[],
            crust: &[],
            contact: &[],
            min_h: 0.01,
            inv_dx: 2.0,
            dt,
            kappa,
            four_kdt: 4.0 * kappa * dt,
            reset_ratio: ratio,
            four_r2_kappa: 4.0 * ratio * ratio * kappa,
        };
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut unit = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut flagged, mut resets, mut total) = (0, 0, 0);
        for n in 0..300_000 {
            let scale = [0.01, 0.2, 5.0, 60.0][n % 4]; // speeds (m/s): Courant up to 2.4
            let mut five = |lo: f64, hi: f64| [(); 5].map(|_| lo + (hi - lo) * unit());
            let h = five(-0.1, 1.2);
            let (vx, vy) = (five(-scale, scale), five(-scale, scale));
            let contact = five(0.0, 2000.0);
            // Crust at a random fraction of 2√(κt) around the reset ratio, sometimes exactly
            // at the threshold of the advected contact time.
            let mut crust = contact.map(|t| crust_from_contact(kappa, t) * (0.8 + 0.3 * unit()));
            if n % 7 == 0 {
                crust = contact.map(|t| ratio * crust_from_contact(kappa, t + dt));
            }
            let cells = (h, vx, vy, crust, contact);
            let span = ([1.0, 0.5][n % 2], 0.5);
            let fast = crust_cell::<false>(&c, cells, span);
            let exact = crust_cell::<true>(&c, cells, span);
            total += 1;
            if fast.3 {
                flagged += 1;
                continue;
            }
            let bits = |r: (f64, f64, f64, bool)| (r.0.to_bits(), r.1.to_bits(), r.2.to_bits());
            assert_eq!(bits(fast), bits(exact), "{cells:?}");
            resets += (exact.1 != contact[0] + dt && exact.1 != 0.0) as usize;
        }
        // Both kinds of cells occur, and the unflagged ones are most.
        assert!(flagged > 1000 && flagged < total / 2, "{flagged} of {total}");
        let _ = resets;
    }
}
