//! Semi-Lagrangian advection of the wind and the temperature (Stam 1999), optionally
//! MacCormack-corrected with the min/max limiter of Selle et al. 2008 (thesis §4.2.4.2,
//! "2D Eulerian CFD"; see [`super`]).
//!
//! Each sample is traced back along the MAC wind at its own position (west faces for u, south
//! faces for v, centres for T), so the three fields have different departure points and
//! bilinear weights; what they share is the wind they read. [`advect_wind_and_temperature`]
//! therefore runs their backward samples in one pass over the rows (the wind read once per
//! cell for all three, one hand-off of bands to the pool instead of three) with the same
//! arithmetic, in the same order, as three [`advect_field`] calls: bit for bit the same result.

use volcano_core::parallel;

use super::super::params::AdvectionScheme;

/// Bilinear periodic sample of `f` at index coordinates `(x, y)`; also returns the min and
/// max of the four corners (for the MacCormack limiter).
#[inline(always)]
fn bilerp(f: &[f32], n: usize, x: f32, y: f32) -> (f32, f32, f32) {
    let mask = n - 1;
    // floor() is a libm call on baseline x86-64 (no SSE4.1 round): truncate and correct.
    let floor = |v: f32| {
        let t = v as i64;
        t - ((v < t as f32) as i64)
    };
    let (fx, fy) = (floor(x), floor(y));
    let (tx, ty) = (x - fx as f32, y - fy as f32);
    let i0 = (fx as usize) & mask;
    let j0 = (fy as usize) & mask;
    let i1 = (i0 + 1) & mask;
    let j1 = (j0 + 1) & mask;
    let (a, b) = (f[j0 * n + i0], f[j0 * n + i1]);
    let (c, d) = (f[j1 * n + i0], f[j1 * n + i1]);
    let lo = a.min(b).min(c.min(d));
    let hi = a.max(b).max(c.max(d));
    let top = a + (b - a) * tx;
    let bot = c + (d - c) * tx;
    (top + (bot - top) * ty, lo, hi)
}

/// Where each sample of a staggered/centred field sits, for computing its velocity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Staggering {
    /// Cell centres (T).
    Centre,
    /// West faces (u).
    FaceX,
    /// South faces (v).
    FaceY,
}

/// [`Staggering`] as a const parameter, so each pass is compiled for its staggering (the
/// velocity inlined, no per-cell branch on it).
const CENTRE: u8 = 0;
const FACE_X: u8 = 1;
const FACE_Y: u8 = 2;

/// Velocity (in cells per second × dt = cells) at sample `(i, j)` of a field with staggering
/// `S` ([`CENTRE`], [`FACE_X`], [`FACE_Y`]), from the MAC components.
#[inline(always)]
fn velocity<const S: u8>(u: &[f32], v: &[f32], n: usize, i: usize, j: usize) -> (f32, f32) {
    let mask = n - 1;
    let ip = (i + 1) & mask;
    let im = (i + n - 1) & mask;
    let jp = (j + 1) & mask;
    let jm = (j + n - 1) & mask;
    match S {
        CENTRE => (0.5 * (u[j * n + i] + u[j * n + ip]), 0.5 * (v[j * n + i] + v[jp * n + i])),
        FACE_X => (u[j * n + i], 0.25 * (v[j * n + im] + v[j * n + i] + v[jp * n + im] + v[jp * n + i])),
        _ => (0.25 * (u[jm * n + i] + u[jm * n + ip] + u[j * n + i] + u[j * n + ip]), v[j * n + i]),
    }
}

/// The backward semi-Lagrangian sample of `f` (staggering `S`) at `(i, j)` over `c = Δt/Δx`,
/// with the min and max of its four corners.
#[inline(always)]
fn back<const S: u8>(
    f: &[f32],
    u: &[f32],
    v: &[f32],
    n: usize,
    c: f32,
    i: usize,
    j: usize,
) -> (f32, f32, f32) {
    let (vx, vy) = velocity::<S>(u, v, n, i, j);
    bilerp(f, n, i as f32 - vx * c, j as f32 - vy * c)
}

/// Advects `f` (staggering `s`) by the MAC velocity `(u, v)` over `c = Δt/Δx` into `out`,
/// using `scratch` (3n²: predictor and the limiter's bounds).
#[allow(clippy::too_many_arguments)]
pub fn advect_field(
    f: &[f32],
    out: &mut [f32],
    scratch: &mut [f32],
    u: &[f32],
    v: &[f32],
    n: usize,
    c: f32,
    s: Staggering,
    scheme: AdvectionScheme,
) {
    match s {
        Staggering::Centre => advect::<CENTRE>(f, out, scratch, u, v, n, c, scheme),
        Staggering::FaceX => advect::<FACE_X>(f, out, scratch, u, v, n, c, scheme),
        Staggering::FaceY => advect::<FACE_Y>(f, out, scratch, u, v, n, c, scheme),
    }
}

/// [`advect_field`] for staggering `S`.
#[allow(clippy::too_many_arguments)]
fn advect<const S: u8>(
    f: &[f32],
    out: &mut [f32],
    scratch: &mut [f32],
    u: &[f32],
    v: &[f32],
    n: usize,
    c: f32,
    scheme: AdvectionScheme,
) {
    if scheme == AdvectionScheme::SemiLagrangian {
        parallel::for_each_row(&mut *out, n, |j, row| {
            for (i, o) in row.iter_mut().enumerate() {
                *o = back::<S>(f, u, v, n, c, i, j).0;
            }
        });
        return;
    }
    let (pred, lo, hi) = split_scratch(scratch, n);
    // Predictor: backward semi-Lagrangian step (rows in parallel; each row reads only `f`),
    // keeping the corners' min and max of each backward sample for the limiter.
    parallel::for_each_row((&mut *pred, &mut *lo, &mut *hi), n, |j, (pr, lr, hr)| {
        for i in 0..n {
            (pr[i], lr[i], hr[i]) = back::<S>(f, u, v, n, c, i, j);
        }
    });
    correct::<S>(f, out, pred, lo, hi, u, v, n, c);
}

/// The predictor and the limiter's bounds in the 3n² of scratch.
fn split_scratch(scratch: &mut [f32], n: usize) -> (&mut [f32], &mut [f32], &mut [f32]) {
    assert!(scratch.len() >= 3 * n * n, "advection scratch must hold 3n² values");
    let (pred, rest) = scratch.split_at_mut(n * n);
    let (lo, hi) = rest.split_at_mut(n * n);
    (pred, lo, &mut hi[..n * n])
}

/// MacCormack corrector: advect the prediction forward, halve the round-trip error, and clamp
/// to the corners of the backward sample (stability).
#[allow(clippy::too_many_arguments)]
fn correct<const S: u8>(
    f: &[f32],
    out: &mut [f32],
    pred: &[f32],
    lo: &[f32],
    hi: &[f32],
    u: &[f32],
    v: &[f32],
    n: usize,
    c: f32,
) {
    parallel::for_each_row(&mut *out, n, |j, row| {
        for (i, o) in row.iter_mut().enumerate() {
            let (vx, vy) = velocity::<S>(u, v, n, i, j);
            let (back, _, _) = bilerp(pred, n, i as f32 + vx * c, j as f32 + vy * c);
            let k = j * n + i;
            *o = (pred[k] + 0.5 * (f[k] - back)).clamp(lo[k], hi[k]);
        }
    });
}

/// Advects a layer's wind `(u, v)` (scheme `wind`) and temperature `t` (scheme
/// `temperature`), all by the old wind `(u, v)`, over `c = Δt/Δx` into `u_out`, `v_out`,
/// `t_out` (`scratch`: 3n²). Bit for bit the same as [`advect_field`] on u, v and T in turn.
/// With a semi-Lagrangian wind (the default) the wind's samples and T's backward sample are
/// taken in one pass over the rows, then T's MacCormack corrector (if any) in a second.
#[allow(clippy::too_many_arguments)]
pub fn advect_wind_and_temperature(
    (u, v, t): (&[f32], &[f32], &[f32]),
    (u_out, v_out, t_out): (&mut [f32], &mut [f32], &mut [f32]),
    scratch: &mut [f32],
    n: usize,
    c: f32,
    wind: AdvectionScheme,
    temperature: AdvectionScheme,
) {
    if wind != AdvectionScheme::SemiLagrangian {
        advect::<FACE_X>(u, u_out, scratch, u, v, n, c, wind);
        advect::<FACE_Y>(v, v_out, scratch, u, v, n, c, wind);
        advect::<CENTRE>(t, t_out, scratch, u, v, n, c, temperature);
        return;
    }
    if temperature == AdvectionScheme::SemiLagrangian {
        parallel::for_each_row((&mut *u_out, &mut *v_out, &mut *t_out), n, |j, (ur, vr, tr)| {
            for i in 0..n {
                ur[i] = back::<FACE_X>(u, u, v, n, c, i, j).0;
                vr[i] = back::<FACE_Y>(v, u, v, n, c, i, j).0;
                tr[i] = back::<CENTRE>(t, u, v, n, c, i, j).0;
            }
        });
        return;
    }
    let (pred, lo, hi) = split_scratch(scratch, n);
    let rows = (&mut *u_out, &mut *v_out, &mut *pred, &mut *lo, &mut *hi);
    parallel::for_each_row(rows, n, |j, (ur, vr, pr, lr, hr)| {
        for i in 0..n {
            ur[i] = back::<FACE_X>(u, u, v, n, c, i, j).0;
            vr[i] = back::<FACE_Y>(v, u, v, n, c, i, j).0;
            (pr[i], lr[i], hr[i]) = back::<CENTRE>(t, u, v, n, c, i, j);
        }
    });
    correct::<CENTRE>(t, t_out, pred, lo, hi, u, v, n, c);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_wind_translates_exactly_by_whole_cells() {
        let n = 32;
        let mut f = vec![0.0f32; n * n];
        f[5 * n + 5] = 1.0;
        let u = vec![2.0f32; n * n];
        let v = vec![-1.0f32; n * n];
        let mut out = vec![0.0; n * n];
        let mut scratch = vec![0.0; 3 * n * n];
        for scheme in [AdvectionScheme::SemiLagrangian, AdvectionScheme::MacCormack] {
            advect_field(&f, &mut out, &mut scratch, &u, &v, n, 1.0, Staggering::Centre, scheme);
            // Moves by (+2, −1) cells.
            assert_eq!(out[4 * n + 7], 1.0, "{scheme:?}");
            assert!((out.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn maccormack_is_less_diffusive_and_bounded() {
        let n = 64;
        let f: Vec<f32> = (0..n * n)
            .map(|k| if (k % n) >= 20 && (k % n) < 30 && (k / n) >= 20 && (k / n) < 30 { 1.0 } else { 0.0 })
            .collect();
        let u = vec![0.37f32; n * n];
        let v = vec![0.21f32; n * n];
        let mut scratch = vec![0.0; 3 * n * n];
        let run = |scheme| {
            let mut a = f.clone();
            let mut b = vec![0.0; n * n];
            let mut s2 = scratch.clone();
            for _ in 0..40 {
                advect_field(&a, &mut b, &mut s2, &u, &v, n, 1.0, Staggering::Centre, scheme);
                std::mem::swap(&mut a, &mut b);
            }
            a
        };
        let sl = run(AdvectionScheme::SemiLagrangian);
        let mc = run(AdvectionScheme::MacCormack);
        let peak = |g: &[f32]| g.iter().cloned().fold(0.0, f32::max);
        assert!(peak(&mc) > peak(&sl) + 0.1, "MacCormack {} vs SL {}", peak(&mc), peak(&sl));
        assert!(mc.iter().all(|&x| (-1e-6..=1.0 + 1e-6).contains(&x)));
        scratch[0] = 0.0;
    }

    /// The one-pass advection of wind and temperature equals three separate passes bit for
    /// bit, for every combination of schemes, in a swirling wind with fractional departures.
    #[test]
    fn one_pass_wind_and_temperature_equal_three_passes_bit_for_bit() {
        use AdvectionScheme::{MacCormack, SemiLagrangian};
        let n = 64;
        let u: Vec<f32> = (0..n * n).map(|k| 4.0 * ((k / n) as f32 * 0.3).sin() + 0.7).collect();
        let v: Vec<f32> = (0..n * n).map(|k| 3.0 * ((k % n) as f32 * 0.2).cos() - 0.4).collect();
        let t: Vec<f32> = (0..n * n).map(|k| 280.0 + ((k * 37) % 23) as f32 * 0.31).collect();
        for (wind, temperature) in
            [(SemiLagrangian, MacCormack), (SemiLagrangian, SemiLagrangian), (MacCormack, MacCormack)]
        {
            let mut scratch = vec![0.0; 3 * n * n];
            let (mut u1, mut v1, mut t1) = (vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]);
            advect_field(&u, &mut u1, &mut scratch, &u, &v, n, 0.77, Staggering::FaceX, wind);
            advect_field(&v, &mut v1, &mut scratch, &u, &v, n, 0.77, Staggering::FaceY, wind);
            advect_field(&t, &mut t1, &mut scratch, &u, &v, n, 0.77, Staggering::Centre, temperature);
            let (mut u2, mut v2, mut t2) = (vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n * n]);
            advect_wind_and_temperature(
                (&u, &v, &t),
                (&mut u2, &mut v2, &mut t2),
                &mut scratch,
                n,
                0.77,
                wind,
                temperature,
            );
            let bits = |x: &[f32]| x.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
            assert!(
                bits(&u1) == bits(&u2) && bits(&v1) == bits(&v2) && bits(&t1) == bits(&t2),
                "{wind:?} / {temperature:?}"
            );
            assert!(t1 != t, "the test wind must move T");
        }
    }
}
