//! Property tests: budgets and bounds hold for arbitrary inputs.

use approx::assert_relative_eq;
use proptest::prelude::*;
use volcano_atmosphere::model::advection::{advect_conservative, apertures};
use volcano_atmosphere::model::thermo::{phase_change, saturation_humidity};

proptest! {
    #[test]
    fn phase_change_conserves_water_and_never_goes_negative(
        t in 200.0f64..320.0, h in 0.0f64..40.0, w in 0.0f64..10.0,
        pi in 20_000.0f64..105_000.0, gamma in 0.0f64..1.0, dt in 0.1f64..600.0,
    ) {
        let pc = phase_change(t, h, w, pi, gamma, dt);
        assert_relative_eq!(pc.h + pc.w, h + w, max_relative = 1e-12);
        // Condensing releases latent heat, evaporating takes it: the air warms exactly when
        // vapour is lost.
        let (dh, dtk) = (pc.h - h, pc.t - t);
        prop_assert!(dh * dtk <= 0.0, "Δh {} g/m³ with ΔT {} K", dh, dtk);
        // Moves toward saturation, never past it.
        let sat = saturation_humidity(t, pi);
        if h < sat { prop_assert!(pc.h >= h && pc.h <= sat + 1e-9) } else { prop_assert!(pc.h <= h && pc.h >= sat - 1e-9) }
    }

    #[test]
    fn flux_advection_conserves_for_any_wind_and_terrain(
        seed in 0u64..1000, speed in 0.0f32..40.0, dt_dx in 0.01f64..1.0,
    ) {
        let n = 16;
        let r = |k: usize, m: u64| ((((k as u64 + 1) * 2_654_435_761) ^ (seed * 97 + m)) % 1000) as f32 / 1000.0;
        let sigma: Vec<f32> = (0..n * n).map(|k| if r(k, 1) < 0.2 { 0.0 } else { r(k, 2).max(0.1) }).collect();
        let u: Vec<f32> = (0..n * n).map(|k| speed * (2.0 * r(k, 3) - 1.0)).collect();
        let v: Vec<f32> = (0..n * n).map(|k| speed * (2.0 * r(k, 4) - 1.0)).collect();
        let mut q: Vec<f64> = (0..n * n).map(|k| if sigma[k] > 0.0 { 10.0 * r(k, 5) as f64 } else { 0.0 }).collect();
        let (mut ax, mut ay) = (vec![0.0; n * n], vec![0.0; n * n]);
        apertures(&sigma, n, &mut ax, &mut ay);
        let total = |q: &[f64]| q.iter().zip(&sigma).map(|(a, &s)| a * s as f64).sum::<f64>();
        let before = total(&q);
        let mut scratch = vec![0.0; 3 * n * n];
        advect_conservative(&mut [&mut q[..]], &mut scratch, &u, &v, &ax, &ay, &sigma, n, dt_dx);
        // Conservation is what the scheme's floor at zero would break if it ever acted.
        prop_assert!((total(&q) - before).abs() <= 1e-12 * before.max(1.0));
        prop_assert!((0..n * n).all(|k| sigma[k] > 0.0 || q[k] == 0.0));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    /// Any coefficients that pass validation keep the state finite and non-negative.
    #[test]
    fn any_valid_params_keep_the_state_valid(
        lambda in 0.0f64..1.0, nu in 0.0f64..10.0, gamma in 0.0f64..100.0,
        evap in 0.0f64..1.0, solar in 0.0f64..2000.0,
        kappa in 0.0f64..1000.0, soil in 0.01f64..100.0, relax in 1.0f64..1e7,
        cycles in 1u32..8, dt in 1.0f64..3600.0, sky in 0.0f64..1.0,
    ) {
        let c = Coefficients { lambda, nu, gamma, evap, solar, kappa, soil, relax, cycles, sky };
        let summary = orographic(&c, dt);
        prop_assert!(summary.valid, "state became invalid");
        prop_assert!(summary.water_total_rel_error < 1e-9, "water drift {}", summary.water_total_rel_error);
    }
}

/// The coefficients the property test varies (the fields of `AtmosphereParams` it sets).
struct Coefficients {
    lambda: f64,
    nu: f64,
    gamma: f64,
    evap: f64,
    solar: f64,
    kappa: f64,
    soil: f64,
    relax: f64,
    cycles: u32,
    sky: f64,
}

/// The orographic scenario with `c` (validated), 12 steps of `dt` s on a 16² grid.
fn orographic(c: &Coefficients, dt: f64) -> volcano_atmosphere::AtmosphereSummary {
    let mut s = volcano_atmosphere::WeatherScenario::builtin("orographic").unwrap();
    s.params.convective_coupling = c.lambda;
    s.params.uplift_coupling = c.nu;
    s.params.phase_rate = c.gamma;
    s.params.ground_evaporation_velocity = c.evap;
    s.params.solar_constant = c.solar;
    s.params.sensible_heat_coefficient = c.kappa;
    s.params.soil_depth = c.soil;
    s.params.temperature_relaxation_s = c.relax;
    s.params.multigrid_cycles = c.cycles;
    s.params.sky_emissivity = c.sky;
    s.params.validate().unwrap();
    volcano_atmosphere::model::run::run(&s, Some(12), Some(dt), Some(16)).unwrap().summary
}

/// A case proptest found with no donor limiter: a 2,767 s step with strong uplift hits the
/// 256-substep cap, and without the limiter the clamp at zero creates water (drift 1.8e-9).
#[test]
fn substep_cap_regression_keeps_water_exact() {
    let c = Coefficients {
        lambda: 0.0,
        nu: 7.466619247877709,
        gamma: 78.0077694986079,
        evap: 0.023271021668145,
        solar: 0.0,
        kappa: 0.0,
        soil: 87.29544783755267,
        relax: 1.0,
        cycles: 4,
        sky: 0.0,
    };
    let summary = orographic(&c, 2766.874965108243);
    assert!(summary.valid);
    assert!(summary.water_total_rel_error < 1e-12, "drift {}", summary.water_total_rel_error);
}

/// A case proptest found (one V-cycle per step, a 1,313 s step, a 1 cm soil) where the
/// ground's latent heat can overshoot and make the state invalid: it must stay valid.
#[test]
fn one_cycle_long_step_regression_keeps_the_state_valid() {
    let c = Coefficients {
        lambda: 0.23811716142107545,
        nu: 9.897881557681725,
        gamma: 45.98628821132328,
        evap: 0.913507706268909,
        solar: 0.0,
        kappa: 0.0,
        soil: 0.01,
        relax: 2326936.3643335043,
        cycles: 1,
        sky: 0.0,
    };
    let summary = orographic(&c, 1312.91051029756);
    assert!(summary.valid, "state became invalid: {summary:?}");
    assert!(summary.water_total_rel_error < 1e-9, "drift {}", summary.water_total_rel_error);
}
