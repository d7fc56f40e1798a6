//! The ground's energy budget alone: under fixed forcing its temperature
//! must not depend on how the time is cut into steps, and no clamp may hide an oscillation.

use volcano_atmosphere::AtmosphereParams;
use volcano_atmosphere::model::scenario::WeatherScenario;
use volcano_atmosphere::model::sun::sun_position;
use volcano_atmosphere::model::terrain::ground_exchange;

/// Thin soil (2 cm: heat capacity 25.6 kJ/(m²·K), a time constant of ≈ 20 min against
/// radiation and sensible heat) under a fixed noon sun, dry air held at its initial
/// temperature, no ground water: one 1 h step and 60 steps of 1 min land within 1 K, and the
/// ground ends between its start and the 150–400 K band's inside (no clamp reached).
#[test]
fn thin_soil_one_hour_step_matches_sixty_one_minute_steps() {
    let s = WeatherScenario::builtin("convection").unwrap();
    let mut st = s.build(Some(16)).unwrap();
    for l in st.layers.iter_mut() {
        l.h.data_mut().fill(0.0);
        l.w.data_mut().fill(0.0);
    }
    st.ground.water.data_mut().fill(0.0);
    let params = AtmosphereParams { soil_depth: 0.02, ..Default::default() };
    let sun = sun_position(172.0, 12.0, 43.0);
    let air: Vec<f32> = st.layers[0].t.data().to_vec();
    let run = |steps: usize, dt: f64| {
        let mut g = st.clone();
        for _ in 0..steps {
            ground_exchange(&mut g, &params, &sun, dt);
            g.layers[0].t.data_mut().copy_from_slice(&air); // air held constant
        }
        g.ground.t.data()[0] as f64
    };
    let t0 = st.ground.t.data()[0] as f64;
    let (one, sixty) = (run(1, 3600.0), run(60, 60.0));
    let fine = run(3600, 1.0);
    eprintln!("start {t0:.2} K; 1 × 1 h: {one:.2} K, 60 × 1 min: {sixty:.2} K, 3600 × 1 s: {fine:.2} K");
    assert!((one - sixty).abs() < 1.0, "1 h step {one:.2} K vs 60 × 1 min {sixty:.2} K");
    assert!((sixty - fine).abs() < 0.5, "60 × 1 min {sixty:.2} K vs 3600 × 1 s {fine:.2} K");
    // Noon sun on dry soil warms it by tens of kelvin, to well inside the 150–400 K band.
    assert!(fine > t0 + 10.0 && fine < 380.0, "{t0:.2} → {fine:.2} K");
}
