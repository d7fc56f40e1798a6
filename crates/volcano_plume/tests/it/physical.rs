//! The physical preset (`Dynamics::Column`, docs/physics/plume.md §4.5) against published
//! numbers: Mastin et al. (2009), Costa et al. (2016), the collapse threshold of a Woods-type
//! column, and the inverse control. Single slice, vent at sea level.

use bevy::math::DVec2;
use volcano_core::AtmosphereProfile;
use volcano_core::atmosphere::AtmosphereModel;
use volcano_plume::model::inverse::{mer_for_height, mer_for_height_in};
use volcano_plume::model::run::{SingleSliceSummary, collapse_threshold, run_single_slice};
use volcano_plume::{AmbientLevel, LayeredAmbient, SliceEnv};
use volcano_plume::{Eruption, PlumeParams, Preset, WindProfile};

/// Mastin et al. (2009): top above the vent (m), `H[km] = 2.00 V^0.241`, V dense rock at
/// 2,500 kg/m³ (m³/s).
fn mastin_m(mer: f64) -> f64 {
    2_000.0 * (mer / 2_500.0).powf(0.241)
}

fn run(p: &PlumeParams) -> SingleSliceSummary {
    run_single_slice(p, 7_200.0, 0.0).unwrap().0
}

fn costa(strong: bool) -> PlumeParams {
    let base = Preset::Physical.params();
    if strong {
        PlumeParams { t0: 1_053.0, gas_fraction: 0.05, ..base }.with_mer(1.5e9, Some(275.0)).unwrap()
    } else {
        PlumeParams { t0: 1_273.0, gas_fraction: 0.03, ..base }.with_mer(1.5e6, Some(135.0)).unwrap()
    }
}

#[test]
fn vent_mixture_is_a_light_gas_ash_mixture() {
    // 3 wt% water at 1,273 K and 1 atm: ≈ 5.7 kg/m³ (Woods 1988), not Table 3.1's 200.
    let p = Preset::Physical.params();
    let rho = p.vent_density();
    assert!((5.0..6.5).contains(&rho), "{rho}");
    // Hotter or richer in gas: lighter; at a 3 km vent (lower pressure): lighter.
    assert!(PlumeParams { gas_fraction: 0.05, ..p.clone() }.vent_density() < rho);
    assert!(PlumeParams { vent_altitude: 3_000.0, ..p.clone() }.vent_density() < 0.8 * rho);
    // The mass eruption rate is the vent flux ρ0 π r0² v0, and with_mer inverts it.
    let flux = rho * std::f64::consts::PI * p.r0 * p.r0 * p.v0;
    assert!((p.mass_eruption_rate() - flux).abs() < 1e-9 * flux);
    let q = p.with_mer(3.0e6, Some(120.0)).unwrap();
    assert!((q.mass_eruption_rate() - 3.0e6).abs() < 1e-6 * 3.0e6 && q.v0 == 120.0);
    // The thesis slice delivers twice its vent flux.
    let t = Preset::Thesis.params();
    let thesis_flux = t.rho0 * std::f64::consts::PI * t.r0 * t.r0 * t.v0;
    assert!((t.mass_eruption_rate() / thesis_flux - 2.0).abs() < 1e-12);
    assert!(p.with_mer(-5.0, None).is_err() && p.with_mer(f64::NAN, None).is_err());
}

#[test]
fn top_height_follows_mastin_within_30_percent() {
    let base = Preset::Physical.params();
    for mer in [1e5, 1e6, 1e7, 1e8, 1e9] {
        let p = base.with_mer(mer, None).unwrap();
        let s = run(&p);
        let want = mastin_m(mer);
        println!(
            "MER {mer:.0e} kg/s (v0 {:.0} m/s, r0 {:.1} m): top {:.0} m, Mastin {want:.0} m, ratio {:.2}",
            p.v0,
            p.r0,
            s.apex_m,
            s.apex_m / want
        );
        assert_eq!(s.regime, "plume", "{mer:e}");
        assert!((s.apex_m / want - 1.0).abs() <= 0.30, "MER {mer:e}: {} m vs Mastin {want} m", s.apex_m);
    }
}

#[test]
fn costa_2016_cases_within_25_percent_and_wind_bends_the_weak_plume() {
    let (strong, weak) = (run(&costa(true)), run(&costa(false)));
    println!("strong: top {:.0} m; weak: top {:.0} m", strong.apex_m, weak.apex_m);
    assert!((strong.apex_m / 41_000.0 - 1.0).abs() <= 0.25, "strong {:?}", strong);
    assert!((weak.apex_m / 9_100.0 - 1.0).abs() <= 0.25, "weak {:?}", weak);
    // Wind rising linearly to 15 m/s at 12 km: the weak plume bends over and tops out lower.
    let windy = PlumeParams {
        wind: WindProfile::Linear { max: 15.0, top: 12_000.0, direction_deg: 0.0 },
        ..costa(false)
    };
    let w = run(&windy);
    println!(
        "weak in wind: top {:.0} m ({:.0} % lower), {:.0} m downwind",
        w.apex_m,
        100.0 * (1.0 - w.apex_m / weak.apex_m),
        w.max_downwind_m
    );
    assert_eq!(w.regime, "plume");
    assert!(w.apex_m < 0.8 * weak.apex_m, "{} vs calm {}", w.apex_m, weak.apex_m);
    assert!(w.max_downwind_m > 1_000.0);
}

#[test]
fn woods_column_collapses_below_70_and_rises_above_90_m_s() {
    // 3 wt%, 1,273 K, r0 = 100 m (the physical preset's vent), exit speed varied.
    let p = Preset::Physical.params();
    assert_eq!(run(&PlumeParams { v0: 70.0, ..p.clone() }).regime, "collapse");
    assert_eq!(run(&PlumeParams { v0: 90.0, ..p.clone() }).regime, "plume");
    let t = collapse_threshold(&p, 20.0, 300.0, 0.5).unwrap().unwrap();
    println!("collapse threshold {t:.1} m/s");
}

#[test]
fn exit_speed_rule_keeps_the_column_buoyant_from_1e4_to_1e9() {
    let base = Preset::Physical.params();
    for k in 0..=10 {
        let mer = 10f64.powf(4.0 + 0.5 * k as f64);
        let p = base.with_mer(mer, None).unwrap();
        assert_eq!(run(&p).regime, "plume", "MER {mer:e}, v0 {}", p.v0);
        // With a margin: 20 % slower (and the wider vent of the same rate) still rises.
        let slow = base.with_mer(mer, Some(p.v0 / 1.2)).unwrap();
        assert_eq!(run(&slow).regime, "plume", "MER {mer:e}, v0 {}", slow.v0);
    }
}

#[test]
fn column_time_step_barely_matters_and_mass_closes() {
    let p = Preset::Physical.params().with_mer(1e6, None).unwrap();
    let apex = |dt| run(&PlumeParams { dt, ..p.clone() }).apex_m;
    let (fine, table, coarse) = (apex(0.0005), apex(0.002), apex(0.01));
    assert!((table / fine - 1.0).abs() < 0.01, "{fine} vs {table}");
    assert!((coarse / fine - 1.0).abs() < 0.03, "{fine} vs {coarse}");
    assert!(run(&p).mass_budget_rel_error.abs() < 1e-9);
}

#[test]
fn inverse_control_lands_within_5_percent() {
    for km in [4.0, 12.0, 30.0] {
        let e = Eruption::physical().with_target_height(km).unwrap();
        let s = run(&e.params);
        println!(
            "target {km} km: MER {:.3e} kg/s, forward top {:.0} m",
            e.params.mass_eruption_rate(),
            s.apex_m
        );
        assert!((s.apex_m / (km * 1_000.0) - 1.0).abs() <= 0.05, "{km} km: {}", s.apex_m);
    }
    // In wind the same height needs more mass.
    let windy = PlumeParams {
        wind: WindProfile::Linear { max: 15.0, top: 12_000.0, direction_deg: 0.0 },
        ..Preset::Physical.params()
    };
    let calm = mer_for_height(&Preset::Physical.params(), 8_000.0).unwrap();
    let blown = mer_for_height(&windy, 8_000.0).unwrap();
    assert!(blown.mer_kg_s > 1.5 * calm.mer_kg_s, "{} vs {}", blown.mer_kg_s, calm.mer_kg_s);
    // Under a coupled column's ambient air (standard layers with a wind rising to 15 m/s at
    // 12 km): the solver reads the given air and wind, not the parameters' calm.
    let level = |z: f64| AmbientLevel {
        altitude: z,
        temperature: volcano_core::UsStandard1976.temperature(z),
        humidity: 0.0,
        wind: DVec2::new(15.0 * (z / 12_000.0).min(1.0), 0.0),
    };
    let ambient = LayeredAmbient::new(
        AtmosphereModel::UsStandard1976,
        (0..9).map(|k| level(2_000.0 * k as f64)).collect(),
    )
    .unwrap();
    let wind = |z: f64| ambient.wind_at(z);
    let env = SliceEnv { air: &ambient, vent_altitude: 0.0, wind: &wind };
    let coupled = mer_for_height_in(&Preset::Physical.params(), 8_000.0, &env).unwrap();
    assert!((coupled.top_m / 8_000.0 - 1.0).abs() <= 0.01);
    assert!(coupled.mer_kg_s > 1.5 * calm.mer_kg_s, "{} vs {}", coupled.mer_kg_s, calm.mer_kg_s);
    // Out of reach: errors, not panics.
    assert!(Eruption::physical().with_target_height(150.0).is_err());
    assert!(Eruption::physical().with_target_height(0.05).is_err());
    assert!(Eruption::physical().with_target_height(f64::NAN).is_err());
}
