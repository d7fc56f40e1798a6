//! Cooling and solidification of the flow (docs/ARCHITECTURE.md §6.1–6.2): heat leaves through
//! the top by radiation and convection (and optionally through the base); lava colder than the
//! solidus freezes into the ground, so later lava flows over it.

use super::field::FlowField;
use super::params::{LavaParams, STEFAN_BOLTZMANN};

/// Heat flux out of a lava surface at temperature `t` (W/m²): grey-body radiation
/// `εσ(T⁴ − T_e⁴)` plus convection `h_c (T − T_e)` (thesis Table 5.2 σ and T_e; ε = 0.95 and
/// h_c ≈ 60 W/m²/K from docs/ARCHITECTURE.md §6.3).
pub fn top_heat_loss(params: &LavaParams, t: f64) -> f64 {
    let te = params.air_temperature;
    params.emissivity * STEFAN_BOLTZMANN * (t.powi(4) - te.powi(4)) + params.convection * (t - te)
}

/// What one cooling pass did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ThermalReport {
    /// Lava volume frozen into the ground (m³).
    pub frozen: f64,
    /// Number of cells that froze.
    pub frozen_cells: u32,
}

/// Cools every lava cell for `dt` seconds as a lumped column (depth-averaged temperature,
/// `ρ C_p h dT/dt = −(top + base losses)`, never below the air temperature), then freezes
/// whole cells whose temperature fell below the solidus: their thickness moves into the
/// `solid` layer and the ground, booked as `solidified`. Latent heat is neglected.
pub fn cool_and_freeze(field: &mut FlowField, params: &LavaParams, dt: f64) -> ThermalReport {
    let mut report = ThermalReport::default();
    if !params.cooling {
        return report;
    }
    let area = field.cell() * field.cell();
    let rho_cp = params.density * params.heat_capacity;
    let te = params.air_temperature;
    let h = field.h.data_mut();
    let t = field.temp.data_mut();
    let ground = field.ground.data_mut();
    let solid = field.solid.data_mut();
    for k in 0..h.len() {
        if h[k] <= 0.0 {
            continue;
        }
        let loss = top_heat_loss(params, t[k]) + params.base_heat_transfer * (t[k] - te);
        t[k] = (t[k] - loss * dt / (rho_cp * h[k])).max(te);
        if t[k] < params.solidus {
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
/// the steady balance of conduction through the crust, `k (T_core − T_s)/h_crust`, with the
/// surface losses of [`top_heat_loss`], solved by Newton iterations (our estimate for
/// gameplay and rendering; the thesis gives no surface-temperature law). No crust: `t_core`.
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
