//! Cooling and solidification of the flow (docs/physics/lava.md §6.2): heat conducts through the crust to its top, which
//! radiates and convects (and optionally through the base), so the core stays hot while the
//! crust thickens; lava colder than the solidus, or crusted through, freezes into the ground,
//! so later lava flows over it.

use super::field::FlowField;
use super::params::{LavaParams, STEFAN_BOLTZMANN};

/// Heat flux out of a lava surface at temperature `t` (W/m²): grey-body radiation
/// `εσ(T⁴ − T_e⁴)` plus convection `h_c (T − T_e)` (thesis Table 5.2 σ and T_e; ε = 0.95 and
/// h_c ≈ 60 W/m²/K from docs/physics/lava.md §6.3).
pub fn top_heat_loss(params: &LavaParams, t: f64) -> f64 {
    let te = params.air_temperature;
    params.emissivity * STEFAN_BOLTZMANN * (t.powi(4) - te.powi(4)) + params.convection * (t - te)
}

/// Effective heat capacity (J/kg/K) of lava at depth-averaged temperature `t` (K): `C_p`,
/// plus the latent heat of crystallisation `L` released uniformly between the liquidus and
/// the solidus, `C_p + L/(T_l − T_s)`, in that interval. (A standard lumped treatment of a
/// basalt's crystallisation interval; the thesis neglects latent heat. With L = 4·10⁵ J/kg it
/// triples the heat a column gives off between liquidus and solidus.)
pub fn effective_heat_capacity(params: &LavaParams, t: f64) -> f64 {
    let (tl, ts) = (params.liquidus, params.solidus);
    if t > ts && t <= tl && tl > ts {
        params.heat_capacity + params.latent_heat / (tl - ts)
    } else {
        params.heat_capacity
    }
}

/// Heat flux (W/m²) out of the top of a lava column at `t_core` (K) under a crust `crust` m
/// thick: heat conducts through the crust, `k (T_core − T_top)/δ`, to a top at `T_top` that
/// radiates and convects ([`top_heat_loss`]); `T_top` is the balance of the two
/// ([`surface_temperature`]). Without crust the top is at `t_core`.
pub fn heat_loss_through_crust(params: &LavaParams, t_core: f64, crust: f64) -> f64 {
    top_heat_loss(params, surface_temperature(params, t_core, crust))
}

/// What one cooling pass did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThermalReport {
    /// Lava volume frozen into the ground (m³).
    pub frozen: f64,
    /// Number of cells that froze.
    pub frozen_cells: u32,
}

/// Cools every lava cell for `dt` seconds as a lumped column and freezes the cells that
/// solidified.
///
/// `T` is the column's depth-averaged temperature (it also stands for the core's in the
/// viscosity). Heat leaves from the crust top ([`heat_loss_through_crust`], with the crust
/// thickness `crust[k]` from the crust model, eq 5.1/5.3; bare lava where `crust` is empty or
/// 0) and optionally through the base: `ρ C_eff(T) h dT/dt = −(top + base)`, with the latent
/// heat in [`effective_heat_capacity`], never below the air temperature.
///
/// A cell counts as **frozen** when its depth-averaged temperature falls below the solidus,
/// or when its crust reaches its whole thickness (`crust ≥ h`). A frozen cell's whole
/// thickness moves into the `solid` layer and the ground, booked as `solidified`. Until then
/// the crust is part of the lava: it is in `h`, moves with the flow and counts in the lava
/// volume, not in `solidified`.
pub fn cool_and_freeze(field: &mut FlowField, params: &LavaParams, crust: &[f64], dt: f64) -> ThermalReport {
    let mut report = ThermalReport::default();
    if !params.cooling {
        return report;
    }
    let area = field.cell() * field.cell();
    let te = params.air_temperature;
    let h = field.h.data_mut();
    let t = field.temp.data_mut();
    let ground = field.ground.data_mut();
    let solid = field.solid.data_mut();
    let has_crust = crust.len() == h.len();
    for k in 0..h.len() {
        if h[k] <= 0.0 {
            continue;
        }
        let c = if has_crust && crust[k].is_finite() { crust[k].max(0.0) } else { 0.0 };
        let mut frozen = c >= h[k];
        if !frozen {
            let loss = heat_loss_through_crust(params, t[k], c) + params.base_heat_transfer * (t[k] - te);
            let rho_c = params.density * effective_heat_capacity(params, t[k]);
            t[k] = (t[k] - loss * dt / (rho_c * h[k])).max(te);
            frozen = t[k] < params.solidus;
        }
        if frozen {
            report.frozen += h[k] * area;
            report.frozen_cells += 1;
            solid[k] += h[k];
            ground[k] += h[k];
            h[k] = 0.0;
            t[k] = te;
        }
    }
    field.budget.solidified += report.frozen;
    report
}

/// Temperature (K) of the top of a crust of thickness `crust` (m) over lava at `t_core` (K):
/// the steady balance of conduction through the crust with the losses of the top,
/// `k (T_core − T_top)/δ = εσ(T_top⁴ − T_e⁴) + h_c (T_top − T_e)`, solved by Newton
/// iterations from `T_core` (the right side is convex and increasing, so the iterates
/// decrease monotonically to the root; clamped to `[T_e, T_core]`). The thesis gives no
/// surface-temperature law; this is the standard quasi-steady crust of lava-cooling models.
/// Cooling ([`cool_and_freeze`]) and the display use it. No crust: `t_core`.
pub fn surface_temperature(params: &LavaParams, t_core: f64, crust: f64) -> f64 {
    let te = params.air_temperature;
    if crust <= 0.0 || t_core <= te {
        return t_core.max(te);
    }
    let g = params.conductivity / crust;
    let mut ts = t_core;
    for _ in 0..30 {
        let f = g * (t_core - ts) - top_heat_loss(params, ts);
        let df = -g - 4.0 * params.emissivity * STEFAN_BOLTZMANN * ts.powi(3) - params.convection;
        let next = (ts - f / df).clamp(te, t_core);
        if (next - ts).abs() < 1e-9 {
            return next;
        }
        ts = next;
    }
    ts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crust_surface_is_cooler_and_balances_conduction() {
        let p = LavaParams::default();
        assert_eq!(surface_temperature(&p, 1400.0, 0.0), 1400.0);
        let ts = surface_temperature(&p, 1400.0, 0.02);
        assert!(ts > 400.0 && ts < 1000.0, "{ts}");
        let conduction = p.conductivity * (1400.0 - ts) / 0.02;
        assert!((conduction - top_heat_loss(&p, ts)).abs() < 1e-3 * conduction);
        assert!(surface_temperature(&p, 1400.0, 0.05) < ts, "thicker crust, cooler surface");
    }

    #[test]
    fn heat_loss_at_liquidus() {
        let p = LavaParams::default();
        // 0.95·5.67e-8·(1473⁴ − 300⁴) + 60·1173 = 253.1 kW/m² + 70.4 kW/m²
        let q = top_heat_loss(&p, 1473.0);
        let expect = 0.95 * 5.67e-8 * (1473f64.powi(4) - 300f64.powi(4)) + 60.0 * 1173.0;
        assert!((q - expect).abs() < 1e-6);
        assert!((q - 323_500.0).abs() < 1_000.0, "{q}");
        assert_eq!(top_heat_loss(&p, 300.0), 0.0);
    }
}
