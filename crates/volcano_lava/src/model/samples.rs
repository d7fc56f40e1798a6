//! Lagrangian surface samples (thesis §5.4.2, last paragraph): "to obtain more accurate
//! measurements of the crust thickness, we use Lagrangian particle samples that are advected
//! along the surface velocity field [...] we track the time since the emission of these
//! particles, and use it to compute the crust thickness where each one of them is, and finally
//! compute a mean in each cell of the grid."
//!
//! Each sample carries its own contact time and crust thickness and moves with the surface
//! velocity, so crust is transported without the numerical diffusion of the grid's upwind
//! advection. Per step a sample gets the same physics as a cell (eqs 5.1 and 5.3, the reset
//! and no-crust rules) with the divergence and lava thickness of the cell it is in; then every
//! cell that holds samples takes their mean. Wet cells with no sample get one, initialised from
//! the cell; dry or off-grid samples are removed; a cell keeps at most `2 × max_per_cell`
//! (twice: samples one cell apart that cross cell edges a step apart, by the rounding of their
//! positions, would otherwise find their next cell still full and drop one another; the cell
//! they left would be re-seeded from the grid, and on a translating sheet this would replace
//! carried crust by stale crust over whole stretches, 4 % too thick where the crust varies 1 %
//! a cell).

use bevy::math::DVec2;

use super::bands::BAND_ROWS;
use super::crust::{
    DIVERGENCE_MIN_CRUST, MOVING_SPEED, NO_CRUST_BELOW, contact_from_crust, crust_from_contact, exp_small,
};
use super::field::FlowField;
use super::params::LavaParams;
use volcano_core::parallel::par_map;

/// One surface sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSample {
    /// Position in cell units (cell `(i, j)` spans `[i, i+1) × [j, j+1)`).
    pub pos: DVec2,
    /// Time of contact with the air (s).
    pub contact: f64,
    /// Crust thickness (m).
    pub crust: f64,
}

/// The samples of one field, with per-cell scratch.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SurfaceSamples {
    /// Live samples, in a deterministic order (creation order, compacted).
    pub samples: Vec<SurfaceSample>,
    count: Vec<u32>,
    sum: Vec<[f64; 2]>,
    cells: Vec<u32>,
    /// Calls since the last update and the time they covered.
    pending: (u32, f64),
}

/// Samples per parallel task.
const SAMPLE_CHUNK: usize = 16_384;

/// How many samples ahead the sample loops prefetch the grid cells they will read.
const AHEAD: usize = 16;

/// Asks the CPU to bring the cache line of `a[k]` into its caches, if `k` is in bounds: a
/// hint that changes no result.
#[inline(always)]
fn prefetch<T>(a: &[T], k: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(x) = a.get(k)
        && std::arch::is_x86_feature_detected!("sse")
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: `_mm_prefetch` needs SSE, checked just above (every x86-64 CPU has it, so
        // the check is decided at compile time); a prefetch reads nothing and never faults,
        // and the pointer is in bounds anyway.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (a, k);
}

/// What the surface layer hands to [`update_samples`] (per-cell arrays, row-major).
pub struct CellSurface<'a> {
    /// Surface velocity (m/s), x and y.
    pub vsurf: [&'a [f64]; 2],
    /// Divergence of the surface velocity (1/s).
    pub divergence: &'a [f64],
    /// Crust (m) and contact time (s) from the grid update; overwritten where samples are.
    pub crust: &'a mut [f64],
    /// See `crust`.
    pub contact: &'a mut [f64],
}

/// Advances the samples by `dt` (accumulated over `params.surface_sample_every` calls), then
/// writes their per-cell means into `cells` (see the module doc). `max_per_cell` = 0 disables
/// the samples (and drops any).
pub fn update_samples(
    s: &mut SurfaceSamples,
    field: &FlowField,
    params: &LavaParams,
    cells: CellSurface,
    dt: f64,
    max_per_cell: u32,
) {
    let (nx, ny, dx) = (field.nx(), field.ny(), field.cell());
    let n = nx * ny;
    if max_per_cell == 0 || cells.crust.len() != n || !(dt.is_finite() && dt > 0.0) {
        s.samples.clear();
        s.pending = (0, 0.0);
        return;
    }
    // Every `surface_sample_every` calls, with the time elapsed since the last update.
    s.pending = (s.pending.0 + 1, s.pending.1 + dt);
    if s.pending.0 < params.surface_sample_every.max(1) {
        return;
    }
    let dt = std::mem::take(&mut s.pending).1;
    let h = field.h.data();
    let min_h = params.min_thickness;
    let kappa = params.kappa();
    let four_kdt = 4.0 * kappa * dt;
    // Truncation is floor for non-negative values (and avoids a libm call per sample).
    let cell_of = |p: DVec2| -> Option<usize> {
        let (i, j) = (p.x as usize, p.y as usize);
        (p.x >= 0.0 && p.y >= 0.0 && i < nx && j < ny).then_some(j * nx + i)
    };
    // Bilinear surface velocity at a position in cell units (values at cell centres).
    let velocity = |p: DVec2| -> DVec2 {
        let g = (p - 0.5).clamp(DVec2::ZERO, DVec2::new((nx - 1) as f64, (ny - 1) as f64));
        let (i0, j0) = (g.x as usize, g.y as usize);
        let (i1, j1) = ((i0 + 1).min(nx - 1), (j0 + 1).min(ny - 1));
        let (tx, ty) = (g.x - i0 as f64, g.y - j0 as f64);
        let at = |a: &[f64]| {
            let lo = a[j0 * nx + i0] * (1.0 - tx) + a[j0 * nx + i1] * tx;
            let hi = a[j1 * nx + i0] * (1.0 - tx) + a[j1 * nx + i1] * tx;
            lo * (1.0 - ty) + hi * ty
        };
        DVec2::new(at(cells.vsurf[0]), at(cells.vsurf[1]))
    };
    s.count.clear();
    s.count.resize(n, 0);
    s.sum.clear();
    s.sum.resize(n, [0.0; 2]);
    // Advection and physics per sample in parallel (fixed chunks); each reports its cell, or
    // `u32::MAX` when it left the grid or the lava.
    s.cells.resize(s.samples.len(), 0);
    let items: Vec<_> = s.samples.chunks_mut(SAMPLE_CHUNK).zip(s.cells.chunks_mut(SAMPLE_CHUNK)).collect();
    // The samples' cells are scattered over grids larger than the caches: the cache lines a
    // sample will read (its velocity stencil, its cell's h and divergence) are requested
    // `AHEAD` samples early, from its position before the move (≪ 1 cell away).
    let fetch = |p: DVec2| {
        let g = (p - 0.5).max(DVec2::ZERO);
        let k0 = g.y as usize * nx + g.x as usize;
        for a in cells.vsurf {
            prefetch(a, k0);
            prefetch(a, k0 + nx);
        }
        let k = p.y.max(0.0) as usize * nx + p.x.max(0.0) as usize;
        prefetch(h, k);
        prefetch(cells.divergence, k);
    };
    par_map(items, |_, (samples, ks)| {
        for idx in 0..samples.len() {
            if let Some(ahead) = samples.get(idx + AHEAD) {
                fetch(ahead.pos);
            }
            let (smp, kk) = (&mut samples[idx], &mut ks[idx]);
            // Explicit Euler: a sample moves ≪ 1 cell per step (Courant ~10⁻²).
            smp.pos += velocity(smp.pos) * (dt / dx);
            *kk = u32::MAX;
            let Some(k) = cell_of(smp.pos) else { continue };
            let hk = h[k];
            if hk < min_h {
                continue;
            }
            *kk = k as u32;
            let (vx, vy) = (cells.vsurf[0][k], cells.vsurf[1][k]);
            if hk < NO_CRUST_BELOW && vx * vx + vy * vy > MOVING_SPEED * MOVING_SPEED {
                smp.crust = 0.0;
                smp.contact = 0.0;
                continue;
            }
            smp.contact += dt;
            let mut c = (smp.crust * smp.crust + four_kdt).sqrt();
            let div = cells.divergence[k];
            if c > DIVERGENCE_MIN_CRUST && div != 0.0 {
                c *= exp_small(-div * dt);
                if div > 0.0 && c < params.crust_reset_ratio * crust_from_contact(kappa, smp.contact) {
                    smp.contact = contact_from_crust(kappa, c);
                }
            }
            smp.crust = c.min(hk);
        }
    });
    // Binning in sample order (deterministic): drop the lost and the surplus, sum the rest.
    let (count, sum, ks) = (&mut s.count, &mut s.sum, &s.cells);
    let mut idx = 0;
    s.samples.retain(|smp| {
        let k = ks[idx] as usize;
        if let Some(&ka) = ks.get(idx + AHEAD) {
            prefetch(count, ka as usize);
            prefetch(sum, ka as usize);
        }
        idx += 1;
        if k == u32::MAX as usize || count[k] >= 2 * max_per_cell {
            return false;
        }
        count[k] += 1;
        sum[k][0] += smp.crust;
        sum[k][1] += smp.contact;
        true
    });
    // Cell means and new samples by row bands in parallel; the new samples are appended in
    // band order, so in cell order as a single loop would push them.
    let band = BAND_ROWS * nx;
    let items: Vec<_> = cells
        .crust
        .chunks_mut(band)
        .zip(cells.contact.chunks_mut(band))
        .zip(count.chunks(band).zip(sum.chunks(band)))
        .collect();
    let fresh = par_map(items, |b, ((crust, contact), (count, sum))| {
        let o = b * band;
        let mut fresh = Vec::new();
        for (l, ((c, t), (&n, sm))) in
            crust.iter_mut().zip(contact.iter_mut()).zip(count.iter().zip(sum)).enumerate()
        {
            let k = o + l;
            if n > 0 {
                let inv = 1.0 / n as f64;
                *c = sm[0] * inv;
                *t = sm[1] * inv;
            } else if h[k] >= min_h {
                // A wet cell with no sample gets one at its centre, from the grid's values.
                let (i, j) = (k % nx, k / nx);
                fresh.push(SurfaceSample {
                    pos: DVec2::new(i as f64 + 0.5, j as f64 + 0.5),
                    contact: *t,
                    crust: *c,
                });
            }
        }
        fresh
    });
    for f in fresh {
        s.samples.extend(f);
    }
}
