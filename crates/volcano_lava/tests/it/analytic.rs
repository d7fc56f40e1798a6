//! Isothermal constant-viscosity checks against analytic solutions (within 10 %).

use volcano_lava::scenario::{LavaScenario, ScenarioConfig, ScenarioKind, huppert_radius};

#[test]
fn steady_sheet_on_incline_matches_jeffreys() {
    let mut c = ScenarioConfig::new(ScenarioKind::Incline);
    c.isothermal = true;
    c.viscosity = Some(1000.0);
    c.slope_deg = 5.0;
    c.rate = 0.05;
    c.grid = 128;
    let mut s = LavaScenario::build(&c).unwrap();
    s.run_until(600.0);
    let sum = s.summary();
    let u_an = sum.analytic.mean_velocity_m_s.unwrap();
    let h_an = sum.analytic.thickness_m.unwrap();
    println!(
        "incline: u measured {:.5} vs Jeffreys {:.5} m/s; h measured {:.5} vs {:.5} m; \
         front {:.1} m; substeps mean {:.2}",
        sum.mean_velocity_m_s, u_an, sum.thickness_m, h_an, sum.front_distance_m, sum.mean_substeps
    );
    assert!(sum.front_distance_m > 0.9 * 64.0 - 2.0, "sheet must cover the slope");
    assert!((sum.mean_velocity_m_s / u_an - 1.0).abs() < 0.10);
    assert!((sum.thickness_m / h_an - 1.0).abs() < 0.10);
    // And the flux itself: q = u h equals the fed rate in the steady region.
    assert!((sum.mean_velocity_m_s * sum.thickness_m / c.rate - 1.0).abs() < 0.05);
    assert!(sum.volume_error_rel < 1e-9);
}

#[test]
fn spreading_volume_matches_huppert_1982() {
    let mut c = ScenarioConfig::new(ScenarioKind::Spread);
    c.isothermal = true;
    c.viscosity = Some(1000.0);
    c.volume = 20.0;
    c.initial_radius = 2.0;
    c.grid = 64;
    let mut s = LavaScenario::build(&c).unwrap();
    for t in [100.0, 300.0, 900.0] {
        s.run_until(t);
        let sum = s.summary();
        let r_an = huppert_radius(2700.0 * 9.81, 1000.0, 20.0, t);
        println!(
            "spread t={t}: r measured {:.3} vs Huppert {:.3} m (ratio {:.3}), farthest cell {:.2} m",
            sum.front_radius_m,
            r_an,
            sum.front_radius_m / r_an,
            sum.front_distance_m
        );
        assert!((sum.front_radius_m / r_an - 1.0).abs() < 0.10);
        assert!(sum.volume_error_rel < 1e-9);
    }
}

#[test]
fn huppert_constant_is_0_894() {
    // ξ_N = (1024/(81 π³))^{1/8}
    let r = huppert_radius(3.0, 1.0, 1.0, 1.0);
    assert!((r - 0.894).abs() < 5e-4, "{r}");
}
