//! Layer 1, the flow: a mass-exact explicit finite-volume scheme for the lubrication
//! (Jeffreys) equation of a viscous sheet over a heightfield,
//! `∂h/∂t = ∇·(ρ g h³/(3η(T)) ∇s)`, `s = ground + h` (DESIGN.md §5; the thesis used a closed
//! virtual-pipes simulator, §5.4, whose role this replaces).
//!
//! Per substep: (1) a flux per face from the surface gradient, with the upwind (donor)
//! thickness and the donor's viscosity; (2) a stable substep from the explicit diffusion and
//! kinematic-wave limits; (3) each cell's outgoing volume scaled so it never exceeds what the
//! cell holds; (4) every face volume is subtracted from its donor and added to its receiver
//! as the same f64 number, so the total changes only by round-off, and heat (h·T) moves with
//! it at the donor temperature.

use super::field::{Edge, FlowField};
use super::params::{GRAVITY, LavaParams, ViscosityModel};

/// Reusable work arrays of one field (allocated once).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scratch {
    /// ρg/(3η) per cell (1/(m·s)).
    coef: Vec<f64>,
    /// x-face fluxes, `(nx+1) × ny`: m²/s, then m³ after the substep; +x positive.
    fx: Vec<f64>,
    /// y-face fluxes, `nx × (ny+1)`.
    fy: Vec<f64>,
    /// Per-cell outgoing volume, then the limiter factor in [0, 1].
    out: Vec<f64>,
    h_new: Vec<f64>,
    t_new: Vec<f64>,
    /// Face volumes accumulated over the step (for velocities).
    acc_x: Vec<f64>,
    acc_y: Vec<f64>,
}

impl Scratch {
    pub(crate) fn new(nx: usize, ny: usize) -> Self {
        let n = nx * ny;
        Self {
            coef: vec![0.0; n],
            fx: vec![0.0; (nx + 1) * ny],
            fy: vec![0.0; nx * (ny + 1)],
            out: vec![0.0; n],
            h_new: vec![0.0; n],
            t_new: vec![0.0; n],
            acc_x: vec![0.0; (nx + 1) * ny],
            acc_y: vec![0.0; nx * (ny + 1)],
        }
    }
}

/// What one call to [`advance_flow`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FlowReport {
    /// Substeps taken.
    pub substeps: u32,
    /// True if `max_substeps` was reached and the last substep's mobility was capped (the flow
    /// was slowed to stay stable).
    pub mobility_capped: bool,
    /// Volume that left through open edges during the call (m³).
    pub outflow: f64,
}

/// Slope correction turning the small-slope lubrication flux `ρ g h_v³ G/(3η)` (vertical
/// thickness h_v, ground gradient G = tan θ) into Jeffreys' exact sheet flux on an incline,
/// `ρ g h_n³ sin θ/(3η)` with `h_n = h_v cos θ`: the factor is `cos⁴ θ = 1/(1 + G²)²`.
#[inline]
pub fn slope_factor(ground_gradient: f64) -> f64 {
    let c2 = 1.0 / (1.0 + ground_gradient * ground_gradient);
    c2 * c2
}

/// Bingham factor of the lubrication flux (Liu & Mei 1989): with plug height
/// `h₀ = τ_y/(ρ g |∇s|)` and `r = h₀/h`, the flux is multiplied by `1 − 3r/2 + r³/2`, and is
/// zero when `h ≤ h₀` (the basal stress does not exceed the yield strength).
#[inline]
pub fn bingham_factor(h: f64, plug: f64) -> f64 {
    if plug >= h {
        0.0
    } else {
        let r = plug / h;
        1.0 - 1.5 * r + 0.5 * r * r * r
    }
}

/// Lubrication (Jeffreys) flux per unit width (m²/s) across one face, from cell `a` to cell
/// `b` (positive = a → b), and its stability measures `(q, mobility, wave speed)`:
/// `q = −M_f · ∂s/∂n · cos⁴θ · bingham`, with the face mobility `M_f` the mean of the two cells'
/// mobilities `ρ g h³/(3η(T))` (second-order in the interior; at a front it is half the wet
/// cell's, so lava advances into dry cells). A face whose donor (higher surface) cell is dry
/// carries no lava: the limiter of [`transfer`] scales it to zero.
#[inline]
fn face_flux(
    dx: f64,
    yield_over_rho_g: f64,
    (ga, ha, ca): (f64, f64, f64),
    (gb, hb, cb): (f64, f64, f64),
) -> (f64, f64, f64) {
    let grad = ((gb + hb) - (ga + ha)) / dx;
    let hd = if grad < 0.0 { ha } else { hb };
    if hd <= 0.0 || grad == 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let mut m = 0.5 * (ca * ha * ha * ha + cb * hb * hb * hb) * slope_factor((gb - ga) / dx);
    if yield_over_rho_g > 0.0 {
        m *= bingham_factor(hd, yield_over_rho_g / grad.abs());
    }
    let q = -m * grad;
    // Kinematic wave speed ∂q/∂h ≈ 3q/h with the thickness that dominates the mobility.
    (q, m, 3.0 * q.abs() / ha.max(hb))
}

/// Advances the lava thickness and temperature of `field` by `dt` seconds with as many
/// CFL-limited substeps as needed (at most `params.max_substeps`). Volume is conserved to
/// round-off: only open edges remove lava (booked as outflow).
pub fn advance_flow(field: &mut FlowField, params: &LavaParams, dt: f64) -> FlowReport {
    let mut report = FlowReport::default();
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    field.scratch.acc_x.iter_mut().for_each(|v| *v = 0.0);
    field.scratch.acc_y.iter_mut().for_each(|v| *v = 0.0);
    let yield_rg = params.yield_strength / (params.density * GRAVITY);
    let mut t_left = dt;
    while t_left > 0.0 && report.substeps < params.max_substeps {
        report.substeps += 1;
        let s = &mut field.scratch;
        // 1. per-cell mobility coefficient ρg/(3η(T)).
        let rg3 = params.density * GRAVITY / 3.0;
        match params.viscosity {
            ViscosityModel::Constant(eta) => s.coef.iter_mut().for_each(|c| *c = rg3 / eta),
            model => {
                for (c, &t) in s.coef.iter_mut().zip(field.temp.data()) {
                    *c = rg3 / model.viscosity(t);
                }
            }
        }
        // 2. face fluxes and stability limits.
        let (g, h) = (field.ground.data(), field.h.data());
        let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
        let nfx = nx + 1;
        for j in 0..ny {
            let row = j * nx;
            for i in 1..nx {
                let (a, b) = (row + i - 1, row + i);
                let (q, m, c) = face_flux(dx, yield_rg, (g[a], h[a], s.coef[a]), (g[b], h[b], s.coef[b]));
                s.fx[j * nfx + i] = q;
                m_max = m_max.max(m);
                c_max = c_max.max(c);
            }
            let (w, e) = (row, row + nx - 1);
            let (q0, qn) = match (field.edges.west, field.edges.east) {
                (Edge::Periodic, _) => {
                    let (q, m, c) = face_flux(dx, yield_rg, (g[e], h[e], s.coef[e]), (g[w], h[w], s.coef[w]));
                    m_max = m_max.max(m);
                    c_max = c_max.max(c);
                    (q, q)
                }
                (we, ee) => {
                    let qw = open_flux(we, dx, yield_rg, row, 1, nx, g, h, &s.coef, &mut m_max, &mut c_max);
                    let qe = open_flux(ee, dx, yield_rg, e, -1, nx, g, h, &s.coef, &mut m_max, &mut c_max);
                    (-qw, qe)
                }
            };
            s.fx[j * nfx] = q0;
            s.fx[j * nfx + nx] = qn;
        }
        for j in 1..ny {
            for i in 0..nx {
                let (a, b) = ((j - 1) * nx + i, j * nx + i);
                let (q, m, c) = face_flux(dx, yield_rg, (g[a], h[a], s.coef[a]), (g[b], h[b], s.coef[b]));
                s.fy[j * nx + i] = q;
                m_max = m_max.max(m);
                c_max = c_max.max(c);
            }
        }
        for i in 0..nx {
            let (so, no) = (i, (ny - 1) * nx + i);
            let (q0, qn) = match (field.edges.south, field.edges.north) {
                (Edge::Periodic, _) => {
                    let (q, m, c) =
                        face_flux(dx, yield_rg, (g[no], h[no], s.coef[no]), (g[so], h[so], s.coef[so]));
                    m_max = m_max.max(m);
                    c_max = c_max.max(c);
                    (q, q)
                }
                (se, ne) => {
                    let step = nx as isize;
                    let qs = open_flux(se, dx, yield_rg, so, step, ny, g, h, &s.coef, &mut m_max, &mut c_max);
                    let qn =
                        open_flux(ne, dx, yield_rg, no, -step, ny, g, h, &s.coef, &mut m_max, &mut c_max);
                    (-qs, qn)
                }
            };
            s.fy[i] = q0;
            s.fy[ny * nx + i] = qn;
        }
        // 3. substep: explicit diffusion limit dx²/(4 D) and kinematic wave limit dx/c.
        let mut stable = f64::INFINITY;
        if m_max > 0.0 {
            stable = stable.min(dx * dx / (4.0 * m_max));
        }
        if c_max > 0.0 {
            stable = stable.min(dx / c_max);
        }
        let mut dt_s = t_left.min(params.cfl * stable);
        let mut scale = dx; // face length: volume = q · dt · dx
        if report.substeps == params.max_substeps && dt_s < t_left {
            // Out of substeps: finish the step but cap the mobility so it stays stable.
            scale *= dt_s / t_left;
            dt_s = t_left;
            report.mobility_capped = true;
        }
        let vol = scale * dt_s;
        s.fx.iter_mut().for_each(|q| *q *= vol);
        s.fy.iter_mut().for_each(|q| *q *= vol);
        t_left -= dt_s;
        if t_left < 1e-12 * dt {
            t_left = 0.0;
        }
        report.outflow += transfer(field, dx);
    }
    // Depth-averaged velocity: mean of the two face fluxes over the step, divided by h.
    let s = &field.scratch;
    let (h, [u, v]) = (field.h.data(), &mut field.vel);
    let (u, v) = (u.data_mut(), v.data_mut());
    let nfx = nx + 1;
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            if h[k] < params.min_thickness {
                u[k] = 0.0;
                v[k] = 0.0;
                continue;
            }
            let qx = 0.5 * (s.acc_x[j * nfx + i] + s.acc_x[j * nfx + i + 1]) / (dx * dt);
            let qy = 0.5 * (s.acc_y[j * nx + i] + s.acc_y[(j + 1) * nx + i]) / (dx * dt);
            u[k] = qx / h[k];
            v[k] = qy / h[k];
        }
    }
    field.budget.outflow += report.outflow;
    field.time += dt;
    report
}

/// Flux (m²/s, positive = out of the grid) through an open edge next to cell `e`, whose
/// inward neighbour is `e + inward` (ground extrapolated linearly outside, same thickness:
/// the lava leaves at the ground slope, nothing comes in). Zero for walls.
#[allow(clippy::too_many_arguments)]
#[inline]
fn open_flux(
    edge: Edge,
    dx: f64,
    yield_rg: f64,
    e: usize,
    inward: isize,
    n: usize,
    g: &[f64],
    h: &[f64],
    coef: &[f64],
    m_max: &mut f64,
    c_max: &mut f64,
) -> f64 {
    if edge != Edge::Open {
        return 0.0;
    }
    let inner = if n > 1 { (e as isize + inward) as usize } else { e };
    let ghost = 2.0 * g[e] - g[inner];
    let (q, m, c) = face_flux(dx, yield_rg, (g[e], h[e], coef[e]), (ghost, h[e], coef[e]));
    *m_max = m_max.max(m);
    *c_max = c_max.max(c);
    q.max(0.0)
}

/// Applies the face volumes (m³) of one substep with the positivity limiter; returns the
/// volume that left through open edges.
fn transfer(field: &mut FlowField, dx: f64) -> f64 {
    let (nx, ny) = (field.nx(), field.ny());
    let nfx = nx + 1;
    let area = dx * dx;
    let s = &mut field.scratch;
    let (h, t) = (field.h.data(), field.temp.data());
    // Outgoing volume per cell, then the limiter factor.
    s.out.iter_mut().for_each(|v| *v = 0.0);
    for j in 0..ny {
        for i in 0..=nx {
            let q = s.fx[j * nfx + i];
            if q > 0.0 {
                if i > 0 {
                    s.out[j * nx + i - 1] += q;
                } else if field.edges.west == Edge::Periodic {
                    s.out[j * nx + nx - 1] += q;
                }
            } else if q < 0.0 {
                if i < nx {
                    s.out[j * nx + i] -= q;
                } else if field.edges.east == Edge::Periodic {
                    s.out[j * nx] -= q;
                }
            }
        }
    }
    // Periodic faces 0 and nx are the same face: count it once.
    if field.edges.west == Edge::Periodic {
        for j in 0..ny {
            let q = s.fx[j * nfx];
            if q > 0.0 {
                s.out[j * nx + nx - 1] -= q;
            } else {
                s.out[j * nx] += q;
            }
        }
    }
    for j in 0..=ny {
        for i in 0..nx {
            let q = s.fy[j * nx + i];
            if q > 0.0 && j > 0 {
                s.out[(j - 1) * nx + i] += q;
            } else if q < 0.0 && j < ny {
                s.out[j * nx + i] -= q;
            }
        }
    }
    // (y: a periodic face's outflow is counted once, at face ny if positive, face 0 if not.)
    for (f, &hk) in s.out.iter_mut().zip(h) {
        let avail = hk * area;
        *f = if *f > avail { avail / *f } else { 1.0 };
    }
    // Scale each face by its donor's factor (the same number seen from both sides).
    let wrap_x = field.edges.west == Edge::Periodic;
    let wrap_y = field.edges.south == Edge::Periodic;
    let mut outflow = 0.0;
    for j in 0..ny {
        for i in 0..=nx {
            let k = j * nfx + i;
            let q = s.fx[k];
            let donor = if q > 0.0 {
                if i > 0 {
                    Some(j * nx + i - 1)
                } else if wrap_x {
                    Some(j * nx + nx - 1)
                } else {
                    None
                }
            } else if i < nx {
                Some(j * nx + i)
            } else if wrap_x {
                Some(j * nx)
            } else {
                None
            };
            let q = match donor {
                Some(d) => q * s.out[d],
                None => 0.0,
            };
            s.fx[k] = q;
            if !wrap_x && ((i == 0 && q < 0.0) || (i == nx && q > 0.0)) {
                outflow += q.abs();
            }
            s.acc_x[k] += q;
        }
    }
    for j in 0..=ny {
        for i in 0..nx {
            let k = j * nx + i;
            let q = s.fy[k];
            let donor = if q > 0.0 {
                if j > 0 {
                    Some((j - 1) * nx + i)
                } else if wrap_y {
                    Some((ny - 1) * nx + i)
                } else {
                    None
                }
            } else if j < ny {
                Some(j * nx + i)
            } else if wrap_y {
                Some(i)
            } else {
                None
            };
            let q = match donor {
                Some(d) => q * s.out[d],
                None => 0.0,
            };
            s.fy[k] = q;
            if !wrap_y && ((j == 0 && q < 0.0) || (j == ny && q > 0.0)) {
                outflow += q.abs();
            }
            s.acc_y[k] += q;
        }
    }
    // Cell update: h' = h + (in − out)/A; heat h·T moves at the donor temperature.
    let mut rounding = 0.0;
    for j in 0..ny {
        let jm = if j > 0 { j - 1 } else { ny - 1 };
        let jp = if j + 1 < ny { j + 1 } else { 0 };
        for i in 0..nx {
            let k = j * nx + i;
            let im = if i > 0 { i - 1 } else { nx - 1 };
            let ip = if i + 1 < nx { i + 1 } else { 0 };
            // (face volume, +1 if positive means inflow, neighbour cell)
            let faces = [
                (s.fx[j * nfx + i], 1.0, j * nx + im),
                (s.fx[j * nfx + i + 1], -1.0, j * nx + ip),
                (s.fy[j * nx + i], 1.0, jm * nx + i),
                (s.fy[(j + 1) * nx + i], -1.0, jp * nx + i),
            ];
            let (mut vin, mut ein, mut vout) = (0.0, 0.0, 0.0);
            for (q, sign, nb) in faces {
                let v = q * sign;
                if v > 0.0 {
                    vin += v;
                    ein += v * t[nb];
                } else {
                    vout -= v;
                }
            }
            let mut hn = h[k] + (vin - vout) / area;
            if hn < 0.0 {
                rounding -= hn * area;
                hn = 0.0;
            }
            let remain = (h[k] - vout / area).max(0.0);
            s.t_new[k] = if hn > 0.0 { (remain * t[k] + ein / area) / hn } else { t[k] };
            s.h_new[k] = hn;
        }
    }
    field.h.data_mut().copy_from_slice(&s.h_new);
    field.temp.data_mut().copy_from_slice(&s.t_new);
    field.budget.rounding += rounding;
    outflow
}
