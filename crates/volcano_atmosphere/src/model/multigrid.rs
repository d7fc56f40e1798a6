//! Geometric multigrid for the pressure Poisson equation (thesis eq. 4.1, `∇²P = ∇·V`) on a
//! toroidal, cell-centred `n × n` grid (n a power of two), optionally with face weights:
//! `∇·(a ∇P) = rhs` with `a ∈ [0, 1]` the open fraction (aperture) of each cell face, so the
//! terrain closes faces (`a = 0`) and narrows partly cut ones.
//!
//! V-cycle: red-black Gauss–Seidel smoothing, over-relaxed (SOR, ω = 1.15; 2 pre, 2 post
//! sweeps), residual restricted by averaging
//! the four children, bilinear cell-centred prolongation (weights 9/16, 3/16, 3/16, 1/16), the
//! coarse operator rediscretised at twice the spacing — with face weights, each coarse face
//! weight is the mean of the two fine faces it covers — and a 4 × 4 coarsest grid smoothed to
//! convergence. A cell whose faces are all closed has no equation (its φ is left alone). On a
//! torus the operator has the constants (per connected open region) as null space:
//! right-hand sides must sum to zero over each region, and solutions are returned with zero
//! mean.
//!
//! The row loops of the sweeps, the residual, the restriction and the prolongation have AVX2
//! copies (`multigrid::avx2`, chosen at run time) that give the same bits as the scalar ones.
//!
//! Hand-written: no maintained Rust crate offers a periodic geometric multigrid for a 2D
//! Poisson problem (the sparse-solver crates are algebraic/Krylov and far slower here).

use volcano_core::ConfigError;

mod avx2;
mod kernels;

use kernels::{prolong_add, rb_gauss_seidel, residual_sum_sq, restrict_residual};

/// Over-relaxation of the red-black smoother: each cell moves `ω` times its Gauss–Seidel
/// update. Red-black SOR with ω a little above 1 is a better smoother of the 5-point
/// Laplacian than plain Gauss–Seidel (I. Yavneh, "On red-black SOR smoothing in multigrid",
/// SIAM J. Sci. Comput. 1996). The value is chosen by measurement at 512², V-cycles per step
/// (all layers) to the same residual criterion with ω = 1 / 1.15 / 1.2 / 1.3: convection
/// 12 / 9 / 9 / 12, mixed 34 / 28 / 28 / 31–35, orographic 20 / 17 / 17–18 / –,
/// sea-breeze 12 / 7–8 / 9–10 / –.
const OMEGA: f64 = 1.15;

/// Face weights of one level: `ax` on the west face of each cell, `ay` on its south face.
#[derive(Debug, Clone, PartialEq)]
struct Faces {
    ax: Vec<f64>,
    ay: Vec<f64>,
    /// 1 for a cell with at least one open face, else 0.
    live: Vec<f64>,
}

impl Faces {
    /// Faces of an `n × n` level and which cells they leave open.
    fn new(ax: Vec<f64>, ay: Vec<f64>, n: usize) -> Faces {
        let mask = n - 1;
        let live = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let open = ax[k] + ay[k] + ax[j * n + ((i + 1) & mask)] + ay[((j + 1) & mask) * n + i];
                if open > 0.0 { 1.0 } else { 0.0 }
            })
            .collect();
        Faces { ax, ay, live }
    }

    /// The faces of the `n/2` level: each coarse face is the mean of the two fine faces that
    /// make it up.
    fn coarsen(&self, n: usize) -> Faces {
        let m = n / 2;
        let mut ax = vec![0.0; m * m];
        let mut ay = vec![0.0; m * m];
        for jc in 0..m {
            for ic in 0..m {
                let (i, j) = (2 * ic, 2 * jc);
                ax[jc * m + ic] = 0.5 * (self.ax[j * n + i] + self.ax[(j + 1) * n + i]);
                ay[jc * m + ic] = 0.5 * (self.ay[j * n + i] + self.ay[j * n + i + 1]);
            }
        }
        Faces::new(ax, ay, m)
    }

    /// Weights (west, east, south, north) of cell `(i, j)`; `right`/`up` are the east and
    /// north neighbours' indices.
    #[inline]
    fn around(&self, k: usize, right: usize, up: usize) -> (f64, f64, f64, f64) {
        (self.ax[k], self.ax[right], self.ay[k], self.ay[up])
    }
}

/// One coarse level's storage.
#[derive(Debug, Clone)]
struct Level {
    n: usize,
    h2: f64,
    phi: Vec<f64>,
    rhs: Vec<f64>,
    faces: Option<Faces>,
}

/// Reusable multigrid workspace for one grid size.
#[derive(Debug, Clone)]
pub struct Poisson {
    n: usize,
    h2: f64,
    /// Coarse levels, finest first (level 1 is n/2).
    coarse: Vec<Level>,
    /// Face weights of the finest level (`None`: all faces open, the plain Laplacian).
    faces: Option<Faces>,
}

/// Outcome of [`Poisson::solve`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SolveReport {
    /// V-cycles run.
    pub cycles: u32,
    /// RMS residual before the first cycle.
    pub initial_residual: f64,
    /// RMS residual after the last cycle.
    pub final_residual: f64,
    /// Geometric-mean reduction factor per V-cycle (initial/final)^(1/cycles); 1 if none ran.
    pub reduction_per_cycle: f64,
}

/// Checks that `n` is a power of two in [16, 4096] (the multigrid hierarchy halves it down to
/// 4).
pub fn check_grid_size(n: usize) -> Result<usize, ConfigError> {
    if n.is_power_of_two() && (16..=4096).contains(&n) {
        Ok(n)
    } else {
        Err(ConfigError::InvalidParameter {
            name: "grid",
            value: n as f64,
            reason: "must be a power of two between 16 and 4096 (multigrid coarsening)".into(),
        })
    }
}

impl Poisson {
    /// A workspace for an `n × n` torus of cell size `dx` (m).
    pub fn new(n: usize, dx: f64) -> Result<Self, ConfigError> {
        check_grid_size(n)?;
        volcano_core::error::positive("cell size", dx)?;
        let mut coarse = Vec::new();
        let mut m = n / 2;
        let mut h = 2.0 * dx;
        while m >= 4 {
            coarse.push(Level { n: m, h2: h * h, phi: vec![0.0; m * m], rhs: vec![0.0; m * m], faces: None });
            m /= 2;
            h *= 2.0;
        }
        Ok(Self { n, h2: dx * dx, coarse, faces: None })
    }

    /// Sets the face weights (apertures in [0, 1]: `ax` on west faces, `ay` on south faces)
    /// of the operator `∇·(a∇φ)` and derives the coarse levels' weights. All-ones weights
    /// select the plain Laplacian (the faster path).
    pub fn set_face_weights(&mut self, ax: &[f32], ay: &[f32]) -> Result<(), ConfigError> {
        let n = self.n;
        for (name, w) in [("face weights x", ax), ("face weights y", ay)] {
            if w.len() != n * n {
                return Err(ConfigError::InvalidParameter {
                    name,
                    value: w.len() as f64,
                    reason: format!("must hold one weight per cell ({})", n * n),
                });
            }
            if let Some(&bad) = w.iter().find(|a| !(0.0..=1.0).contains(*a)) {
                return Err(ConfigError::InvalidParameter {
                    name,
                    value: bad as f64,
                    reason: "face weights are open fractions in [0, 1]".into(),
                });
            }
        }
        if ax.iter().chain(ay).all(|&a| a == 1.0) {
            self.clear_face_weights();
            return Ok(());
        }
        let fine =
            Faces::new(ax.iter().map(|&a| a as f64).collect(), ay.iter().map(|&a| a as f64).collect(), n);
        let mut prev = fine.coarsen(n);
        let mut m = n / 2;
        for level in self.coarse.iter_mut() {
            let next = if level.n > 4 { Some(prev.coarsen(m)) } else { None };
            level.faces = Some(prev);
            match next {
                Some(f) => prev = f,
                None => break,
            }
            m /= 2;
        }
        self.faces = Some(fine);
        Ok(())
    }

    /// Back to the plain Laplacian (every face open).
    pub fn clear_face_weights(&mut self) {
        self.faces = None;
        self.coarse.iter_mut().for_each(|l| l.faces = None);
    }

    /// Whether face weights are set.
    pub fn has_face_weights(&self) -> bool {
        self.faces.is_some()
    }

    /// Grid size.
    pub fn n(&self) -> usize {
        self.n
    }

    /// RMS of the residual `rhs − ∇·(a∇φ)` (summed per fixed band of rows while computed).
    pub fn residual_rms(&mut self, phi: &[f64], rhs: &[f64]) -> f64 {
        let sum = residual_sum_sq(self.n, self.h2, self.faces.as_ref(), phi, rhs);
        (sum / (self.n * self.n) as f64).sqrt()
    }

    /// One V-cycle on `phi` (in place) for right-hand side `rhs` (zero mean).
    pub fn v_cycle(&mut self, phi: &mut [f64], rhs: &[f64]) {
        let n = self.n;
        assert_eq!(phi.len(), n * n, "phi has the wrong size");
        assert_eq!(rhs.len(), n * n, "rhs has the wrong size");
        cycle(n, self.h2, self.faces.as_ref(), phi, rhs, &mut self.coarse);
        remove_mean(phi);
    }

    /// Runs V-cycles until the RMS residual falls below `tol_abs` or `max_cycles` ran. The
    /// mean (the null space, which changes no residual) is removed once at the end rather than
    /// after every cycle.
    pub fn solve(&mut self, phi: &mut [f64], rhs: &[f64], max_cycles: u32, tol_abs: f64) -> SolveReport {
        let n = self.n;
        assert_eq!(phi.len(), n * n, "phi has the wrong size");
        assert_eq!(rhs.len(), n * n, "rhs has the wrong size");
        let initial = self.residual_rms(phi, rhs);
        let mut report = SolveReport {
            cycles: 0,
            initial_residual: initial,
            final_residual: initial,
            reduction_per_cycle: 1.0,
        };
        let mut r = initial;
        while report.cycles < max_cycles && r > tol_abs {
            cycle(n, self.h2, self.faces.as_ref(), phi, rhs, &mut self.coarse);
            report.cycles += 1;
            r = self.residual_rms(phi, rhs);
        }
        if report.cycles > 0 {
            remove_mean(phi);
        }
        report.finish(r);
        report
    }
}

/// Whether the multigrid uses its AVX2 row loops on CPUs that have AVX2 (`true`, the
/// default) or its scalar loops only. Both give the same bits (the comparison in
/// `tests/simd.rs`); a process-wide switch for that comparison and for timing.
pub fn use_simd(enabled: bool) {
    avx2::set_enabled(enabled);
}

impl SolveReport {
    fn finish(&mut self, r: f64) {
        self.final_residual = r;
        if self.cycles > 0 && r > 0.0 {
            self.reduction_per_cycle = (self.initial_residual / r).powf(1.0 / self.cycles as f64);
        } else if self.cycles > 0 {
            self.reduction_per_cycle = f64::INFINITY;
        }
    }
}

fn cycle(n: usize, h2: f64, faces: Option<&Faces>, phi: &mut [f64], rhs: &[f64], coarse: &mut [Level]) {
    if coarse.is_empty() {
        // Coarsest grid (4 × 4): smooth to convergence.
        for _ in 0..60 {
            rb_gauss_seidel(n, h2, faces, phi, rhs);
        }
        remove_mean(phi);
        return;
    }
    for _ in 0..2 {
        rb_gauss_seidel(n, h2, faces, phi, rhs);
    }
    // The residual is restricted on the fly, never stored.
    let (level, rest) = coarse.split_first_mut().expect("checked non-empty");
    restrict_residual(n, h2, faces, phi, rhs, &mut level.rhs);
    remove_mean(&mut level.rhs);
    level.phi.iter_mut().for_each(|p| *p = 0.0);
    cycle(level.n, level.h2, level.faces.as_ref(), &mut level.phi, &level.rhs, rest);
    prolong_add(level.n, &level.phi, level.faces.as_ref(), phi);
    for _ in 0..2 {
        rb_gauss_seidel(n, h2, faces, phi, rhs);
    }
}

/// Subtracts the mean (the torus' null space).
pub fn remove_mean<T>(v: &mut [T])
where
    T: Copy + Into<f64> + FromF64,
{
    if v.is_empty() {
        return;
    }
    let mean = v.iter().map(|&x| x.into()).sum::<f64>() / v.len() as f64;
    for x in v.iter_mut() {
        *x = T::from_f64((*x).into() - mean);
    }
}

/// Conversion back from f64 for [`remove_mean`].
pub trait FromF64 {
    /// `x as Self`.
    fn from_f64(x: f64) -> Self;
}
impl FromF64 for f64 {
    fn from_f64(x: f64) -> Self {
        x
    }
}
impl FromF64 for f32 {
    fn from_f64(x: f64) -> Self {
        x as f32
    }
}

/// Root mean square.
pub fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::kernels::{Plain, Stencil};
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// A zero-mean random right-hand side (all frequencies, the hard case for smoothers).
    fn random_rhs(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut rhs: Vec<f64> = (0..n * n).map(|_| rng.random_range(-1.0..1.0)).collect();
        remove_mean(&mut rhs);
        rhs
    }

    #[test]
    fn residual_falls_at_least_5x_per_v_cycle_on_512() {
        let n = 512;
        let mut mg = Poisson::new(n, 100.0).unwrap();
        let rhs = random_rhs(n, 7);
        let mut phi = vec![0.0; n * n];
        let mut prev = mg.residual_rms(&phi, &rhs);
        let first = prev;
        for k in 0..6 {
            mg.v_cycle(&mut phi, &rhs);
            let r = mg.residual_rms(&phi, &rhs);
            let factor = prev / r;
            eprintln!("V-cycle {k}: residual {r:.3e}, reduction {factor:.2}×");
            assert!(factor >= 5.0, "cycle {k}: residual fell only {factor:.2}×");
            prev = r;
        }
        assert!(prev < first * 1e-4);
    }

    #[test]
    fn solves_a_smooth_periodic_problem() {
        // φ = sin(2πx/L) cos(4πy/L): ∇²φ = −((2π/L)² + (4π/L)²) φ. The discrete solution
        // matches to second order.
        let n = 64;
        let dx = 10.0;
        let l = n as f64 * dx;
        let (kx, ky) = (std::f64::consts::TAU / l, 2.0 * std::f64::consts::TAU / l);
        let exact: Vec<f64> = (0..n * n)
            .map(|k| {
                let (x, y) = (((k % n) as f64 + 0.5) * dx, ((k / n) as f64 + 0.5) * dx);
                (kx * x).sin() * (ky * y).cos()
            })
            .collect();
        let rhs: Vec<f64> = exact.iter().map(|p| -(kx * kx + ky * ky) * p).collect();
        let mut mg = Poisson::new(n, dx).unwrap();
        let mut phi = vec![0.0; n * n];
        let rep = mg.solve(&mut phi, &rhs, 30, 1e-12);
        assert!(rep.final_residual < 1e-9, "{rep:?}");
        let err = phi.iter().zip(&exact).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(err < 0.01, "max error {err}");
    }

    /// Residual reduction of each of 6 V-cycles on a masked problem of size n: face weights
    /// are the apertures (min of the two cells' open fractions) of `sigma`, the right-hand
    /// side random on the open cells with zero sum.
    fn masked_rates(n: usize, sigma: &[f32]) -> Vec<f64> {
        let (mut ax, mut ay) = (vec![0.0; n * n], vec![0.0; n * n]);
        crate::model::advection::apertures(sigma, n, &mut ax, &mut ay);
        let active: Vec<bool> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                ax[k] + ax[j * n + (i + 1) % n] + ay[k] + ay[((j + 1) % n) * n + i] > 0.0
            })
            .collect();
        let mut rhs = random_rhs(n, 11);
        rhs.iter_mut().zip(&active).for_each(|(r, &a)| *r = if a { *r } else { 0.0 });
        let count = active.iter().filter(|&&a| a).count() as f64;
        let mean = rhs.iter().sum::<f64>() / count;
        rhs.iter_mut().zip(&active).for_each(|(r, &a)| *r -= if a { mean } else { 0.0 });
        let mut mg = Poisson::new(n, 100.0).unwrap();
        mg.set_face_weights(&ax, &ay).unwrap();
        assert!(mg.has_face_weights());
        let mut phi = vec![0.0; n * n];
        let mut prev = mg.residual_rms(&phi, &rhs);
        (0..6)
            .map(|_| {
                mg.v_cycle(&mut phi, &rhs);
                let r = mg.residual_rms(&phi, &rhs);
                let rate = prev / r;
                prev = r;
                rate
            })
            .collect()
    }

    /// A layer cut by terrain: a closed block (odd-aligned edges) inside a rim of half-open
    /// cells, on 256². Every V-cycle reduces the residual at least 5× (measured 94×, 25×,
    /// 14×, 12×, 9.8×, 8.4×; 58×, 17×, 9.9×, 7.6×, 6.9×, 6.6× with a plain, ω = 1 smoother).
    /// A one-cell-thick wall with an open end is the hard case of
    /// rediscretised coarse operators (the two sides connect only round its end): measured
    /// 17×, 1.4×, 2.1×, 2.4×, 2.6×, 2.7× (18×, 1.2×, 1.7×, 1.9×, 2.1×, 2.1× with ω = 1);
    /// required: 100× over the six cycles.
    #[test]
    fn masked_problems_converge() {
        let n = 256;
        let block: Vec<f32> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                if (81..151).contains(&i) && (61..199).contains(&j) {
                    0.0
                } else if (78..154).contains(&i) && (58..202).contains(&j) {
                    0.5
                } else {
                    1.0
                }
            })
            .collect();
        let rates = masked_rates(n, &block);
        eprintln!("block: {rates:.2?}");
        assert!(rates.iter().all(|&r| r >= 5.0), "block: {rates:.2?}");
        let wall: Vec<f32> = (0..n * n).map(|k| if k % n == 31 && k / n < 200 { 0.0 } else { 1.0 }).collect();
        let rates = masked_rates(n, &wall);
        eprintln!("thin wall: {rates:.2?}");
        assert!(rates.iter().product::<f64>() >= 100.0, "thin wall: {rates:.2?}");
        // Bad weights are errors, all-open weights fall back to the plain Laplacian.
        let mut mg = Poisson::new(16, 100.0).unwrap();
        let ones = vec![1.0f32; 256];
        assert!(mg.set_face_weights(&vec![1.5; 256], &ones).is_err());
        assert!(mg.set_face_weights(&ones[1..], &ones).is_err());
        assert!(mg.set_face_weights(&ones, &[f32::NAN; 256]).is_err());
        mg.set_face_weights(&ones, &ones).unwrap();
        assert!(!mg.has_face_weights());
    }

    /// The reference red-black (SOR) sweep: all red cells, then all black ones.
    fn two_pass_sweep(n: usize, h2: f64, faces: Option<&Faces>, phi: &mut [f64], rhs: &[f64]) {
        let mask = n - 1;
        for colour in 0..2 {
            for j in 0..n {
                for i in ((colour + j) & 1..n).step_by(2) {
                    let (row, up, down) = (j * n, ((j + 1) & mask) * n, ((j + n - 1) & mask) * n);
                    let (left, right) = ((i + n - 1) & mask, (i + 1) & mask);
                    let nb = [phi[row + left], phi[row + right], phi[up + i], phi[down + i]];
                    let (k, h2r) = (row + i, h2 * rhs[row + i]);
                    let x = match faces {
                        None => Plain.relax(k, row + right, up + i, nb, h2r),
                        Some(f) => f.relax(k, row + right, up + i, nb, h2r),
                    };
                    if let Some(x) = x {
                        phi[row + i] += OMEGA * (x - phi[row + i]);
                    }
                }
            }
        }
    }

    #[test]
    /// Also: the AVX2 row loops (sweep, residual sum, restriction,
    /// prolongation) give the scalar loops' bits.
    fn one_pass_sweep_equals_two_colour_passes_bit_for_bit() {
        for n in [8, 16, 64, 256, 512] {
            let rhs = random_rhs(n, 3);
            let start = random_rhs(n, 5);
            let sigma: Vec<f32> =
                (0..n * n).map(|k| [1.0, 0.3, 0.0, 1.0, 1.0, 0.7][(k * 7 / 3) % 6]).collect();
            let (mut ax, mut ay) = (vec![0.0; n * n], vec![0.0; n * n]);
            crate::model::advection::apertures(&sigma, n, &mut ax, &mut ay);
            let faces =
                Faces::new(ax.iter().map(|&a| a as f64).collect(), ay.iter().map(|&a| a as f64).collect(), n);
            for f in [None, Some(&faces)] {
                // The scalar loops and, on a CPU with AVX2, its row loops.
                for avx2 in [false, avx2::cpu_has_avx2()] {
                    let (mut a, mut b) = (start.clone(), start.clone());
                    for _ in 0..3 {
                        kernels::rb_gauss_seidel_on(n, 1e4, f, &mut a, &rhs, avx2);
                        two_pass_sweep(n, 1e4, f, &mut b, &rhs);
                    }
                    assert!(a == b, "n = {n}, faces {}, avx2 {avx2}", f.is_some());
                    let sums = [false, avx2].map(|v| kernels::residual_sum_sq_on(n, 1e4, f, &a, &rhs, v));
                    assert!(
                        sums[0].to_bits() == sums[1].to_bits(),
                        "n = {n}, faces {}: {sums:?}",
                        f.is_some()
                    );
                    let restricted = [false, avx2].map(|v| {
                        let mut coarse = vec![0.0; n * n / 4];
                        kernels::restrict_residual_on(n, 1e4, f, &a, &rhs, &mut coarse, v);
                        coarse
                    });
                    assert!(restricted[0] == restricted[1], "n = {n}, faces {}", f.is_some());
                    if n >= 16 {
                        // Prolongation from this level to twice its size.
                        let prolonged = [false, avx2].map(|v| {
                            let mut fine = random_rhs(2 * n, 9);
                            kernels::prolong_add_on(n, &a, f, &mut fine, v);
                            fine
                        });
                        assert!(prolonged[0] == prolonged[1], "n = {n}, faces {}", f.is_some());
                    }
                }
            }
        }
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(Poisson::new(100, 1.0).is_err());
        assert!(Poisson::new(8, 1.0).is_err());
        assert!(Poisson::new(64, -1.0).is_err());
        assert!(Poisson::new(64, f64::NAN).is_err());
    }
}
