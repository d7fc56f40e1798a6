//! Pressure projection of a layer's wind (thesis eq. 4.1) with the continuity target of
//! docs/ARCHITECTURE.md §5.3: `∇·V_i = −(D_i − D_{i−1}) / h_i`, so air leaving a layer through
//! its top draws air in horizontally (and the pressure coupling of eq. 4.7 is not erased).
//!
//! On the staggered grid the discrete divergence of the corrected wind equals the target up to
//! the multigrid residual. On a torus a net gain or loss of air in a layer is not
//! representable: the target's mean is removed (reported as `target_mean`).

use rayon::prelude::*;

use super::multigrid::{Poisson, SolveReport, remove_mean};

/// Discrete divergence (1/s) of the MAC wind into `out`.
pub fn divergence(u: &[f32], v: &[f32], n: usize, dx: f64, out: &mut [f64]) {
    let mask = n - 1;
    let inv = 1.0 / dx;
    out.par_chunks_mut(n).enumerate().with_min_len(8).for_each(|(j, row)| {
        let jp = (j + 1) & mask;
        for (i, o) in row.iter_mut().enumerate() {
            let ip = (i + 1) & mask;
            let k = j * n + i;
            *o = ((u[j * n + ip] - u[k]) as f64 + (v[jp * n + i] - v[k]) as f64) * inv;
        }
    });
}

/// Orographic damping of the wind: each face's velocity is multiplied by its aperture
/// (min σ of the two cells it separates), thesis eq. (4.8) "σ is used for damping the
/// velocity field around obstacles".
pub fn damp(u: &mut [f32], v: &mut [f32], ax: &[f32], ay: &[f32]) {
    u.iter_mut().zip(ax).for_each(|(x, a)| *x *= a);
    v.iter_mut().zip(ay).for_each(|(x, a)| *x *= a);
}

/// Relaxes the wind toward a prevailing wind `(wu, wv)` with time scale `tau` (s): a
/// synoptic forcing (not in the thesis) that keeps a scenario's background wind blowing
/// against the damping by terrain.
pub fn relax_wind(u: &mut [f32], v: &mut [f32], wu: f32, wv: f32, dt: f64, tau: f64) {
    let a = (1.0 - (-dt / tau).exp()) as f32;
    u.iter_mut().for_each(|x| *x += (wu - *x) * a);
    v.iter_mut().for_each(|x| *x += (wv - *x) * a);
}

/// Outcome of one projection.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ProjectionReport {
    /// max |∇·V − target| before the projection (1/s).
    pub initial_error: f64,
    /// max |∇·V − target| after the projection (1/s).
    pub final_error: f64,
    /// Mean of the requested target, removed for solvability (1/s).
    pub target_mean: f64,
    /// The multigrid solve.
    pub solve: SolveReport,
}

/// Scratch buffers of a projection (one set per layer, reused between steps).
#[derive(Debug, Clone)]
pub struct ProjectionWork {
    /// The multigrid workspace.
    pub poisson: Poisson,
    /// Divergence / right-hand side.
    pub rhs: Vec<f64>,
    /// Divergence scratch.
    pub div: Vec<f64>,
}

impl ProjectionWork {
    /// Buffers for an `n × n` grid of cell size `dx`.
    pub fn new(n: usize, dx: f64) -> Result<Self, volcano_core::ConfigError> {
        Ok(Self { poisson: Poisson::new(n, dx)?, rhs: vec![0.0; n * n], div: vec![0.0; n * n] })
    }
}

/// Projects `(u, v)` so that its divergence equals `target` (its mean removed), solving
/// `∇²P = ∇·V − target` (eq. 4.1 with the continuity target) warm-started from `p`, then
/// `V ← V − ∇P`. Stops when the RMS residual is below `tol ·` RMS(right-hand side) or after
/// `max_cycles` V-cycles.
#[allow(clippy::too_many_arguments)]
pub fn project(
    u: &mut [f32],
    v: &mut [f32],
    p: &mut [f64],
    target: &[f64],
    work: &mut ProjectionWork,
    dx: f64,
    max_cycles: u32,
    tol: f64,
) -> ProjectionReport {
    let n = work.poisson.n();
    let target_mean = target.iter().sum::<f64>() / target.len() as f64;
    divergence(u, v, n, dx, &mut work.div);
    let mut initial_error = 0.0f64;
    for ((r, d), t) in work.rhs.iter_mut().zip(&work.div).zip(target) {
        *r = d - (t - target_mean);
        initial_error = initial_error.max(r.abs());
    }
    remove_mean(&mut work.rhs);
    remove_mean(p);
    let scale = super::multigrid::rms(&work.rhs);
    let solve = work.poisson.solve(p, &work.rhs, max_cycles, tol * scale);
    // V ← V − ∇P on the faces.
    let mask = n - 1;
    let inv = 1.0 / dx;
    let p = &*p;
    u.par_chunks_mut(n).zip(v.par_chunks_mut(n)).enumerate().with_min_len(8).for_each(|(j, (ur, vr))| {
        let jm = (j + n - 1) & mask;
        for i in 0..n {
            let im = (i + n - 1) & mask;
            let k = j * n + i;
            ur[i] -= ((p[k] - p[j * n + im]) * inv) as f32;
            vr[i] -= ((p[k] - p[jm * n + i]) * inv) as f32;
        }
    });
    divergence(u, v, n, dx, &mut work.div);
    let final_error =
        work.div.iter().zip(target).map(|(d, t)| (d - (t - target_mean)).abs()).fold(0.0, f64::max);
    ProjectionReport { initial_error, final_error, target_mean, solve }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn projection_meets_the_divergence_target() {
        let n = 128;
        let dx = 200.0;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut u: Vec<f32> = (0..n * n).map(|_| rng.random_range(-5.0..5.0)).collect();
        let mut v: Vec<f32> = (0..n * n).map(|_| rng.random_range(-5.0..5.0)).collect();
        // A vertical-exchange target: a rising column (convergence) and a sink (divergence).
        let target: Vec<f64> = (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64 - 40.0, (k / n) as f64 - 64.0);
                -1e-3 * (-(x * x + y * y) / 50.0).exp() + 5e-4 * (-((x - 50.0).powi(2) + y * y) / 80.0).exp()
            })
            .collect();
        let mut p = vec![0.0; n * n];
        let mut work = ProjectionWork::new(n, dx).unwrap();
        let rep = project(&mut u, &mut v, &mut p, &target, &mut work, dx, 30, 1e-9);
        eprintln!("{rep:?}");
        assert!(rep.final_error <= 1e-4 * rep.initial_error, "{rep:?}");
        assert!(rep.solve.reduction_per_cycle >= 5.0, "{rep:?}");
        // The target is really there: mean convergence under the rising column.
        let mut div = vec![0.0; n * n];
        divergence(&u, &v, n, dx, &mut div);
        let centre = 64 * n + 40;
        assert!((div[centre] - (target[centre] - rep.target_mean)).abs() < 1e-7);
        assert!(div[centre] < -9e-4);
    }
}
