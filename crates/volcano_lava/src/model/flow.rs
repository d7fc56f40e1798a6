//! Layer 1, the flow: a mass-exact explicit finite-volume scheme for the lubrication
//! (Jeffreys) equation of a viscous sheet over a heightfield,
//! `∂h/∂t = ∇·(ρ g h³/(3η(T)) ∇s)`, `s = ground + h` (docs/physics/lava.md §6.1; the thesis
//! used a closed virtual-pipes simulator, §5.4, whose role this replaces).
//!
//! Per substep: (1) a flux per face from the surface gradient, with the face mobility the mean
//! of the two cells' `ρ g h³/(3η(T))` (none out of a dry donor; see `flux::face_flux`); (2) a stable
//! substep from the explicit diffusion and kinematic-wave limits; (3) each cell's outgoing
//! volume scaled so it never exceeds what the cell holds; (4) every face volume is subtracted
//! from its donor and added to its receiver as the same f64 number, so the total changes only
//! by round-off, and heat (h·T) moves with it at the donor temperature.
//!
//! The work runs in two passes over fixed row bands (see [`super::bands`]): mobilities and
//! fluxes, then the global substep, then limiter and cell update. Each band computes what it
//! needs of its neighbours' rows (mobility one row below, limiter one row each side) into the
//! work buffer of the thread that runs it (reused band after band, so it stays in that core's
//! cache) instead of waiting for a separate pass over the whole grid. The row loops of
//! both passes are in `flow_rows` (branch-free, vectorised, bit-identical on any CPU).

use super::field::{Edge, FlowField};

use std::cell::RefCell;

use super::bands::{BAND_ROWS, Simd, band_range, simd};
use super::flow_rows::{FluxCtx, UpdateCtx, UpdateOut, band_fluxes, band_update};
use super::flux::face_flux;
pub use super::flux::{bingham_factor, slope_factor};
use super::params::{GRAVITY, LavaParams};
use volcano_core::parallel::par_map;

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

/// Advances the lava thickness and temperature of `field` by `dt` seconds with as many
/// CFL-limited substeps as needed (at most `params.max_substeps`). Volume is conserved to
/// round-off: only open edges remove lava (booked as outflow). The velocity field is the
/// depth-averaged velocity of the last substep.
pub fn advance_flow(field: &mut FlowField, params: &LavaParams, dt: f64) -> FlowReport {
    let mut report = FlowReport::default();
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    let mut t_left = dt;
    let simd = simd();
    while t_left > 0.0 && report.substeps < params.max_substeps {
        report.substeps += 1;
        let s = &mut field.scratch;
        let c = FluxCtx {
            nx,
            ny,
            inv_dx: 1.0 / dx,
            yield_rg: params.yield_strength / (params.density * GRAVITY),
            rg3: params.density * GRAVITY / 3.0,
            viscosity: params.viscosity,
            edges: field.edges,
            g: field.ground.data(),
            h: field.h.data(),
            t: field.temp.data(),
            fac: &field.mob_factor,
        };
        // 1. mobilities and face fluxes (row bands in parallel; maxima are exact in any order).
        let (fy_rows, fy_north) = s.fy.split_at_mut(ny * nx);
        let mut north = Some(fy_north);
        let bands = ny.div_ceil(BAND_ROWS);
        let items: Vec<_> =
            s.fx.chunks_mut(BAND_ROWS * (nx + 1))
                .zip(fy_rows.chunks_mut(BAND_ROWS * nx))
                .enumerate()
                .map(|(b, (fx, fy))| (fx, fy, if b + 1 == bands { north.take() } else { None }))
                .collect();
        // The mobility rows of a band go to the work buffer of the thread that runs it.
        let limits = par_map(items, |b, (fx, fy, north)| {
            with_work((band_range(b, ny).len() + 1) * nx, |mob| band_fluxes(&c, b, mob, fx, fy, north, simd))
        });
        let (mut m_max, mut c_max) = (0.0f64, 0.0f64);
        for (m, w) in limits {
            m_max = m_max.max(m);
            c_max = c_max.max(w);
        }
        if c.edges.south == Edge::Periodic {
            for i in 0..nx {
                let (so, no) = (i, (ny - 1) * nx + i);
                let (q, m, w) = face_flux(
                    c.inv_dx,
                    c.yield_rg,
                    (c.g[no], c.h[no], c.mob(no)),
                    (c.g[so], c.h[so], c.mob(so)),
                );
                m_max = m_max.max(m);
                c_max = c_max.max(w);
                s.fy[i] = q;
                s.fy[ny * nx + i] = q;
            }
        }
        // 2. substep.
        let sub = substep(dx, (m_max, c_max), params, report.substeps, (t_left, dt));
        let (dt_s, scale) = (sub.dt, sub.face_volume);
        report.mobility_capped |= sub.capped;
        t_left = sub.left;
        let last = t_left == 0.0 || report.substeps == params.max_substeps;
        report.outflow += transfer(field, scale * dt_s, last, simd);
    }
    field.budget.outflow += report.outflow;
    field.time += dt;
    report
}

/// One substep's length and face volume factor, from [`substep`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Substep {
    /// Its length (s).
    pub dt: f64,
    /// Face length times the mobility cap (m): volume across a face = q · dt · this.
    pub face_volume: f64,
    /// Out of substeps: the mobility was capped to finish the step stably.
    pub capped: bool,
    /// Seconds of the step left after it (0 once within 10⁻¹² of the step's end).
    pub left: f64,
}

/// The stable substep of a flow with largest face mobility `m_max` and wave speed `c_max` on
/// cells of `dx` m, `t_left` seconds from the end of a step of `step` seconds, as substep
/// number `n`: the explicit diffusion limit `dx²/(4 D)` and the kinematic-wave limit `dx/c`,
/// times `cfl`. The last allowed substep (`max_substeps`) finishes the step and caps the
/// mobility instead.
pub(crate) fn substep(
    dx: f64,
    (m_max, c_max): (f64, f64),
    params: &LavaParams,
    n: u32,
    (t_left, step): (f64, f64),
) -> Substep {
    let mut stable = f64::INFINITY;
    if m_max > 0.0 {
        stable = stable.min(dx * dx / (4.0 * m_max));
    }
    if c_max > 0.0 {
        stable = stable.min(dx / c_max);
    }
    let dt = t_left.min(params.cfl * stable);
    let (dt, face_volume, capped) = if n == params.max_substeps && dt < t_left {
        (t_left, dx * (dt / t_left), true)
    } else {
        (dt, dx, false)
    };
    let mut left = t_left - dt;
    if left < 1e-12 * step {
        left = 0.0;
    }
    Substep { dt, face_volume, capped, left }
}

thread_local! {
    /// The work buffer of the bands a thread runs (their mobility or limiter rows): reused, so
    /// it stays in that core's cache instead of one buffer per band travelling through memory.
    static WORK: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// Runs `f` on this thread's work buffer, `len` long.
fn with_work<R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    WORK.with_borrow_mut(|w| {
        if w.len() < len {
            w.resize(len, 0.0);
        }
        f(&mut w[..len])
    })
}

/// Applies one substep's face fluxes (`vol` = face length × substep, so volume = q · vol) with
/// the positivity limiter; returns the volume that left through open edges. Each face volume
/// is `q · vol · lim[donor]`, computed by the same expression on both sides, so what one cell
/// loses its neighbour gains exactly.
fn transfer(field: &mut FlowField, vol: f64, write_velocity: bool, simd: Simd) -> f64 {
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    let area = dx * dx;
    let s = &mut field.scratch;
    let (h, t) = (field.h.data(), field.temp.data());
    let (fx, fy) = (&s.fx, &s.fy);
    // Cell update: h' = h + (in − out)/A; heat h·T moves at the donor temperature. Row bands
    // in parallel, each with the limiter of its rows and the rows on either side; the
    // round-off tally is summed in band order.
    let (hn, tn) = (s.h_new.data_mut(), s.t_new.data_mut());
    let (u, v) = field.vel.split_at_mut(1);
    let (u, v) = (u[0].data_mut(), v[0].data_mut());
    let band = BAND_ROWS * nx;
    let items: Vec<_> = hn
        .chunks_mut(band)
        .zip(tn.chunks_mut(band))
        .zip(u.chunks_mut(band).zip(v.chunks_mut(band)))
        .collect();
    let e = field.edges;
    let c = UpdateCtx { nx, ny, edges: e, fx, fy, h, t, vol, area, write_velocity };
    // The limiters of a band go to the work buffer of the thread that runs it.
    let tallies = par_map(items, |b, ((hn, tn), (u, v))| {
        with_work((band_range(b, ny).len() + 2) * nx, |lim| {
            band_update(&c, b, UpdateOut { lim, hn, tn, u, v }, simd)
        })
    });
    let rounding: f64 = tallies.iter().map(|t| t.rounding).sum();
    // Volume through open edges, in row order, then cell by cell along the south and north.
    let mut outflow = 0.0;
    for [w, east] in tallies.iter().flat_map(|t| &t.west_east) {
        if e.west == Edge::Open {
            outflow -= w;
        }
        if e.east == Edge::Open {
            outflow += east;
        }
    }
    let south: Vec<f64> = tallies.iter().flat_map(|t| &t.south).copied().collect();
    let north: Vec<f64> = tallies.iter().flat_map(|t| &t.north).copied().collect();
    for i in 0..nx {
        if e.south == Edge::Open {
            outflow -= south[i];
        }
        if e.north == Edge::Open {
            outflow += north[i];
        }
    }
    std::mem::swap(&mut field.h, &mut s.h_new);
    std::mem::swap(&mut field.temp, &mut s.t_new);
    field.budget.rounding += rounding;
    outflow
}
