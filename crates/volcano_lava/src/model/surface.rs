//! Layer 2, the surface (thesis §5.4): surface velocity smoothed by the crust, and crust
//! thickness from the time of contact with the air (eq 5.1) and the divergence of the surface
//! velocity (eq 5.3), with the thesis' thresholds and reset rule.

use super::field::FlowField;
use super::params::LavaParams;

/// Crust thickness (m) above which divergence changes the crust (thesis §5.4.2: 1 cm).
pub const DIVERGENCE_MIN_CRUST: f64 = 0.01;
/// Lava thinner than this (m) and moving carries no crust (thesis §5.4.2: 20 cm).
pub const NO_CRUST_BELOW: f64 = 0.2;
/// Speed (m/s) above which lava counts as moving for the no-crust rule.
pub const MOVING_SPEED: f64 = 1e-3;

/// Ratio of the surface speed to the depth-averaged speed of a Jeffreys (half-Poiseuille)
/// profile, `u(h)/ū = 3/2`.
pub const SURFACE_TO_MEAN: f64 = 1.5;

/// Crust thickness after `t` seconds of contact with the air, `2√(κt)` (thesis eq 5.1).
pub fn crust_from_contact(kappa: f64, t: f64) -> f64 {
    2.0 * (kappa * t.max(0.0)).sqrt()
}

/// Contact time giving crust `h`, `t = h²/(4κ)`: the reset after stretching (thesis §5.4.2).
pub fn contact_from_crust(kappa: f64, h: f64) -> f64 {
    h * h / (4.0 * kappa)
}

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
    old: [Vec<f64>; 2],
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
            old: [z.clone(), z],
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
pub fn update_surface(s: &mut SurfaceState, field: &FlowField, params: &LavaParams, dt: f64) {
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    if s.nx != nx || s.ny != ny || !(dt.is_finite() && dt > 0.0) {
        return;
    }
    let h = field.h.data();
    let (u, v) = (field.vel[0].data(), field.vel[1].data());
    let min_h = params.min_thickness;
    let inv_rigid = 1.0 / params.rigid_crust;
    // 1. surface velocity, smoothed by crust thickness.
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            if h[k] < min_h {
                s.vsurf[0][k] = 0.0;
                s.vsurf[1][k] = 0.0;
                continue;
            }
            let (rx, ry) = (SURFACE_TO_MEAN * u[k], SURFACE_TO_MEAN * v[k]);
            let w = (s.crust[k] * inv_rigid).min(1.0);
            if w == 0.0 {
                s.vsurf[0][k] = rx;
                s.vsurf[1][k] = ry;
                continue;
            }
            let (mut mx, mut my, mut n) = (0.0, 0.0, 0.0);
            for nj in j.saturating_sub(1)..(j + 2).min(ny) {
                for ni in i.saturating_sub(1)..(i + 2).min(nx) {
                    let q = nj * nx + ni;
                    if h[q] >= min_h {
                        mx += u[q];
                        my += v[q];
                        n += 1.0;
                    }
                }
            }
            let f = SURFACE_TO_MEAN / n;
            s.vsurf[0][k] = (1.0 - w) * rx + w * mx * f;
            s.vsurf[1][k] = (1.0 - w) * ry + w * my * f;
        }
    }
    // 2–5. divergence, upwind advection, radiation, eq (5.3), thresholds; new values go to
    // `old`, then the buffers swap.
    let kappa = params.kappa();
    let four_kdt = 4.0 * kappa * dt;
    let inv_dx = 1.0 / dx;
    let (vx, vy) = (&s.vsurf[0], &s.vsurf[1]);
    let (crust, contact) = (&s.crust, &s.contact);
    let [new_c, new_t] = &mut s.old;
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            let hk = h[k];
            let speed2 = vx[k] * vx[k] + vy[k] * vy[k];
            if hk < min_h || (hk < NO_CRUST_BELOW && speed2 > MOVING_SPEED * MOVING_SPEED) {
                new_c[k] = 0.0;
                new_t[k] = 0.0;
                s.divergence[k] = 0.0;
                continue;
            }
            let (im, ip) = (if i > 0 { k - 1 } else { k }, if i + 1 < nx { k + 1 } else { k });
            let (jm, jp) = (if j > 0 { k - nx } else { k }, if j + 1 < ny { k + nx } else { k });
            // Divergence by central differences; a dry neighbour counts as this cell.
            let pick = |c: usize, a: &[f64]| if h[c] >= min_h { a[c] } else { a[k] };
            let ddx = (pick(ip, vx) - pick(im, vx)) * inv_dx / ((ip - im).max(1) as f64);
            let ddy = (pick(jp, vy) - pick(jm, vy)) * inv_dx / (((jp - jm) / nx).max(1) as f64);
            let div = ddx + ddy;
            s.divergence[k] = div;
            // Upwind advection of crust and contact time (dry upwind cells carry none).
            let cx = (vx[k] * dt * inv_dx).clamp(-1.0, 1.0);
            let cy = (vy[k] * dt * inv_dx).clamp(-1.0, 1.0);
            let (ux, uy) = (if cx > 0.0 { im } else { ip }, if cy > 0.0 { jm } else { jp });
            let (ax, ay) = (cx.abs(), cy.abs());
            let keep = (1.0 - ax - ay).max(0.0);
            let norm = keep + ax + ay;
            let c0 = (keep * crust[k] + ax * crust[ux] + ay * crust[uy]) / norm;
            let t0 = (keep * contact[k] + ax * contact[ux] + ay * contact[uy]) / norm;
            // Radiation (eq 5.1, incremental) and divergence (eq 5.3).
            let mut t_c = t0 + dt;
            let mut c = (c0 * c0 + four_kdt).sqrt();
            if c > DIVERGENCE_MIN_CRUST && div != 0.0 {
                c *= (-div * dt).exp();
                if div > 0.0 && c < params.crust_reset_ratio * crust_from_contact(kappa, t_c) {
                    t_c = contact_from_crust(kappa, c);
                }
            }
            new_c[k] = c.min(hk);
            new_t[k] = t_c;
        }
    }
    std::mem::swap(&mut s.crust, &mut s.old[0]);
    std::mem::swap(&mut s.contact, &mut s.old[1]);
}

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
