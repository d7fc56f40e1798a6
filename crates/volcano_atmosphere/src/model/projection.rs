//! Pressure projection of a layer's wind (thesis eq. 4.1) with the continuity target of
//! docs/physics/atmosphere.md §5.3: `∇·V_i = −(D_i − D_{i−1}) / h_i`, so air leaving a layer through
//! its top draws air in horizontally (and the pressure coupling of eq. 4.7 is not erased).
//!
//! The terrain enters through the face apertures `a` (open fraction of each face, from σ of
//! eq. 4.8, see `advection::apertures`): what must meet the target is the flux `a·V`, so the
//! pressure solves the variable-coefficient problem `∇·(a∇P) = ∇·(aV) − target` and the
//! correction `V ← V − ∇P` applies on open faces, while the wind on closed faces (`a = 0`,
//! rock on one side) is zero: no wind blows into the terrain.
//!
//! On the staggered grid the discrete flux divergence of the corrected wind equals the target
//! up to the multigrid residual. On a torus a net gain or loss of air in a layer is not
//! representable: the target's mean over each connected open region is removed (reported as
//! `target_mean`); cells with every face closed take no part.

use volcano_core::parallel;

use super::multigrid::{Poisson, SolveReport, remove_mean};

/// Discrete divergence (1/s) of the MAC wind into `out`.
pub fn divergence(u: &[f32], v: &[f32], n: usize, dx: f64, out: &mut [f64]) {
    let mask = n - 1;
    let inv = 1.0 / dx;
    parallel::for_each_row(out, n, |j, row| {
        let jp = (j + 1) & mask;
        for (i, o) in row.iter_mut().enumerate() {
            let ip = (i + 1) & mask;
            let k = j * n + i;
            *o = ((u[j * n + ip] - u[k]) as f64 + (v[jp * n + i] - v[k]) as f64) * inv;
        }
    });
}

/// Discrete divergence (1/s) of the face fluxes `a·V` (aperture × wind) into `out`.
pub fn flux_divergence(u: &[f32], v: &[f32], ax: &[f32], ay: &[f32], n: usize, dx: f64, out: &mut [f64]) {
    let inv = 1.0 / dx;
    parallel::for_each_row(out, n, |j, row| {
        for (i, o) in row.iter_mut().enumerate() {
            *o = flux_divergence_at(u, v, ax, ay, n, inv, i, j);
        }
    });
}

/// The flux divergence of [`flux_divergence`] at cell `(i, j)`; `inv = 1/Δx`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn flux_divergence_at(
    u: &[f32],
    v: &[f32],
    ax: &[f32],
    ay: &[f32],
    n: usize,
    inv: f64,
    i: usize,
    j: usize,
) -> f64 {
    let mask = n - 1;
    let f = |a: f32, w: f32| a as f64 * w as f64;
    let (k, ke, kn) = (j * n + i, j * n + ((i + 1) & mask), ((j + 1) & mask) * n + i);
    (f(ax[ke], u[ke]) - f(ax[k], u[k]) + f(ay[kn], v[kn]) - f(ay[k], v[k])) * inv
}

/// Orographic damping of the wind, thesis eq. (4.8) "σ is used for damping the velocity field
/// around obstacles": each face's velocity is scaled by how much narrower the face is than the
/// air it joins, `f = a / max(σ_left, σ_right)` (1 where the terrain cuts both cells alike,
/// e.g. a flat floor inside the lowest slab; 0 against a wall). Multiplying by `a` itself
/// would brake a layer whose slab reaches below a flat ground every step
/// (docs/physics/atmosphere.md §5). The thesis applies `f` once per step, so the damping doubles
/// when the step is halved and the wind over a ridge does not converge in Δt
/// (`tests/convergence.rs`); here it is a rate: `f^{steps}` with `steps = Δt/τ`, i.e. `f`
/// every τ seconds.
pub fn damp(u: &mut [f32], v: &mut [f32], ax: &[f32], ay: &[f32], sigma: &[f32], n: usize, steps: f64) {
    let mask = n - 1;
    let power = steps as f32;
    let rel = |a: f32, s0: f32, s1: f32| {
        let s = s0.max(s1);
        if a >= s && s > 0.0 {
            // a / s ≥ 1 (correctly rounded): no damping, without the division (open air).
            return 1.0;
        }
        let f = if s > 0.0 { (a / s).min(1.0) } else { 0.0 };
        if f >= 1.0 { 1.0 } else { f.powf(power) }
    };
    parallel::for_each_row((&mut *u, &mut *v), n, |j, (ur, vr)| {
        let jm = (j + n - 1) & mask;
        for i in 0..n {
            let k = j * n + i;
            ur[i] *= rel(ax[k], sigma[k], sigma[j * n + ((i + n - 1) & mask)]);
            vr[i] *= rel(ay[k], sigma[k], sigma[jm * n + i]);
        }
    });
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
    /// max |∇·(aV) − target| over the open cells before the projection (1/s).
    pub initial_error: f64,
    /// max |∇·(aV) − target| over the open cells after the projection (1/s).
    pub final_error: f64,
    /// Mean of the requested target over the open cells, removed (per connected open region)
    /// for solvability (1/s).
    pub target_mean: f64,
    /// Largest |wind| on a closed face (aperture 0) after the projection (m/s).
    pub solid_face_speed: f64,
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
    /// Connected open region of each cell (`u32::MAX`: every face closed).
    region: Vec<u32>,
    /// Per region: target sum, then mean.
    region_mean: Vec<f64>,
    /// Cells per region.
    region_cells: Vec<u32>,
    /// The apertures `region` and the multigrid weights were built for (`ax` then `ay`).
    faces_for: Vec<f32>,
}

impl ProjectionWork {
    /// Buffers for an `n × n` grid of cell size `dx`.
    pub fn new(n: usize, dx: f64) -> Result<Self, volcano_core::ConfigError> {
        Ok(Self {
            poisson: Poisson::new(n, dx)?,
            rhs: vec![0.0; n * n],
            div: vec![0.0; n * n],
            region: Vec::new(),
            region_mean: Vec::new(),
            region_cells: Vec::new(),
            faces_for: Vec::new(),
        })
    }

    /// Rebuilds the open regions and the multigrid face weights when the apertures changed.
    fn use_faces(&mut self, ax: &[f32], ay: &[f32]) -> Result<(), volcano_core::ConfigError> {
        let n = self.poisson.n();
        if self.faces_for.len() == 2 * n * n
            && self.faces_for[..n * n] == *ax
            && self.faces_for[n * n..] == *ay
        {
            return Ok(());
        }
        self.poisson.set_face_weights(ax, ay)?;
        (self.region, self.region_cells) = open_regions(ax, ay, n);
        self.region_mean = vec![0.0; self.region_cells.len()];
        self.faces_for.clear();
        self.faces_for.extend_from_slice(ax);
        self.faces_for.extend_from_slice(ay);
        Ok(())
    }
}

/// Labels the connected open regions (cells joined by faces with aperture > 0), in order of
/// their first cell, and counts their cells; cells with every face closed get `u32::MAX`.
fn open_regions(ax: &[f32], ay: &[f32], n: usize) -> (Vec<u32>, Vec<u32>) {
    let mask = n - 1;
    let mut parent: Vec<u32> = (0..(n * n) as u32).collect();
    fn root(parent: &mut [u32], mut k: u32) -> u32 {
        while parent[k as usize] != k {
            parent[k as usize] = parent[parent[k as usize] as usize];
            k = parent[k as usize];
        }
        k
    }
    fn join(parent: &mut [u32], a: usize, b: usize) {
        let (ra, rb) = (root(parent, a as u32), root(parent, b as u32));
        if ra != rb {
            parent[ra.max(rb) as usize] = ra.min(rb);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let k = j * n + i;
            if ax[k] > 0.0 {
                join(&mut parent, k, j * n + ((i + n - 1) & mask));
            }
            if ay[k] > 0.0 {
                join(&mut parent, k, ((j + n - 1) & mask) * n + i);
            }
        }
    }
    let mut label = vec![u32::MAX; n * n];
    let mut id_of_root = vec![u32::MAX; n * n];
    let mut cells: Vec<u32> = Vec::new();
    for k in 0..n * n {
        let (i, j) = (k % n, k / n);
        let east = ax[j * n + ((i + 1) & mask)];
        let north = ay[((j + 1) & mask) * n + i];
        if !(ax[k] > 0.0 || ay[k] > 0.0 || east > 0.0 || north > 0.0) {
            continue;
        }
        let r = root(&mut parent, k as u32) as usize;
        if id_of_root[r] == u32::MAX {
            id_of_root[r] = cells.len() as u32;
            cells.push(0);
        }
        label[k] = id_of_root[r];
        cells[id_of_root[r] as usize] += 1;
    }
    (label, cells)
}

/// Projects `(u, v)` so that the divergence of the face fluxes `a·V` (apertures `ax` on west
/// faces, `ay` on south faces) equals `target` (its mean over each open region removed),
/// solving `∇·(a∇P) = ∇·(aV) − target` (eq. 4.1 with the continuity target and the terrain's
/// apertures) warm-started from `p`, then `V ← V − ∇P` on open faces and `V = 0` on closed
/// ones. Stops when the RMS residual is below `tol ·` RMS(right-hand side) or after
/// `max_cycles` V-cycles. Errors if the apertures are not in [0, 1].
#[allow(clippy::too_many_arguments)]
pub fn project(
    u: &mut [f32],
    v: &mut [f32],
    p: &mut [f64],
    target: &[f64],
    ax: &[f32],
    ay: &[f32],
    work: &mut ProjectionWork,
    dx: f64,
    max_cycles: u32,
    tol: f64,
) -> Result<ProjectionReport, volcano_core::ConfigError> {
    let n = work.poisson.n();
    work.use_faces(ax, ay)?;
    // Target mean per open region.
    work.region_mean.iter_mut().for_each(|m| *m = 0.0);
    for (r, t) in work.region.iter().zip(target) {
        if *r != u32::MAX {
            work.region_mean[*r as usize] += t;
        }
    }
    let open_cells: u32 = work.region_cells.iter().sum();
    let target_mean = work.region_mean.iter().sum::<f64>() / open_cells.max(1) as f64;
    for (m, &c) in work.region_mean.iter_mut().zip(&work.region_cells) {
        *m /= c.max(1) as f64;
    }
    let (region, region_mean) = (&work.region, &work.region_mean);
    let goal = |k: usize| target[k] - region_mean[region[k] as usize];
    flux_divergence(u, v, ax, ay, n, dx, &mut work.div);
    // The right-hand side, its largest entry and its sum of squares (for its RMS, in the order
    // `multigrid::rms` sums them).
    let (mut initial_error, mut squares) = (0.0f64, 0.0f64);
    for (k, r) in work.rhs.iter_mut().enumerate() {
        *r = if region[k] == u32::MAX { 0.0 } else { work.div[k] - goal(k) };
        initial_error = initial_error.max(r.abs());
        squares += *r * *r;
    }
    remove_mean(p);
    let scale = if work.rhs.is_empty() { 0.0 } else { (squares / work.rhs.len() as f64).sqrt() };
    let solve = work.poisson.solve(p, &work.rhs, max_cycles, tol * scale);
    // V ← V − ∇P on the open faces, no wind through closed ones; the largest wind left on a
    // closed face (a maximum: the same in any order of the rows).
    let mask = n - 1;
    let inv = 1.0 / dx;
    let p = &*p;
    let solid_face_speed = parallel::map_rows((&mut *u, &mut *v), n, |j, (ur, vr)| {
        let jm = (j + n - 1) & mask;
        let mut solid = 0.0f64;
        for i in 0..n {
            let im = (i + n - 1) & mask;
            let k = j * n + i;
            ur[i] = if ax[k] > 0.0 { ur[i] - ((p[k] - p[j * n + im]) * inv) as f32 } else { 0.0 };
            vr[i] = if ay[k] > 0.0 { vr[i] - ((p[k] - p[jm * n + i]) * inv) as f32 } else { 0.0 };
            if ax[k] == 0.0 {
                solid = solid.max(ur[i].abs() as f64);
            }
            if ay[k] == 0.0 {
                solid = solid.max(vr[i].abs() as f64);
            }
        }
        solid
    })
    .into_iter()
    .fold(0.0, f64::max);
    // Largest |∇·(aV) − target| over the open cells after the projection (bands in parallel;
    // a maximum).
    let (u, v) = (&*u, &*v);
    let final_error = parallel::Bands::DEFAULT
        .map_ranges(n, |rows| {
            let mut worst = 0.0f64;
            for j in rows {
                for i in 0..n {
                    let k = j * n + i;
                    if region[k] != u32::MAX {
                        worst = worst.max((flux_divergence_at(u, v, ax, ay, n, inv, i, j) - goal(k)).abs());
                    }
                }
            }
            worst
        })
        .into_iter()
        .fold(0.0, f64::max);
    Ok(ProjectionReport { initial_error, final_error, target_mean, solid_face_speed, solve })
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
        let open = vec![1.0f32; n * n];
        let rep = project(&mut u, &mut v, &mut p, &target, &open, &open, &mut work, dx, 30, 1e-9).unwrap();
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
