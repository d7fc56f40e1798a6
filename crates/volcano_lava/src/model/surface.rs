//! Layer 2, the surface (thesis §5.4): surface velocity smoothed by the crust, and crust
//! thickness from the time of contact with the air (eq 5.1) and the divergence of the surface
//! velocity (eq 5.3), with the thesis' thresholds and reset rule.

use super::bands::{BAND_ROWS, band_range, simd};
use super::field::FlowField;
use super::params::LavaParams;
use super::samples::{CellSurface, SurfaceSamples, update_samples};
use super::surface_rows::{CrustCtx, VelocityCtx, crust_rows, velocity_rows};
use volcano_core::parallel::par_map;

pub use super::crust::{
    DIVERGENCE_MIN_CRUST, MOVING_SPEED, NO_CRUST_BELOW, SURFACE_TO_MEAN, contact_from_crust,
    crust_from_contact, exp_small,
};

/// Per-cell surface state of a lava field.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceState {
    nx: usize,
    ny: usize,
    /// Crust thickness (m).
    pub crust: Vec<f64>,
    /// Time of contact with the air (s).
    pub contact: Vec<f64>,
    /// Surface velocity (m/s), x and y.
    pub vsurf: [Vec<f64>; 2],
    /// Divergence of the surface velocity (1/s).
    pub divergence: Vec<f64>,
    /// Lagrangian samples that carry the crust (thesis §5.4.2).
    pub samples: SurfaceSamples,
    old: [Vec<f64>; 2],
    /// Per row band: horizontal 3-sums of (u, v, 1) over wet cells for the smoothed surface
    /// velocity, one plane each (kept allocated).
    hsum: Vec<[Vec<f64>; 3]>,
}

impl SurfaceState {
    /// An empty surface (no crust) for a field of `nx × ny` cells.
    pub fn new(nx: usize, ny: usize) -> Self {
        let z = vec![0.0; nx * ny];
        Self {
            nx,
            ny,
            crust: z.clone(),
            contact: z.clone(),
            vsurf: [z.clone(), z.clone()],
            divergence: z.clone(),
            samples: SurfaceSamples::default(),
            old: [z.clone(), z],
            hsum: Vec::new(),
        }
    }

    /// Grid size `(nx, ny)`.
    pub fn size(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Largest and mean crust (m) over cells holding lava thicker than `min_h`.
    pub fn crust_stats(&self, field: &FlowField, min_h: f64) -> (f64, f64) {
        let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
        for (c, &h) in self.crust.iter().zip(field.h.data()) {
            if h > min_h {
                max = max.max(*c);
                sum += c;
                n += 1;
            }
        }
        (max, if n > 0 { sum / n as f64 } else { 0.0 })
    }
}

/// Advances the surface layer by `dt` from the flow's current state.
///
/// 1. Surface velocity: `3/2 ×` the depth-averaged velocity, blended toward its 3×3 wet
///    neighbourhood mean with weight `min(1, h_crust/rigid_crust)`: a thick crust moves as a
///    block (thesis §5.4.1 "smoothing depending on the crust thickness"; the kernel is ours).
/// 2. Crust and contact time are advected along the surface velocity (first-order upwind;
///    the Courant number is clamped to 1).
/// 3. Radiation: `dh_c/dt = 2κ/h_c`, integrated exactly as `h_c ← √(h_c² + 4κ dt)`, which is
///    eq (5.1) `h_c = 2√(κt)` for crust that is neither stretched nor compressed.
/// 4. Divergence, eq (5.3) `(1/h_c) ∂h_c/∂t = −∇·v_surf`, integrated as
///    `h_c ← h_c·exp(−∇·v dt)`, only where `h_c > 1 cm`; stretched below
///    `crust_reset_ratio × 2√(κt)` resets `t = h_c²/(4κ)`.
/// 5. No crust where the lava is thinner than 20 cm and moving; none where there is no lava;
///    never thicker than the lava.
/// 6. Lagrangian samples ([`super::samples`]) advected on the surface velocity get the same
///    physics; cells that hold samples take their mean (unless `surface_samples` is 0).
pub fn update_surface(s: &mut SurfaceState, field: &FlowField, params: &LavaParams, dt: f64) {
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    if s.nx != nx || s.ny != ny || !(dt.is_finite() && dt > 0.0) {
        return;
    }
    let h = field.h.data();
    let (u, v) = (field.vel[0].data(), field.vel[1].data());
    let min_h = params.min_thickness;
    let inv_rigid = 1.0 / params.rigid_crust;
    let band = BAND_ROWS * nx;
    // 1. surface velocity, smoothed by crust thickness (row bands in parallel).
    let simd = simd();
    let c = VelocityCtx { nx, ny, h, u, v, crust: &s.crust, min_h, inv_rigid };
    let [vsx, vsy] = &mut s.vsurf;
    s.hsum.resize_with(ny.div_ceil(BAND_ROWS), Default::default);
    let items: Vec<_> = vsx.chunks_mut(band).zip(vsy.chunks_mut(band)).zip(s.hsum.iter_mut()).collect();
    par_map(items, |b, ((vsx, vsy), hsum)| {
        velocity_rows(&c, band_range(b, ny), hsum, (vsx, vsy), simd);
    });
    // 2–5. divergence, upwind advection, radiation, eq (5.3), thresholds; new values go to
    // `old`, then the buffers swap (row bands in parallel).
    let kappa = params.kappa();
    let c = CrustCtx {
        nx,
        ny,
        h,
        vx: &s.vsurf[0],
        vy: &s.vsurf[1],
        crust: &s.crust,
        contact: &s.contact,
        min_h,
        inv_dx: 1.0 / dx,
        dt,
        kappa,
        four_kdt: 4.0 * kappa * dt,
        reset_ratio: params.crust_reset_ratio,
        four_r2_kappa: 4.0 * params.crust_reset_ratio * params.crust_reset_ratio * kappa,
    };
    let [new_c, new_t] = &mut s.old;
    let items: Vec<_> =
        new_c.chunks_mut(band).zip(new_t.chunks_mut(band)).zip(s.divergence.chunks_mut(band)).collect();
    par_map(items, |b, ((new_c, new_t), divergence)| {
        crust_rows(&c, band_range(b, ny), (new_c, new_t, divergence), simd);
    });
    std::mem::swap(&mut s.crust, &mut s.old[0]);
    std::mem::swap(&mut s.contact, &mut s.old[1]);
    // 6. Lagrangian samples carry the crust; cells holding samples take their mean.
    let cells = CellSurface {
        vsurf: [&s.vsurf[0], &s.vsurf[1]],
        divergence: &s.divergence,
        crust: &mut s.crust,
        contact: &mut s.contact,
    };
    update_samples(&mut s.samples, field, params, cells, dt, params.surface_samples);
}

#[cfg(test)]
#[path = "surface_samples_tests.rs"]
mod samples_tests;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::params::LavaParams;

    fn sheet(n: usize, h: f64) -> FlowField {
        let mut f = FlowField::flat(n, n, 0.5).unwrap();
        f.h.data_mut().fill(h);
        f.temp.data_mut().fill(1400.0);
        f
    }

    /// Under a rigid crust the surface velocity is 3/2 × the mean over the wet cells of the
    /// 3×3 neighbourhood (checked against a direct sum, with dry cells and grid edges, over
    /// more rows than one band).
    #[test]
    fn rigid_crust_moves_with_the_wet_neighbourhood_mean() {
        let p = LavaParams::isothermal(1000.0).unwrap();
        let n = 70;
        let mut f = sheet(n, 1.0);
        for j in 0..n {
            for i in 0..n {
                let k = (i * 7 + j * 13) % 11;
                f.h.set(i, j, if k == 0 { 0.0 } else { 1.0 });
                f.vel[0].set(i, j, (i as f64 * 0.37).sin() + 0.01 * j as f64);
                f.vel[1].set(i, j, (j as f64 * 0.23).cos());
            }
        }
        let mut s = SurfaceState::new(n, n);
        s.crust.fill(p.rigid_crust * 2.0);
        update_surface(&mut s, &f, &p, 0.02);
        for (i, j) in [(0, 0), (5, 31), (33, 32), (69, 40), (12, 69), (50, 64)] {
            if f.h.get(i, j) < p.min_thickness {
                continue;
            }
            let (mut mx, mut my, mut c) = (0.0, 0.0, 0.0);
            for nj in j.saturating_sub(1)..(j + 2).min(n) {
                for ni in i.saturating_sub(1)..(i + 2).min(n) {
                    if f.h.get(ni, nj) >= p.min_thickness {
                        mx += f.vel[0].get(ni, nj);
                        my += f.vel[1].get(ni, nj);
                        c += 1.0;
                    }
                }
            }
            let k = j * n + i;
            assert!((s.vsurf[0][k] - 1.5 * mx / c).abs() < 1e-12, "({i},{j})");
            assert!((s.vsurf[1][k] - 1.5 * my / c).abs() < 1e-12, "({i},{j})");
        }
    }

    #[test]
    fn exp_small_matches_exp() {
        for x in [-0.5, -0.0099, -1e-3, -1e-9, 0.0, 1e-6, 5e-3, 0.0099, 0.01, 0.3] {
            let (a, b) = (exp_small(x), f64::exp(x));
            assert!(((a - b) / b).abs() < 1e-12, "{x}: {a} vs {b}");
        }
    }

    #[test]
    fn stretching_thins_crust_and_resets_contact_time() {
        let p = LavaParams::isothermal(1000.0).unwrap();
        let kappa = p.kappa();
        let mut f = sheet(16, 1.0);
        let mut s = SurfaceState::new(16, 16);
        let t0 = 400.0;
        s.crust.fill(crust_from_contact(kappa, t0)); // 4 cm
        s.contact.fill(t0);
        // Depth-averaged u = a·x: surface divergence 1.5·a = 0.3 /s everywhere.
        let a = 0.2;
        for j in 0..16 {
            for i in 0..16 {
                f.vel[0].set(i, j, a * (i as f64 - 7.5) * 0.5);
            }
        }
        update_surface(&mut s, &f, &p, 0.5);
        let k = 8 * 16 + 8;
        assert!((s.divergence[k] - 1.5 * a).abs() < 1e-12, "{}", s.divergence[k]);
        let grown = (0.04f64.powi(2) + 4.0 * kappa * 0.5).sqrt();
        let expect = grown * (-1.5 * a * 0.5f64).exp();
        assert!((s.crust[k] - expect).abs() < 1e-4, "{} vs {expect}", s.crust[k]);
        // Stretched well below 2√(κt): contact reset to h²/(4κ).
        assert!((s.contact[k] - contact_from_crust(kappa, s.crust[k])).abs() < 1e-6);
        assert!(s.contact[k] < t0);
    }

    #[test]
    fn compression_thickens_and_thin_moving_lava_has_no_crust() {
        let p = LavaParams::isothermal(1000.0).unwrap();
        let kappa = p.kappa();
        let mut f = sheet(16, 1.0);
        let mut s = SurfaceState::new(16, 16);
        s.crust.fill(0.02);
        s.contact.fill(100.0);
        for j in 0..16 {
            for i in 0..16 {
                f.vel[1].set(i, j, -0.1 * (j as f64 - 7.5) * 0.5); // converging in y
            }
        }
        update_surface(&mut s, &f, &p, 0.5);
        let k = 8 * 16 + 8;
        assert!(s.crust[k] > crust_from_contact(kappa, 100.5) * 1.01, "{}", s.crust[k]);
        // 10 cm of moving lava: no crust (thesis 20 cm rule).
        f.h.data_mut().fill(0.1);
        update_surface(&mut s, &f, &p, 0.02);
        assert_eq!(s.crust[k], 0.0);
        assert_eq!(s.contact[k], 0.0);
        // Below 1 cm the divergence does not act: crust grows as 2√(κt) even if compressed.
        let mut s = SurfaceState::new(16, 16);
        f.h.data_mut().fill(1.0);
        update_surface(&mut s, &f, &p, 1.0);
        assert!((s.crust[k] - crust_from_contact(kappa, 1.0)).abs() < 1e-12);
    }
}
