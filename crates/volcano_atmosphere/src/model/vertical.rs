//! Exchanges between layers (thesis §4.2.4.2): convection from moist static energy (4.5),
//! non-convective uplift, the vertical velocity `D_i = C_i + U_i`, transfers (4.6) of
//! amounts and precipitation.
//!
//! Readings (documented deviations from the printed text):
//! - Convection uses the *horizontal anomaly* of the MSE difference between a layer and the
//!   one above: `C_i = λ σ_i [(MSE_i − MSE_{i+1}) − ⟨MSE_i − MSE_{i+1}⟩_σ]`. The printed
//!   `λ (MSE_{i+1} − MSE_i)` is ≈ +3 kJ/kg per km in any stable atmosphere, i.e. a uniform
//!   ≈ 1.6 m/s vertical wind over the whole domain that a torus cannot supply (the net
//!   divergence must vanish) and that no observed skyscape has. With the anomaly, air rises
//!   where the lower layer holds more energy than elsewhere (warm, moist), as in Fig 4.6.
//!   The anomaly is *mass-weighted*: the mean ⟨·⟩_σ weights each cell by its free fraction
//!   σ_i (the air it holds), and the drive is scaled by σ_i, the share of the slab the
//!   anomalous air fills. In parcel theory the kinetic energy a buoyant parcel gains is its
//!   buoyancy integrated over the depth it is buoyant through (`w²/2 = ∫ B dz`, the CAPE of
//!   e.g. Emanuel 1994, *Atmospheric Convection*); linearised, the drive of the flow through
//!   a layer's top grows with the depth of anomalous air below it. A terrain sliver (a few
//!   metres of air that follow the ground) is then a small mass anomaly, not a full-slab one:
//!   without the weight, a night-cooled sliver on a slope pulls air down at several m/s.
//! - Non-convective uplift: the printed `U_i = ν (P_{i+1} − P_i)` feeds back through the
//!   continuity projection (the convergence under a rising column lowers P, which changes U,
//!   which changes the target): on the torus the loop gain exceeds 1 for the largest modes and
//!   in our tests D oscillates until a bound stops it. We keep the mechanism of Fig 4.4 — wind
//!   meeting a slope is deflected upward — in the standard kinematic form of upslope models (Smith
//!   1979): `U_i = ν (V_i · ∇Θ_T) exp(−max(0, Θ_top,i − Θ_T) / H_o)`, the terrain-following
//!   vertical wind of layer i at its top boundary, fading with height above the ground over
//!   `H_o`. Windward (V·∇Θ_T > 0): up; lee: down. ν is dimensionless here.
//! - No bound on D (a volcanic plume's updraft is tens of m/s; a ±2 m/s clamp would make its
//!   cap cloud a trace). The stable scheme is the printed exponential of
//!   (4.6) applied to the velocity: the stored D is the *realised* velocity
//!   `D = sign(D_raw) · V (1 − exp(−|D_raw| Δt / V)) / Δt` ([`realised_velocity`]) with
//!   `D_raw = C + U` and `V` the thinner of the two free columns `σ h` of the pair. It is
//!   ≈ `D_raw` while `|D_raw| Δt ≪ V` and never moves more than `V` per step: the source cannot
//!   give more than it holds (positivity, the vertical CFL of an upwind scheme), and a thin
//!   destination (a layer mostly cut by a slope) is not filled with several times its own
//!   volume before the horizontal wind can carry the excess away (monotonicity: without this,
//!   air pushed into a 10–80 m wedge multiplies its humidity six-fold and more, its MSE runs
//!   away and `D_raw` reaches 368 m/s). The transfer then moves exactly `|D| Δt`, the volume the
//!   projection's continuity target asks the horizontal wind to supply. Cells where the
//!   exponential takes more than 10 % off `D_raw` are counted as limited in
//!   [`VerticalReport`] (and the step report and run summary), with the largest `|D_raw|`.
//! - Transfers (4.6) move *amounts* (concentration × free volume), docs/physics/atmosphere.md §5.3:
//!   the moved air volume per m² is `|D| Δt` of the source's concentration. H, W and ash move
//!   with the air (conserved exactly); temperature mixes as potential temperature into the
//!   destination (rising air cools adiabatically).
//! - Pressure coupling (4.7), `P_i ← P_i + μ D_i`, is not applied: P is re-solved from the
//!   wind every step, so an increment would only change the multigrid's starting guess. Its
//!   purpose (vertical motion acting on the horizontal flow) is served by the continuity
//!   target of the projection (docs/physics/atmosphere.md §5.3), see [`divergence_target`].

use bevy::reflect::Reflect;
use serde::Serialize;
use volcano_core::parallel;

use super::fields::LayerFields;
use super::params::AtmosphereParams;
use super::thermo::{exner, moist_static_energy};

/// What [`vertical_velocity`] found: the realised speeds and the limiter.
#[derive(Debug, Clone, Copy, PartialEq, Default, Reflect, Serialize)]
pub struct VerticalReport {
    /// max |D| realised (m/s).
    pub max_speed: f64,
    /// max |D_raw| = |C + U| before the exponential of (4.6) (m/s): what D would be without
    /// a limit.
    pub max_unlimited_speed: f64,
    /// Limiter: cells (summed over interfaces) where the exponential took more than 10 % off
    /// `D_raw` (the step is long for the updraft there), or where `D_raw` was not finite (D
    /// set to 0).
    pub limited_cells: u64,
}

impl VerticalReport {
    fn merge(self, o: Self) -> Self {
        Self {
            max_speed: self.max_speed.max(o.max_speed),
            max_unlimited_speed: self.max_unlimited_speed.max(o.max_unlimited_speed),
            limited_cells: self.limited_cells + o.limited_cells,
        }
    }
}

/// Realised vertical velocity (m/s) over a step `dt` for `d_raw = C + U` through an
/// interface whose thinner free column is `column` m: the exponential of eq. (4.6) with the
/// free column in place of ΔΘ_i, `sign(D) · V (1 − exp(−|D_raw| Δt / V)) / Δt` — ≈ `D_raw`
/// while `|D_raw| Δt ≪ V`, never more than that column per step. Zero for a closed interface
/// or a non-finite `d_raw`.
pub fn realised_velocity(d_raw: f64, column: f64, dt: f64) -> f64 {
    if !d_raw.is_finite() || d_raw == 0.0 || column <= 0.0 || dt <= 0.0 {
        return 0.0;
    }
    -(-d_raw.abs() * dt / column).exp_m1() * column / dt * d_raw.signum()
}

/// Computes `C_i`, `U_i` and the realised `D_i` (see [`realised_velocity`]) at the top of each
/// layer for a step of `dt` s (zero for the top layer and where either layer of a pair is
/// blocked by terrain). `terrain` holds Θ_T at the cell centres (cell size `dx`).
pub fn vertical_velocity(
    layers: &mut [LayerFields],
    terrain: &[f32],
    dx: f64,
    params: &AtmosphereParams,
    dt: f64,
) -> VerticalReport {
    vertical_velocity_in(layers, terrain, dx, params, dt, &mut VerticalWork::default())
}

/// Scratch of [`vertical_velocity_in`] (kept between steps: no allocation per step).
#[derive(Debug, Clone, Default)]
pub struct VerticalWork {
    /// Terrain gradient per cell.
    grad: Vec<(f64, f64)>,
    /// MSE of the lower layer of the current pair, then the pair's MSE difference.
    lower: Vec<f64>,
    /// MSE of the upper layer of the current pair (the lower one of the next).
    upper: Vec<f64>,
}

/// Moist static energy (4.5) of every cell of `layer` with air (σ > 0; 0 elsewhere) into `out`.
fn layer_mse(layer: &LayerFields, n: usize, out: &mut [f64]) {
    let (t, h, sigma) = (layer.t.data(), layer.h.data(), layer.sigma.data());
    parallel::for_each_row(out, n, |j, row| {
        for (i, x) in row.iter_mut().enumerate() {
            let k = j * n + i;
            *x = if sigma[k] > 0.0 {
                moist_static_energy(t[k] as f64, layer.altitude, h[k], layer.pi)
            } else {
                0.0
            };
        }
    });
}

/// [`vertical_velocity`] with its scratch buffers given. Each layer's MSE is evaluated once
/// (as the upper layer of one pair and the lower of the next), the same values as evaluating
/// it for both pairs.
pub fn vertical_velocity_in(
    layers: &mut [LayerFields],
    terrain: &[f32],
    dx: f64,
    params: &AtmosphereParams,
    dt: f64,
    work: &mut VerticalWork,
) -> VerticalReport {
    let nl = layers.len();
    let mut report = VerticalReport::default();
    let cells = terrain.len();
    let n = (cells as f64).sqrt() as usize;
    // Terrain gradient (central differences, toroidal).
    let mask = n.wrapping_sub(1);
    let VerticalWork { grad, lower, upper } = work;
    grad.resize(cells, (0.0, 0.0));
    parallel::for_each_row(grad.as_mut_slice(), n, |j, row| {
        for (i, g) in row.iter_mut().enumerate() {
            let gx = (terrain[j * n + ((i + 1) & mask)] - terrain[j * n + ((i + n - 1) & mask)]) as f64;
            let gy = (terrain[((j + 1) & mask) * n + i] - terrain[((j + n - 1) & mask) * n + i]) as f64;
            *g = (gx / (2.0 * dx), gy / (2.0 * dx));
        }
    });
    let grad = &grad[..];
    if nl > 1 {
        lower.resize(cells, 0.0);
        upper.resize(cells, 0.0);
        layer_mse(&layers[0], n, lower);
    }
    for i in 0..nl {
        if i + 1 == nl {
            let top = &mut layers[i];
            top.c.data_mut().fill(0.0);
            top.up.data_mut().fill(0.0);
            top.d.data_mut().fill(0.0);
            continue;
        }
        layer_mse(&layers[i + 1], n, upper);
        let (lo, hi) = layers.split_at_mut(i + 1);
        let (a, b) = (&mut lo[i], &hi[0]);
        let open = |k: usize| a.sigma.data()[k] > 0.0 && b.sigma.data()[k] > 0.0;
        // MSE difference per cell (f64, 0 where closed), its mass-weighted (σ) mean over open
        // cells.
        {
            let upper = &upper[..];
            parallel::for_each_row(lower.as_mut_slice(), n, |j, row| {
                for (i, x) in row.iter_mut().enumerate() {
                    let k = j * n + i;
                    *x = if open(k) { *x - upper[k] } else { 0.0 };
                }
            });
        }
        let diff = &lower[..];
        let (sum, mass) = (0..cells).filter(|&k| open(k)).fold((0.0, 0.0), |(s, m), k| {
            let w = a.sigma.data()[k] as f64;
            (s + w * diff[k], m + w)
        });
        let mean = if mass > 0.0 { sum / mass } else { 0.0 };
        let top = a.bottom + a.thickness;
        let (ha, hb) = (a.thickness, b.thickness);
        let (bs, coupling, decay) = (b.sigma.data(), params.convective_coupling, params.orographic_decay_m);
        let LayerFields { c, up, d, u, v, sigma, .. } = a;
        let (u, v, sa) = (u.data(), v.data(), sigma.data());
        // Rows in parallel; maxima and counts are order-independent (and folded in row order).
        let rows = parallel::map_rows((c.data_mut(), up.data_mut(), d.data_mut()), n, |jj, (cr, ur, dr)| {
            let mut m = VerticalReport::default();
            for ii in 0..n {
                let k = jj * n + ii;
                if !(sa[k] > 0.0 && bs[k] > 0.0) {
                    (cr[ii], ur[ii], dr[ii]) = (0.0, 0.0, 0.0);
                    continue;
                }
                let conv = coupling * sa[k] as f64 * (diff[k] - mean);
                let (gx, gy) = grad[k];
                let lift = if gx == 0.0 && gy == 0.0 {
                    0.0
                } else {
                    let uc = 0.5 * (u[k] + u[jj * n + ((ii + 1) & mask)]) as f64;
                    let vc = 0.5 * (v[k] + v[((jj + 1) & mask) * n + ii]) as f64;
                    let above = (top - terrain[k] as f64).max(0.0);
                    params.uplift_coupling * (uc * gx + vc * gy) * (-above / decay).exp()
                };
                let raw = conv + lift;
                // At most the thinner of the two free columns per step.
                let column = (sa[k] as f64 * ha).min(bs[k] as f64 * hb);
                let dk = realised_velocity(raw, column, dt);
                let finite = raw.is_finite();
                (cr[ii], ur[ii], dr[ii]) =
                    if finite { (conv as f32, lift as f32, dk as f32) } else { (0.0, 0.0, 0.0) };
                m.max_speed = m.max_speed.max(dk.abs());
                if finite {
                    m.max_unlimited_speed = m.max_unlimited_speed.max(raw.abs());
                }
                m.limited_cells += (!finite || dk.abs() < 0.9 * raw.abs()) as u64;
            }
            m
        })
        .into_iter()
        .fold(VerticalReport::default(), VerticalReport::merge);
        report = report.merge(rows);
        std::mem::swap(lower, upper);
    }
    report
}

/// Transfers of eq. (4.6) across every interface, bottom to top, driven by the realised `D`
/// of [`vertical_velocity`]: `|D| Δt` of air per m² (never more than the source's free column).
/// Columns are independent, so rows run in parallel.
pub fn transfer(layers: &mut [LayerFields], dt: f64) {
    let nl = layers.len();
    for i in 0..nl.saturating_sub(1) {
        let (lo, hi) = layers.split_at_mut(i + 1);
        let (a, b) = (&mut lo[i], &mut hi[0]);
        let n = a.t.nx();
        let (ex_a, ex_b) = (exner(a.pi), exner(b.pi));
        let (ha, hb) = (a.thickness, b.thickness);
        let (d, sa, sb) = (a.d.data(), a.sigma.data(), b.sigma.data());
        // Air leaving an entraining column's cell (LayerFields::entraining), up or down, carries
        // the temperature of the air around the column: the column's heat rises in its slices,
        // which impose it wherever they are, so the layers must not move it a second time (down
        // beside the column, or up above its top, where no slice holds the cells). Its water
        // does move: the cap cloud (docs/ARCHITECTURE.md §1.4).
        let sorted = |cells: &[(u32, f32)]| {
            let mut v = cells.to_vec();
            v.sort_unstable_by_key(|c| c.0);
            v
        };
        let (held_a, held_b) = (sorted(&a.entraining), sorted(&b.entraining));
        let outside = |held: &[(u32, f32)], k: usize| {
            held.binary_search_by_key(&(k as u32), |c| c.0).ok().map(|i| held[i].1)
        };
        let rows = (
            a.t.data_mut(),
            a.h.data_mut(),
            a.w.data_mut(),
            a.ash.data_mut(),
            b.t.data_mut(),
            b.h.data_mut(),
            b.w.data_mut(),
            b.ash.data_mut(),
        );
        parallel::for_each_row(rows, n, |j, (at, ah, aw, aa, bt, bh, bw, ba)| {
            for x in 0..n {
                let k = j * n + x;
                let dk = d[k] as f64;
                let (sak, sbk) = (sa[k] as f64, sb[k] as f64);
                if dk == 0.0 || sak <= 0.0 || sbk <= 0.0 {
                    continue;
                }
                let (va, vb) = (sak * ha, sbk * hb);
                let up = dk > 0.0;
                let (vs, vd, exs, exd) = if up { (va, vb, ex_a, ex_b) } else { (vb, va, ex_b, ex_a) };
                let moved = (dk.abs() * dt).min(vs);
                let carry = |qa: &mut f64, qb: &mut f64| {
                    let (qs, qd) = if up { (qa, qb) } else { (qb, qa) };
                    let m = *qs * moved;
                    *qs = (*qs - m / vs).max(0.0);
                    *qd += m / vd;
                };
                carry(&mut ah[x], &mut bh[x]);
                carry(&mut aw[x], &mut bw[x]);
                carry(&mut aa[x], &mut ba[x]);
                let (ts, td) = if up {
                    (outside(&held_a, k).unwrap_or(at[x]), &mut bt[x])
                } else {
                    (outside(&held_b, k).unwrap_or(bt[x]), &mut at[x])
                };
                let th_s = ts as f64 / exs;
                let th_d = *td as f64 / exd;
                let th = th_d + (th_s - th_d) * (moved / vd).min(1.0);
                *td = (th * exd) as f32;
            }
        });
    }
}

/// Precipitation: condensed water above `threshold` (g/m³) falls to the ground of the same
/// column at `rate` (1/s, integrated exactly over the step). Adds to `ground_water` (g/m²) and
/// returns the grams precipitated (cell area `area` m²).
pub fn precipitate(
    layers: &mut [LayerFields],
    ground_water: &mut [f64],
    threshold: f64,
    rate: f64,
    dt: f64,
    area: f64,
) -> f64 {
    let frac = 1.0 - (-rate * dt).exp();
    let mut total = 0.0;
    for layer in layers.iter_mut() {
        let h = layer.thickness;
        let sigma = layer.sigma.data();
        for (k, w) in layer.w.data_mut().iter_mut().enumerate() {
            let excess = (*w - threshold).max(0.0) * frac;
            if excess > 0.0 && sigma[k] > 0.0 {
                *w -= excess;
                let grams_m2 = excess * sigma[k] as f64 * h;
                ground_water[k] += grams_m2;
                total += grams_m2 * area;
            }
        }
    }
    total
}

/// Divergence targets of the projection (docs/physics/atmosphere.md §5.3, continuity):
/// `−(D_i − D_{i−1}) / h_i` with `D_{−1} = 0` (ground) and the top layer's `D = 0` (lid).
pub fn divergence_target(layers: &[LayerFields], i: usize, out: &mut [f64]) {
    let layer = &layers[i];
    let inv_h = 1.0 / layer.thickness;
    let d = layer.d.data();
    match i.checked_sub(1).map(|b| layers[b].d.data()) {
        Some(db) => out.iter_mut().enumerate().for_each(|(k, o)| *o = -(d[k] as f64 - db[k] as f64) * inv_h),
        None => out.iter_mut().enumerate().for_each(|(k, o)| *o = -(d[k] as f64) * inv_h),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::fields::{GridSpec, LayerFields, layer_geometry};

    fn two_layers(n: usize) -> Vec<LayerFields> {
        let g = GridSpec::new(n, 100.0).unwrap();
        let geo = layer_geometry(&[500.0, 1500.0]).unwrap();
        vec![
            LayerFields::new(g, 500.0, geo[0].0, geo[0].1, 285.0),
            LayerFields::new(g, 1500.0, geo[1].0, geo[1].1, 278.5),
        ]
    }

    #[test]
    fn warm_spot_rises_and_transfers_conserve_amounts() {
        let n = 16;
        let mut layers = two_layers(n);
        layers[0].t.data_mut()[5] += 8.0;
        layers[0].h.data_mut().fill(8.0);
        layers[1].h.data_mut().fill(2.0);
        let p = AtmosphereParams::default();
        let rep = vertical_velocity(&mut layers, &vec![0.0; 256], 100.0, &p, 30.0);
        assert!(layers[0].d.data()[5] > 0.5, "{}", layers[0].d.data()[5]);
        assert!(layers[0].d.data()[6] < 0.0 && layers[0].d.data()[6] > -0.1);
        assert!(rep.max_speed > 0.5);
        assert_eq!(rep.limited_cells, 0, "an 8 K anomaly is far from the vertical CFL: {rep:?}");
        let water = |l: &[LayerFields]| l.iter().map(|l| l.water_grams(100.0)).sum::<f64>();
        let before = water(&layers);
        let t_up = layers[1].t.data()[5];
        transfer(&mut layers, 30.0);
        assert!(((water(&layers) - before) / before).abs() < 1e-14);
        assert!(layers[1].h.data()[5] > 2.0, "moisture carried up");
        assert!(layers[1].t.data()[5] > t_up, "warm air warms the layer above");
        // Every column with D < 0 moved some water down, nothing negative.
        assert!(layers.iter().all(|l| l.h.data().iter().all(|&h| h >= 0.0)));
    }

    /// Ash in the air (the coupling's tracer) rides the transfers (4.6) exactly as moisture
    /// does: given the same shape as the humidity in both layers, it keeps that shape cell by
    /// cell after an updraft over a warm spot and the compensating subsidence around it, it
    /// goes up over the spot, and not a gram is made or lost.
    #[test]
    fn ash_rides_the_vertical_transfers_like_moisture() {
        let n = 16;
        let mut layers = two_layers(n);
        layers[0].t.data_mut()[5] += 8.0;
        layers[0].t.data_mut()[200] -= 4.0;
        for (i, l) in layers.iter_mut().enumerate() {
            let base = [8.0, 2.0][i];
            for (k, (h, a)) in l.h.data_mut().iter_mut().zip(l.ash.data_mut().iter_mut()).enumerate() {
                *h = base * (1.0 + 0.3 * ((k as f64) * 0.7).sin());
                *a = 0.05 * *h;
            }
        }
        let p = AtmosphereParams::default();
        vertical_velocity(&mut layers, &vec![0.0; n * n], 100.0, &p, 30.0);
        let (d5, lowest) =
            (layers[0].d.data()[5], layers[0].d.data().iter().copied().fold(f32::MAX, f32::min));
        assert!(d5 > 0.5 && lowest < -0.1, "an updraft ({d5} m/s) and downdrafts ({lowest} m/s)");
        let total = |l: &[LayerFields]| -> f64 {
            l.iter()
                .map(|l| {
                    l.ash
                        .data()
                        .iter()
                        .zip(l.sigma.data())
                        .map(|(a, s)| a * *s as f64 * l.thickness)
                        .sum::<f64>()
                })
                .sum()
        };
        let (before, up_before) = (total(&layers), layers[1].ash.data()[5]);
        transfer(&mut layers, 30.0);
        assert!(((total(&layers) - before) / before).abs() < 1e-14, "ash made or lost");
        assert!(layers[1].ash.data()[5] > 1.01 * up_before, "ash carried up over the warm spot");
        for l in &layers {
            for (a, h) in l.ash.data().iter().zip(l.h.data()) {
                assert!((a - 0.05 * *h).abs() < 1e-5 * a.abs().max(1e-9), "ash {a} vs moisture {h}");
            }
        }
    }

    /// A sliver of cold air (2 % of the slab, as where a slope cuts the layer) is a small mass
    /// anomaly: it pulls air down far less than a full column with the same anomaly.
    #[test]
    fn a_cold_sliver_is_a_small_mass_anomaly() {
        let mut layers = two_layers(16);
        layers[0].t.data_mut()[5] -= 10.0;
        layers[0].t.data_mut()[9] -= 10.0;
        layers[0].sigma.data_mut()[9] = 0.02;
        let p = AtmosphereParams::default();
        vertical_velocity(&mut layers, &vec![0.0; 256], 100.0, &p, 30.0);
        let (full, sliver) = (layers[0].c.data()[5], layers[0].c.data()[9]);
        assert!(full < -0.5, "a 10 K colder column sinks: {full} m/s");
        assert!(
            sliver < 0.0 && sliver.abs() < 0.05 * full.abs(),
            "sliver {sliver} vs full column {full} m/s"
        );
    }

    /// The realised velocity is the exponential of (4.6): linear for short steps, at most the
    /// thinner column per step for long ones, zero for non-finite input; and the transfer
    /// moves exactly |D| Δt of the source's air.
    #[test]
    fn realised_velocity_saturates_at_the_thinner_column() {
        assert!((realised_velocity(1.0, 1000.0, 1.0) - 1.0).abs() < 1e-3);
        assert!((realised_velocity(-1.0, 1000.0, 1.0) + 1.0).abs() < 1e-3);
        // 100 m/s for 30 s through a 1,000 m column: (1 − e^{−3}) of it, 31.7 m/s, not 100.
        let d = realised_velocity(100.0, 1000.0, 30.0);
        assert!(d > 31.0 && d < 32.0, "{d}");
        assert!(realised_velocity(1e6, 50.0, 30.0) <= 50.0 / 30.0);
        assert_eq!(realised_velocity(5.0, 0.0, 30.0), 0.0);
        assert_eq!(realised_velocity(f64::NAN, 100.0, 30.0), 0.0);
        assert_eq!(realised_velocity(f64::INFINITY, 100.0, 30.0), 0.0);
    }

    /// A volcanic plume's hot, moist spot under a layer: D far above 2 m/s, the limiter
    /// reported, and the transfer moves |D| Δt of air.
    #[test]
    fn a_hot_moist_spot_drives_an_updraft_far_above_two_m_s() {
        let mut layers = two_layers(16);
        layers[0].t.data_mut()[5] += 300.0;
        layers[0].h.data_mut()[5] = 20.0;
        let p = AtmosphereParams::default();
        let rep = vertical_velocity(&mut layers, &vec![0.0; 256], 100.0, &p, 30.0);
        let d = layers[0].d.data()[5] as f64;
        eprintln!("D {d} m/s, {rep:?}");
        assert!(d > 10.0 && d < rep.max_unlimited_speed, "{rep:?}");
        assert_eq!(rep.limited_cells, 1, "{rep:?}");
        let before = layers[0].h.data()[5] * layers[0].thickness;
        transfer(&mut layers, 30.0);
        let moved = before - layers[0].h.data()[5] * layers[0].thickness;
        assert!((moved - 20.0 * d * 30.0).abs() < 1e-4 * moved, "moved {moved} g/m² for D = {d}");
    }

    #[test]
    fn precipitation_moves_excess_to_the_ground() {
        let mut layers = two_layers(16);
        layers[1].w.data_mut()[3] = 3.0;
        let mut ground = vec![0.0; 256];
        let got = precipitate(&mut layers, &mut ground, 1.0, 1e-3, 1e4, 1e4);
        let fell = 2.0 * (1.0 - (-10.0f64).exp());
        assert!((layers[1].w.data()[3] - (3.0 - fell)).abs() < 1e-12);
        assert!((ground[3] - fell * layers[1].thickness).abs() < 1e-9);
        assert!((got - ground[3] * 1e4).abs() < 1e-6);
    }
}
