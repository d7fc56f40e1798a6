//! Horizontal advection inside a layer (thesis §4.2.4.2, "2D Eulerian CFD"):
//! - wind and temperature: semi-Lagrangian (Stam 1999), optionally MacCormack-corrected with
//!   the min/max limiter of Selle et al. 2008 (less dissipation, still unconditionally stable);
//! - humidity, condensed water and ash: conservative finite-volume upwind fluxes through the
//!   staggered faces, with the face aperture min(σ) so no water enters terrain, and as many
//!   substeps as the outflow Courant number needs. docs/physics/atmosphere.md §5.3 erratum:
//!   semi-Lagrangian advection does not conserve, flux form does (to rounding) on the torus.
//!
//! All grids are `n × n`, `n` a power of two, toroidal. Displacements are in cells.

mod semi_lagrangian;

pub use semi_lagrangian::{Staggering, advect_field, advect_wind_and_temperature};

use volcano_core::parallel;

/// Face apertures from the free fractions σ of the cells: `ax[i, j] = min(σ(i−1, j), σ(i, j))`
/// on west faces, `ay` likewise on south faces.
pub fn apertures(sigma: &[f32], n: usize, ax: &mut [f32], ay: &mut [f32]) {
    let mask = n - 1;
    for j in 0..n {
        let jm = (j + n - 1) & mask;
        for i in 0..n {
            let im = (i + n - 1) & mask;
            let k = j * n + i;
            ax[k] = sigma[k].min(sigma[j * n + im]);
            ay[k] = sigma[k].min(sigma[jm * n + i]);
        }
    }
}

/// Substeps needed so that every cell's outflow Courant number (through apertured faces,
/// relative to its free fraction) stays ≤ 0.9.
pub fn substeps(u: &[f32], v: &[f32], ax: &[f32], ay: &[f32], sigma: &[f32], n: usize, c: f64) -> u32 {
    let mask = n - 1;
    // Max is order-independent: the parallel reduction is deterministic.
    let worst = parallel::Bands::DEFAULT
        .map_ranges(n, |rows| {
            rows.map(|j| {
                let jp = (j + 1) & mask;
                let mut worst = 0.0f64;
                for i in 0..n {
                    let k = j * n + i;
                    if sigma[k] <= 0.0 {
                        continue;
                    }
                    let ip = j * n + ((i + 1) & mask);
                    let kn = jp * n + i;
                    let out = (-u[k]).max(0.0) * ax[k]
                        + u[ip].max(0.0) * ax[ip]
                        + (-v[k]).max(0.0) * ay[k]
                        + v[kn].max(0.0) * ay[kn];
                    worst = worst.max(out as f64 * c / sigma[k] as f64);
                }
                worst
            })
            .fold(0.0, f64::max)
        })
        .into_iter()
        .fold(0.0, f64::max);
    ((worst / 0.9).ceil().min(1e6) as u32).max(1)
}

/// Most substeps a conservative advection runs; beyond, the donor limiter keeps it exact.
pub const MAX_SUBSTEPS: u32 = 256;

/// One conservative upwind step of concentration `q` (amount per free volume) over
/// `c = Δt/Δx`. Pass 1 computes every face flux once (into `fluxes`, length 3n²: west faces,
/// south faces, donor limits); when `limited` (the substep count hit [`MAX_SUBSTEPS`]) pass 2
/// computes for each cell the factor that keeps its total outflow within its content (else all
/// factors are 1: within the CFL limit no cell gives more than it holds); pass 3 adds each limited flux to one cell and removes it from
/// the other, so the sum of `q σ` is conserved to rounding and nothing goes negative. Cells
/// with σ = 0 are untouched.
#[allow(clippy::too_many_arguments)]
pub fn flux_step(
    q: &mut [f64],
    fluxes: &mut [f64],
    u: &[f32],
    v: &[f32],
    ax: &[f32],
    ay: &[f32],
    sigma: &[f32],
    n: usize,
    c: f64,
    limited: bool,
) {
    assert_eq!(fluxes.len(), 3 * n * n, "flux scratch must hold 3n² values");
    let mask = n - 1;
    let (fx, rest) = fluxes.split_at_mut(n * n);
    let (fy, limit) = rest.split_at_mut(n * n);
    {
        let q = &*q;
        parallel::for_each_row((&mut *fx, &mut *fy), n, |j, (fxr, fyr)| {
            let jm = (j + n - 1) & mask;
            for i in 0..n {
                let k = j * n + i;
                let kw = j * n + ((i + n - 1) & mask);
                let ks = jm * n + i;
                let vx = (u[k] * ax[k]) as f64;
                let vy = (v[k] * ay[k]) as f64;
                fxr[i] = vx * if vx > 0.0 { q[kw] } else { q[k] };
                fyr[i] = vy * if vy > 0.0 { q[ks] } else { q[k] };
            }
        });
    }
    let (fx, fy) = (&*fx, &*fy);
    // Within the CFL limit no cell can give more than it holds: no factors needed.
    if limited {
        let q = &*q;
        parallel::for_each_row(&mut *limit, n, |j, row| {
            let jp = (j + 1) & mask;
            for (i, r) in row.iter_mut().enumerate() {
                let k = j * n + i;
                let ke = j * n + ((i + 1) & mask);
                let kn = jp * n + i;
                let out = (-fx[k]).max(0.0) + fx[ke].max(0.0) + (-fy[k]).max(0.0) + fy[kn].max(0.0);
                let content = q[k] * sigma[k] as f64;
                *r = if c * out > content { content / (c * out) } else { 1.0 };
            }
        });
    }
    let limit = &*limit;
    // A face flux limited by its donor cell's factor.
    let lim = |f: f64, into: usize, from: usize| {
        if !limited {
            f
        } else if f > 0.0 {
            f * limit[from]
        } else {
            f * limit[into]
        }
    };
    parallel::for_each_row(&mut *q, n, |j, row| {
        let jp = (j + 1) & mask;
        let jm = (j + n - 1) & mask;
        for (i, qk) in row.iter_mut().enumerate() {
            let k = j * n + i;
            let s = sigma[k];
            if s <= 0.0 {
                continue;
            }
            let kw = j * n + ((i + n - 1) & mask);
            let ks = jm * n + i;
            let ke = j * n + ((i + 1) & mask);
            let kn = jp * n + i;
            let net = lim(fx[k], k, kw) - lim(fx[ke], ke, k) + lim(fy[k], k, ks) - lim(fy[kn], kn, k);
            *qk = (*qk + c * net / s as f64).max(0.0);
        }
    });
}

/// What one conservative advection did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Transport {
    /// Substeps run.
    pub substeps: u32,
    /// Whether the substep cap was hit and the donor limiter acted.
    pub limited: bool,
}

/// Advects several concentration fields conservatively with the same velocities, in
/// `substeps(…)` substeps (at most [`MAX_SUBSTEPS`], beyond which the donor limiter acts).
/// `fluxes` is scratch of length 3n². Fields that are zero everywhere (e.g. ash without an
/// eruption) are skipped: their fluxes are zero.
///
/// Within the substep cap the fields move together, up to three at a time, in one pass per
/// substep (`fused_flux_step`, out of place into `fluxes` and back): the same arithmetic as
/// [`flux_step`] without the limiter, bit for bit, with the wind, apertures and σ read once
/// for all fields and the face fluxes never stored.
#[allow(clippy::too_many_arguments)]
pub fn advect_conservative(
    fields: &mut [&mut [f64]],
    fluxes: &mut [f64],
    u: &[f32],
    v: &[f32],
    ax: &[f32],
    ay: &[f32],
    sigma: &[f32],
    n: usize,
    c: f64,
) -> Transport {
    let need = substeps(u, v, ax, ay, sigma, n, c);
    let m = need.min(MAX_SUBSTEPS);
    let limited = need > MAX_SUBSTEPS;
    let cs = c / m as f64;
    let mut live: Vec<&mut [f64]> =
        fields.iter_mut().filter(|q| q.iter().any(|&x| x != 0.0)).map(|q| &mut **q).collect();
    if limited {
        for q in live.iter_mut() {
            for _ in 0..m {
                flux_step(q, fluxes, u, v, ax, ay, sigma, n, cs, true);
            }
        }
        return Transport { substeps: m, limited };
    }
    assert_eq!(fluxes.len(), 3 * n * n, "flux scratch must hold 3n² values");
    let wind = Faces { u, v, ax, ay, sigma, n };
    for group in live.chunks_mut(3) {
        let mut spare: Vec<&mut [f64]> = fluxes.chunks_mut(n * n).take(group.len()).collect();
        for s in 0..m {
            if s % 2 == 0 {
                let src: Vec<&[f64]> = group.iter().map(|q| &**q).collect();
                fused_flux_step(&src, &mut spare, &wind, cs);
            } else {
                let src: Vec<&[f64]> = spare.iter().map(|q| &**q).collect();
                fused_flux_step(&src, group, &wind, cs);
            }
        }
        if m % 2 == 1 {
            for (q, s) in group.iter_mut().zip(&spare) {
                q.copy_from_slice(s);
            }
        }
    }
    Transport { substeps: m, limited }
}

/// The wind through a layer's faces: MAC components, apertures and free fractions.
struct Faces<'a> {
    u: &'a [f32],
    v: &'a [f32],
    ax: &'a [f32],
    ay: &'a [f32],
    sigma: &'a [f32],
    n: usize,
}

/// One conservative upwind substep of each field of `src` into the same field of `dst` (the
/// flux form of §5.3 within the CFL limit, as [`flux_step`] without the donor limiter): each
/// cell adds the upwind fluxes through its four faces, `q ← max(0, q + c·net/σ)`; cells with
/// σ = 0 keep their value. Rows in bands in parallel (each band writes only its rows).
fn fused_flux_step(src: &[&[f64]], dst: &mut [&mut [f64]], w: &Faces, c: f64) {
    let Faces { u, v, ax, ay, sigma, n } = *w;
    let mask = n - 1;
    let band = parallel::BAND_ROWS * n;
    let mut items: Vec<Vec<&mut [f64]>> = Vec::new();
    for q in dst.iter_mut() {
        for (b, chunk) in q.chunks_mut(band).enumerate() {
            if items.len() <= b {
                items.push(Vec::with_capacity(src.len()));
            }
            items[b].push(chunk);
        }
    }
    parallel::par_map(items, |b, mut out| {
        let first = b * parallel::BAND_ROWS;
        let rows = out.first().map_or(0, |o| o.len() / n);
        for j in first..first + rows {
            let jp = (j + 1) & mask;
            let jm = (j + n - 1) & mask;
            let r = (j - first) * n;
            for i in 0..n {
                let k = j * n + i;
                let s = sigma[k];
                if s <= 0.0 {
                    for (o, q) in out.iter_mut().zip(src) {
                        o[r + i] = q[k];
                    }
                    continue;
                }
                let kw = j * n + ((i + n - 1) & mask);
                let ke = j * n + ((i + 1) & mask);
                let ks = jm * n + i;
                let kn = jp * n + i;
                let (vw, ve) = ((u[k] * ax[k]) as f64, (u[ke] * ax[ke]) as f64);
                let (vs, vn) = ((v[k] * ay[k]) as f64, (v[kn] * ay[kn]) as f64);
                // `x / 1` is `x`: open cells skip the division.
                let open = s == 1.0;
                for (o, q) in out.iter_mut().zip(src) {
                    let fw = vw * if vw > 0.0 { q[kw] } else { q[k] };
                    let fe = ve * if ve > 0.0 { q[k] } else { q[ke] };
                    let fs = vs * if vs > 0.0 { q[ks] } else { q[k] };
                    let fn_ = vn * if vn > 0.0 { q[k] } else { q[kn] };
                    let net = fw - fe + fs - fn_;
                    let gain = if open { c * net } else { c * net / s as f64 };
                    o[r + i] = (q[k] + gain).max(0.0);
                }
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fused_substeps_equal_the_flux_steps_bit_for_bit() {
        let n = 64;
        let sigma: Vec<f32> = (0..n * n).map(|k| [1.0, 1.0, 0.6, 0.0, 1.0][(k * 13 / 7) % 5]).collect();
        let mut ax = vec![0.0; n * n];
        let mut ay = vec![0.0; n * n];
        apertures(&sigma, n, &mut ax, &mut ay);
        let u: Vec<f32> = (0..n * n).map(|k| 9.0 * ((k / n) as f32 * 0.3).sin()).collect();
        let v: Vec<f32> = (0..n * n).map(|k| 6.0 * ((k % n) as f32 * 0.2).cos()).collect();
        let field = |seed: usize| -> Vec<f64> {
            (0..n * n).map(|k| if sigma[k] > 0.0 { ((k * seed) % 17) as f64 * 0.37 } else { 0.0 }).collect()
        };
        let (mut h, mut w, mut ash) = (field(7), field(11), vec![0.0; n * n]);
        let (mut h1, mut w1) = (h.clone(), w.clone());
        let mut src = vec![0.0; 3 * n * n];
        let t =
            advect_conservative(&mut [&mut h, &mut w, &mut ash], &mut src, &u, &v, &ax, &ay, &sigma, n, 0.4);
        assert!(t.substeps > 2 && t.substeps % 2 == 1 && !t.limited, "{t:?}");
        let cs = 0.4 / t.substeps as f64;
        for q in [&mut h1, &mut w1] {
            for _ in 0..t.substeps {
                flux_step(q, &mut src, &u, &v, &ax, &ay, &sigma, n, cs, false);
            }
        }
        assert!(h == h1 && w == w1, "the fused substeps must equal the flux steps");
        assert!(ash.iter().all(|&a| a == 0.0));
    }

    #[test]
    fn flux_form_conserves_and_stays_positive_with_terrain() {
        let n = 32;
        let mut sigma = vec![1.0f32; n * n];
        for j in 10..20 {
            for i in 12..16 {
                sigma[j * n + i] = if i == 12 { 0.4 } else { 0.0 };
            }
        }
        let mut q: Vec<f64> =
            (0..n * n).map(|k| if sigma[k] > 0.0 { 1.0 + ((k * 7) % 5) as f64 } else { 0.0 }).collect();
        // A swirling, divergent wind: the flux form must still conserve Σ q σ.
        let u: Vec<f32> = (0..n * n).map(|k| 8.0 * ((k / n) as f32 * 0.3).sin()).collect();
        let v: Vec<f32> = (0..n * n).map(|k| 5.0 * ((k % n) as f32 * 0.2).cos()).collect();
        let mut ax = vec![0.0; n * n];
        let mut ay = vec![0.0; n * n];
        apertures(&sigma, n, &mut ax, &mut ay);
        let total = |q: &[f64]| q.iter().zip(&sigma).map(|(a, &s)| a * s as f64).sum::<f64>();
        let before = total(&q);
        let mut src = vec![0.0; 3 * n * n];
        let mut subs = 0;
        for _ in 0..200 {
            subs =
                advect_conservative(&mut [&mut q[..]], &mut src, &u, &v, &ax, &ay, &sigma, n, 0.3).substeps;
        }
        assert!(subs > 1, "the test wind should need substeps");
        let after = total(&q);
        assert!(((after - before) / before).abs() < 1e-12, "{before} → {after}");
        assert!(q.iter().all(|&x| x >= 0.0));
        assert!((0..n * n).all(|k| sigma[k] > 0.0 || q[k] == 0.0), "water entered terrain");
        // Far beyond the CFL limit in one step (as when the substep cap is hit): the donor
        // limiter still conserves and keeps every cell non-negative.
        let before = total(&q);
        for _ in 0..20 {
            flux_step(&mut q, &mut src, &u, &v, &ax, &ay, &sigma, n, 5.0, true);
        }
        assert!(((total(&q) - before) / before).abs() < 1e-12);
        assert!(q.iter().all(|&x| x >= 0.0));
    }
}
