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
use volcano_core::Grid2;

use super::bands::{BAND_ROWS, band_range, par_bands};
use super::params::{GRAVITY, LavaParams, ViscosityModel};

/// Reusable work arrays of one field (allocated once).
#[derive(Debug, Clone, PartialEq)]
pub struct Scratch {
    /// Cell mobility ρ g h³/(3η(T)) (m³/s per unit gradient).
    mob: Vec<f64>,
    /// x-face fluxes, `(nx+1) × ny` (m²/s, +x positive); face `i` is west of cell `i`.
    fx: Vec<f64>,
    /// y-face fluxes, `nx × (ny+1)`; face `j` is south of row `j`.
    fy: Vec<f64>,
    /// Per-cell limiter factor in [0, 1].
    lim: Vec<f64>,
    h_new: Grid2<f64>,
    t_new: Grid2<f64>,
}

impl Scratch {
    pub(crate) fn new(template: &Grid2<f64>) -> Self {
        let (nx, ny) = (template.nx(), template.ny());
        let n = nx * ny;
        Self {
            mob: vec![0.0; n],
            fx: vec![0.0; (nx + 1) * ny],
            fy: vec![0.0; nx * (ny + 1)],
            lim: vec![0.0; n],
            h_new: template.clone(),
            t_new: template.clone(),
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
    inv_dx: f64,
    yield_over_rho_g: f64,
    (ga, ha, ma): (f64, f64, f64),
    (gb, hb, mb): (f64, f64, f64),
) -> (f64, f64, f64) {
    let grad = ((gb + hb) - (ga + ha)) * inv_dx;
    let hd = if grad < 0.0 { ha } else { hb };
    if hd <= 0.0 || grad == 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let mut m = 0.5 * (ma + mb) * slope_factor((gb - ga) * inv_dx);
    if yield_over_rho_g > 0.0 {
        m *= bingham_factor(hd, yield_over_rho_g / grad.abs());
    }
    let q = -m * grad;
    // Kinematic wave speed ∂q/∂h ≈ 3q/h with the thickness that dominates the mobility.
    (q, m, 3.0 * q.abs() / ha.max(hb))
}

/// Advances the lava thickness and temperature of `field` by `dt` seconds with as many
/// CFL-limited substeps as needed (at most `params.max_substeps`). Volume is conserved to
/// round-off: only open edges remove lava (booked as outflow). The velocity field is the
/// depth-averaged velocity of the last substep.
pub fn advance_flow(field: &mut FlowField, params: &LavaParams, dt: f64) -> FlowReport {
    let mut report = FlowReport::default();
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    let yield_rg = params.yield_strength / (params.density * GRAVITY);
    let rg3 = params.density * GRAVITY / 3.0;
    let mut t_left = dt;
    while t_left > 0.0 && report.substeps < params.max_substeps {
        report.substeps += 1;
        let s = &mut field.scratch;
        let (g, h, t) = (field.ground.data(), field.h.data(), field.temp.data());
        // 1. cell mobility ρ g h³/(3η(T)), times the crust factor (row bands in parallel).
        let band = BAND_ROWS * nx;
        let mob_factor = &field.mob_factor;
        let viscosity = params.viscosity;
        let items: Vec<&mut [f64]> = s.mob.chunks_mut(band).collect();
        par_bands(items, |b, mob| {
            let o = b * band;
            let (h, t, fac) = (&h[o..o + mob.len()], &t[o..o + mob.len()], &mob_factor[o..o + mob.len()]);
            match viscosity {
                ViscosityModel::Constant(eta) => {
                    let c = rg3 / eta;
                    for ((m, &hk), &fk) in mob.iter_mut().zip(h).zip(fac) {
                        *m = c * fk * hk * hk * hk;
                    }
                }
                model => {
                    for (((m, &hk), &tk), &fk) in mob.iter_mut().zip(h).zip(t).zip(fac) {
                        *m = if hk > 0.0 { rg3 * fk / model.viscosity(tk) * hk * hk * hk } else { 0.0 };
                    }
                }
            }
        });
        // 2. face fluxes and stability limits (row bands in parallel; maxima are exact in any
        // order).
        let inv_dx = 1.0 / dx;
        let nfx = nx + 1;
        let mob = &s.mob;
        let cell = |k: usize| (g[k], h[k], mob[k]);
        let edges = field.edges;
        let items: Vec<&mut [f64]> = s.fx.chunks_mut(BAND_ROWS * nfx).collect();
        let x_limits = par_bands(items, |b, rows| {
            let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
            for (frow, j) in rows.chunks_mut(nfx).zip(band_range(b, ny)) {
                let row = j * nx;
                for (i, f) in frow.iter_mut().enumerate().take(nx).skip(1) {
                    let (q, m, c) = face_flux(inv_dx, yield_rg, cell(row + i - 1), cell(row + i));
                    *f = q;
                    m_max = m_max.max(m);
                    c_max = c_max.max(c);
                }
                let (w, e) = (row, row + nx - 1);
                let (q0, qn) = if edges.west == Edge::Periodic {
                    let (q, m, c) = face_flux(inv_dx, yield_rg, cell(e), cell(w));
                    m_max = m_max.max(m);
                    c_max = c_max.max(c);
                    (q, q)
                } else {
                    let (mm, cm) = (&mut m_max, &mut c_max);
                    let qw = open_flux(edges.west, inv_dx, yield_rg, w, w + 1, g, h, mob, mm, cm);
                    let inner = if nx > 1 { e - 1 } else { e };
                    let qe = open_flux(edges.east, inv_dx, yield_rg, e, inner, g, h, mob, mm, cm);
                    (-qw, qe)
                };
                frow[0] = q0;
                frow[nx] = qn;
            }
            (m_max, c_max)
        });
        // Interior y faces: face row j (1..ny) lies between cell rows j−1 and j.
        let interior = &mut s.fy[nx..ny * nx];
        let items: Vec<&mut [f64]> = interior.chunks_mut(BAND_ROWS * nx).collect();
        let y_limits = par_bands(items, |b, rows| {
            let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
            for (frow, j) in rows.chunks_mut(nx).zip(band_range(b, ny - 1).map(|r| r + 1)) {
                for (i, f) in frow.iter_mut().enumerate() {
                    let (q, m, c) = face_flux(inv_dx, yield_rg, cell((j - 1) * nx + i), cell(j * nx + i));
                    *f = q;
                    m_max = m_max.max(m);
                    c_max = c_max.max(c);
                }
            }
            (m_max, c_max)
        });
        let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
        for (m, c) in x_limits.into_iter().chain(y_limits) {
            m_max = m_max.max(m);
            c_max = c_max.max(c);
        }
        for i in 0..nx {
            let (so, no) = (i, (ny - 1) * nx + i);
            let (q0, qn) = if edges.south == Edge::Periodic {
                let (q, m, c) = face_flux(inv_dx, yield_rg, cell(no), cell(so));
                m_max = m_max.max(m);
                c_max = c_max.max(c);
                (q, q)
            } else {
                let (si, ni) = if ny > 1 { (so + nx, no - nx) } else { (so, no) };
                let qs = open_flux(edges.south, inv_dx, yield_rg, so, si, g, h, mob, &mut m_max, &mut c_max);
                let qn = open_flux(edges.north, inv_dx, yield_rg, no, ni, g, h, mob, &mut m_max, &mut c_max);
                (-qs, qn)
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
        t_left -= dt_s;
        if t_left < 1e-12 * dt {
            t_left = 0.0;
        }
        let last = t_left == 0.0 || report.substeps == params.max_substeps;
        report.outflow += transfer(field, scale * dt_s, last);
    }
    field.budget.outflow += report.outflow;
    field.time += dt;
    report
}

/// Flux (m²/s, positive = out of the grid) through an open edge next to cell `e`, whose
/// inward neighbour is `inner` (ground extrapolated linearly outside, same thickness: the
/// lava leaves at the ground slope, nothing comes in). Zero for walls.
#[allow(clippy::too_many_arguments)]
#[inline]
fn open_flux(
    edge: Edge,
    inv_dx: f64,
    yield_rg: f64,
    e: usize,
    inner: usize,
    g: &[f64],
    h: &[f64],
    mob: &[f64],
    m_max: &mut f64,
    c_max: &mut f64,
) -> f64 {
    if edge != Edge::Open {
        return 0.0;
    }
    let ghost = 2.0 * g[e] - g[inner];
    let (q, m, c) = face_flux(inv_dx, yield_rg, (g[e], h[e], mob[e]), (ghost, h[e], mob[e]));
    *m_max = m_max.max(m);
    *c_max = c_max.max(c);
    q.max(0.0)
}

/// Applies one substep's face fluxes (`vol` = face length × substep, so volume = q · vol) with
/// the positivity limiter; returns the volume that left through open edges. Each face volume
/// is `q · vol · lim[donor]`, computed by the same expression on both sides, so what one cell
/// loses its neighbour gains exactly.
fn transfer(field: &mut FlowField, vol: f64, write_velocity: bool) -> f64 {
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    let nfx = nx + 1;
    let area = dx * dx;
    let inv_area = 1.0 / area;
    let s = &mut field.scratch;
    let (h, t) = (field.h.data(), field.temp.data());
    let (fx, fy) = (&s.fx, &s.fy);
    // Limiter: a cell's outgoing volume never exceeds what it holds.
    let items: Vec<&mut [f64]> = s.lim.chunks_mut(BAND_ROWS * nx).collect();
    par_bands(items, |b, lim| {
        for (lrow, j) in lim.chunks_mut(nx).zip(band_range(b, ny)) {
            for (i, l) in lrow.iter_mut().enumerate() {
                let k = j * nx + i;
                let (w, e) = (fx[j * nfx + i], fx[j * nfx + i + 1]);
                let (so, no) = (fy[k], fy[k + nx]);
                let out = (e.max(0.0) - w.min(0.0) + no.max(0.0) - so.min(0.0)) * vol;
                let avail = h[k] * area;
                *l = if out > avail { avail / out } else { 1.0 };
            }
        }
    });
    let lim = &s.lim;
    // Cell update: h' = h + (in − out)/A; heat h·T moves at the donor temperature. Row bands
    // in parallel; the round-off tally is summed in band order.
    let (hn, tn) = (s.h_new.data_mut(), s.t_new.data_mut());
    let (u, v) = field.vel.split_at_mut(1);
    let (u, v) = (u[0].data_mut(), v[0].data_mut());
    let band = BAND_ROWS * nx;
    let items: Vec<_> = hn
        .chunks_mut(band)
        .zip(tn.chunks_mut(band))
        .zip(u.chunks_mut(band).zip(v.chunks_mut(band)))
        .collect();
    let tallies = par_bands(items, |b, ((hn, tn), (u, v))| {
        let mut rounding = 0.0;
        let o = b * band;
        for j in band_range(b, ny) {
            let jm = if j > 0 { j - 1 } else { ny - 1 };
            let jp = if j + 1 < ny { j + 1 } else { 0 };
            for i in 0..nx {
                let k = j * nx + i;
                let im = j * nx + if i > 0 { i - 1 } else { nx - 1 };
                let ip = j * nx + if i + 1 < nx { i + 1 } else { 0 };
                let (sm, sp) = (jm * nx + i, jp * nx + i);
                // Signed face volumes, +x / +y positive, each scaled by its donor's factor.
                let qw = fx[j * nfx + i] * vol;
                let qe = fx[j * nfx + i + 1] * vol;
                let qs = fy[k] * vol;
                let qn = fy[k + nx] * vol;
                let vw = qw * if qw > 0.0 { lim[im] } else { lim[k] };
                let ve = qe * if qe > 0.0 { lim[k] } else { lim[ip] };
                let vs = qs * if qs > 0.0 { lim[sm] } else { lim[k] };
                let vn = qn * if qn > 0.0 { lim[k] } else { lim[sp] };
                let vin = vw.max(0.0) - ve.min(0.0) + vs.max(0.0) - vn.min(0.0);
                let vout = ve.max(0.0) - vw.min(0.0) + vn.max(0.0) - vs.min(0.0);
                let ein =
                    vw.max(0.0) * t[im] - ve.min(0.0) * t[ip] + vs.max(0.0) * t[sm] - vn.min(0.0) * t[sp];
                let mut hk = h[k] + (vin - vout) * inv_area;
                if hk < 0.0 {
                    rounding -= hk * area;
                    hk = 0.0;
                }
                let remain = (h[k] - vout * inv_area).max(0.0);
                let l = k - o;
                tn[l] = if hk > 0.0 { (remain * t[k] + ein * inv_area) / hk } else { t[k] };
                hn[l] = hk;
                if write_velocity {
                    let ok = hk > 0.0;
                    u[l] = if ok { 0.5 * (vw + ve) / (vol * hk) } else { 0.0 };
                    v[l] = if ok { 0.5 * (vs + vn) / (vol * hk) } else { 0.0 };
                }
            }
        }
        rounding
    });
    let rounding: f64 = tallies.iter().sum();
    // Volume through open edges (same expressions as above).
    let mut outflow = 0.0;
    let e = field.edges;
    for j in 0..ny {
        let (w, east) = (j * nx, j * nx + nx - 1);
        if e.west == Edge::Open {
            outflow -= (fx[j * nfx] * vol * lim[w]).min(0.0);
        }
        if e.east == Edge::Open {
            outflow += (fx[j * nfx + nx] * vol * lim[east]).max(0.0);
        }
    }
    for i in 0..nx {
        if e.south == Edge::Open {
            outflow -= (fy[i] * vol * lim[i]).min(0.0);
        }
        if e.north == Edge::Open {
            outflow += (fy[ny * nx + i] * vol * lim[(ny - 1) * nx + i]).max(0.0);
        }
    }
    std::mem::swap(&mut field.h, &mut s.h_new);
    std::mem::swap(&mut field.temp, &mut s.t_new);
    field.budget.rounding += rounding;
    outflow
}
