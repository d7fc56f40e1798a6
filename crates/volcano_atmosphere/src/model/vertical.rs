//! Exchanges between layers (thesis §4.2.4.2): convection from moist static energy (4.5),
//! non-convective uplift, the vertical velocity `D_i = C_i + U_i`, transfers (4.6) of
//! amounts and precipitation.
//!
//! Readings (documented deviations from the printed text):
//! - Convection uses the *horizontal anomaly* of the MSE difference between a layer and the
//!   one above: `C_i = λ [(MSE_i − MSE_{i+1}) − ⟨MSE_i − MSE_{i+1}⟩]`. The printed
//!   `λ (MSE_{i+1} − MSE_i)` is ≈ +3 kJ/kg per km in any stable atmosphere, i.e. a uniform
//!   ≈ 1.6 m/s vertical wind over the whole domain that a torus cannot supply (the net
//!   divergence must vanish) and that no observed skyscape has. With the anomaly, air rises
//!   where the lower layer holds more energy than elsewhere (warm, moist), as in Fig 4.6.
//! - Non-convective uplift: the printed `U_i = ν (P_{i+1} − P_i)` feeds back through the
//!   continuity projection (the convergence under a rising column lowers P, which changes U,
//!   which changes the target): on the torus the loop gain exceeds 1 for the largest modes and
//!   D oscillated to its bound in our tests. We keep the mechanism of Fig 4.4 — wind meeting
//!   a slope is deflected upward — in the standard kinematic form of upslope models (Smith
//!   1979): `U_i = ν (V_i · ∇Θ_T) exp(−max(0, Θ_top,i − Θ_T) / H_o)`, the terrain-following
//!   vertical wind of layer i at its top boundary, fading with height above the ground over
//!   `H_o`. Windward (V·∇Θ_T > 0): up; lee: down. ν is dimensionless here.
//! - Transfers (4.6) move *amounts* (concentration × free volume), docs/ARCHITECTURE.md §5.3:
//!   the moved air volume per m² is `V_src (1 − exp(−|D| Δt / V_src))`, the printed exponential
//!   with the source's free air column `V_src = σ h` in place of `ΔΘ_i`: ≈ `|D| Δt` (what
//!   continuity moves) for small steps, never more than the source holds, and consistent with
//!   the horizontal inflow of partly blocked cells. H, W and ash move with the air (conserved
//!   exactly); temperature mixes as potential temperature into the destination (rising air
//!   cools adiabatically).
//! - Pressure coupling (4.7), `P_i ← P_i + μ D_i`, is not applied: P is re-solved from the
//!   wind every step, so an increment would only change the multigrid's starting guess. Its
//!   purpose (vertical motion acting on the horizontal flow) is served by the continuity
//!   target of the projection (docs/ARCHITECTURE.md §5.3), see [`divergence_target`].

use rayon::prelude::*;

use super::fields::LayerFields;
use super::params::AtmosphereParams;
use super::thermo::{exner, moist_static_energy};

/// Computes `C_i`, `U_i`, `D_i` at the top of each layer (zero for the top layer and where
/// either layer of a pair is blocked by terrain). `terrain` holds Θ_T at the cell centres
/// (cell size `dx`). Returns max |D|.
pub fn vertical_velocity(
    layers: &mut [LayerFields],
    terrain: &[f32],
    dx: f64,
    params: &AtmosphereParams,
) -> f64 {
    let nl = layers.len();
    let mut max_d = 0.0f64;
    let cells = terrain.len();
    let n = (cells as f64).sqrt() as usize;
    // Terrain gradient (central differences, toroidal).
    let mask = n.wrapping_sub(1);
    let grad: Vec<(f64, f64)> = (0..cells)
        .into_par_iter()
        .with_min_len(4096)
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let gx = (terrain[j * n + ((i + 1) & mask)] - terrain[j * n + ((i + n - 1) & mask)]) as f64;
            let gy = (terrain[((j + 1) & mask) * n + i] - terrain[((j + n - 1) & mask) * n + i]) as f64;
            (gx / (2.0 * dx), gy / (2.0 * dx))
        })
        .collect();
    for i in 0..nl {
        if i + 1 == nl {
            let top = &mut layers[i];
            top.c.data_mut().fill(0.0);
            top.up.data_mut().fill(0.0);
            top.d.data_mut().fill(0.0);
            continue;
        }
        let (lo, hi) = layers.split_at_mut(i + 1);
        let (a, b) = (&mut lo[i], &hi[0]);
        let open = |k: usize| a.sigma.data()[k] > 0.0 && b.sigma.data()[k] > 0.0;
        // MSE difference per cell (f64), its mean over open cells.
        let diff: Vec<f64> = (0..cells)
            .into_par_iter()
            .with_min_len(4096)
            .map(|k| {
                if !open(k) {
                    return 0.0;
                }
                moist_static_energy(a.t.data()[k] as f64, a.altitude, a.h.data()[k], a.pi)
                    - moist_static_energy(b.t.data()[k] as f64, b.altitude, b.h.data()[k], b.pi)
            })
            .collect();
        let (sum, count) =
            (0..cells).filter(|&k| open(k)).fold((0.0, 0usize), |(s, c), k| (s + diff[k], c + 1));
        let mean = if count > 0 { sum / count as f64 } else { 0.0 };
        let dmax = params.max_vertical_speed;
        let top = a.bottom + a.thickness;
        let (bs, coupling, decay) = (b.sigma.data(), params.convective_coupling, params.orographic_decay_m);
        let LayerFields { c, up, d, u, v, sigma, .. } = a;
        let (u, v, sa) = (u.data(), v.data(), sigma.data());
        // Rows in parallel; the max is order-independent.
        let row_max =
            (c.data_mut().par_chunks_mut(n), up.data_mut().par_chunks_mut(n), d.data_mut().par_chunks_mut(n))
                .into_par_iter()
                .enumerate()
                .with_min_len(8)
                .map(|(jj, (cr, ur, dr))| {
                    let mut m = 0.0f64;
                    for ii in 0..n {
                        let k = jj * n + ii;
                        if !(sa[k] > 0.0 && bs[k] > 0.0) {
                            (cr[ii], ur[ii], dr[ii]) = (0.0, 0.0, 0.0);
                            continue;
                        }
                        let conv = coupling * (diff[k] - mean);
                        let (gx, gy) = grad[k];
                        let lift = if gx == 0.0 && gy == 0.0 {
                            0.0
                        } else {
                            let uc = 0.5 * (u[k] + u[jj * n + ((ii + 1) & mask)]) as f64;
                            let vc = 0.5 * (v[k] + v[((jj + 1) & mask) * n + ii]) as f64;
                            let above = (top - terrain[k] as f64).max(0.0);
                            params.uplift_coupling * (uc * gx + vc * gy) * (-above / decay).exp()
                        };
                        let dk = (conv + lift).clamp(-dmax, dmax);
                        (cr[ii], ur[ii], dr[ii]) = (conv as f32, lift as f32, dk as f32);
                        m = m.max(dk.abs());
                    }
                    m
                })
                .reduce(|| 0.0, f64::max);
        max_d = max_d.max(row_max);
    }
    max_d
}

/// Transfers of eq. (4.6) across every interface, bottom to top, driven by `D`. Columns are
/// independent, so rows run in parallel.
pub fn transfer(layers: &mut [LayerFields], dt: f64) {
    let nl = layers.len();
    for i in 0..nl.saturating_sub(1) {
        let (lo, hi) = layers.split_at_mut(i + 1);
        let (a, b) = (&mut lo[i], &mut hi[0]);
        let n = a.t.nx();
        let (ex_a, ex_b) = (exner(a.pi), exner(b.pi));
        let (ha, hb) = (a.thickness, b.thickness);
        let (d, sa, sb) = (a.d.data(), a.sigma.data(), b.sigma.data());
        (
            a.t.data_mut().par_chunks_mut(n),
            a.h.data_mut().par_chunks_mut(n),
            a.w.data_mut().par_chunks_mut(n),
            a.ash.data_mut().par_chunks_mut(n),
            b.t.data_mut().par_chunks_mut(n),
            b.h.data_mut().par_chunks_mut(n),
            b.w.data_mut().par_chunks_mut(n),
            b.ash.data_mut().par_chunks_mut(n),
        )
            .into_par_iter()
            .enumerate()
            .with_min_len(8)
            .for_each(|(j, (at, ah, aw, aa, bt, bh, bw, ba))| {
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
                    let moved = vs * (1.0 - (-dk.abs() * dt / vs).exp());
                    let carry = |qa: &mut f64, qb: &mut f64| {
                        let (qs, qd) = if up { (qa, qb) } else { (qb, qa) };
                        let m = *qs * moved;
                        *qs = (*qs - m / vs).max(0.0);
                        *qd += m / vd;
                    };
                    carry(&mut ah[x], &mut bh[x]);
                    carry(&mut aw[x], &mut bw[x]);
                    carry(&mut aa[x], &mut ba[x]);
                    let (ts, td) = if up { (at[x], &mut bt[x]) } else { (bt[x], &mut at[x]) };
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

/// Divergence targets of the projection (docs/ARCHITECTURE.md §5.3, continuity):
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
        let max_d = vertical_velocity(&mut layers, &vec![0.0; 256], 100.0, &p);
        assert!(layers[0].d.data()[5] > 0.5, "{}", layers[0].d.data()[5]);
        assert!(layers[0].d.data()[6] < 0.0 && layers[0].d.data()[6] > -0.1);
        assert!(max_d > 0.5);
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
