//! The departures from the printed equations that docs/ARCHITECTURE.md §5.4 argues, each with
//! the behaviour that makes the printed form unusable here and ours hold: convection (4.5) as
//! the anomaly of MSE_i − MSE_{i+1}, and heat exchange (4.11) as a sensible-heat flux.

use volcano_atmosphere::model::scenario::Scenario;
use volcano_atmosphere::model::terrain::ground_heat_step;
use volcano_atmosphere::model::thermo::moist_static_energy;
use volcano_atmosphere::model::vertical::vertical_velocity;

/// Eq. (4.5) as printed, `C = λ (MSE_{i+1} − MSE_i)`, on the calm `convection` scenario made
/// horizontally uniform but for one cell of the lowest layer 5 K warmer: the printed law moves
/// the whole domain one way (here down at ≈ 0.5 m/s, the moist low layer holding more MSE; up
/// in drier, stable air), a net vertical flux the torus cannot feed, and over the hot cell it
/// pulls air *down* hardest — the opposite of the thesis' own Fig 4.6, where painted hot spots
/// make convection cells. The code's anomaly form of `MSE_i − MSE_{i+1}` has no net flux and
/// rises over the hot cell only.
#[test]
fn convection_rises_over_a_hot_cell_and_has_no_net_flux_where_the_printed_law_does_neither() {
    let s = Scenario::builtin("convection").unwrap();
    let mut st = s.build(Some(16)).unwrap();
    let hot = 5 * 16 + 7;
    for l in st.layers.iter_mut() {
        let (t, h) = (l.t.data()[0], l.h.data()[0]);
        l.t.data_mut().fill(t);
        l.h.data_mut().fill(h);
        l.u.data_mut().fill(0.0);
        l.v.data_mut().fill(0.0);
        l.sigma.data_mut().fill(1.0);
    }
    st.layers[0].t.data_mut()[hot] += 5.0;
    let terrain = vec![0.0f32; 16 * 16];
    vertical_velocity(&mut st.layers, &terrain, st.grid.dx, &s.params, 1.0);
    let c = st.layers[0].c.data();
    let net: f64 = c.iter().map(|&v| v as f64).sum();
    let elsewhere = c.iter().enumerate().filter(|&(k, _)| k != hot).map(|(_, &v)| v).fold(f32::MIN, f32::max);
    assert!(
        c[hot] > 0.0 && c[hot] > 10.0 * elsewhere.abs(),
        "updraft over the hot cell: {} vs {elsewhere}",
        c[hot]
    );
    assert!(net.abs() < 1e-6 * c[hot] as f64 * 256.0, "no net vertical flux: {net}");

    let (a, b) = (&st.layers[0], &st.layers[1]);
    let mse = |l: &volcano_atmosphere::model::fields::LayerFields, k: usize| {
        moist_static_energy(l.t.data()[k] as f64, l.altitude, l.h.data()[k], l.pi)
    };
    let printed: Vec<f64> =
        (0..256).map(|k| s.params.convective_coupling * (mse(b, k) - mse(a, k))).collect();
    let lowest = (0..256).min_by(|&i, &j| printed[i].total_cmp(&printed[j])).unwrap();
    let sign = printed[0].signum();
    assert!(
        printed.iter().all(|&v| v.signum() == sign && v.abs() > 0.1),
        "printed law: one direction everywhere (net {})",
        printed.iter().sum::<f64>()
    );
    assert_eq!(lowest, hot, "printed law: the hot cell moves down the most (or up the least)");
}

/// Eq. (4.11) as printed, `T⁺ = T⁻ + κ ΔT_emitted`, can only warm the air (the ground always
/// emits). Read as a sensible-heat flux `κ (T_g − T_a)`, air over ground colder than itself
/// cools (a night inversion) and air over warmer ground warms, each toward the ground.
#[test]
fn sensible_heat_cools_air_over_cold_ground_and_warms_it_over_warm_ground() {
    let (cap_ground, cap_air) = (8e5, 1.2e6);
    let (_, cooled) = ground_heat_step(270.0, 285.0, 0.0, 0.95, 15.0, cap_ground, cap_air, 600.0);
    let (_, warmed) = ground_heat_step(300.0, 285.0, 400.0, 0.95, 15.0, cap_ground, cap_air, 600.0);
    assert!(cooled < 285.0 && cooled > 270.0, "air over cold ground: {cooled} K");
    assert!(warmed > 285.0 && warmed < 300.0, "air over warm ground: {warmed} K");
}
