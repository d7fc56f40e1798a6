//! Thesis behaviours (§4.2.7.2) and budgets on the shipped scenarios, at reduced grids so the
//! tests stay fast.

use volcano_atmosphere::model::run::run;
use volcano_atmosphere::model::scenario::Scenario;

#[test]
fn water_is_conserved_over_1000_steps_and_nothing_goes_negative() {
    // Island scenario: sea evaporation, land ground water, condensation, convection, wind,
    // terrain cutting layers; a low precipitation threshold so rain really falls.
    let mut s = Scenario::builtin("island").unwrap();
    s.params.precipitation_threshold = 0.05;
    s.params.precipitation_rate = 5e-3;
    let r = run(&s, Some(1000), Some(30.0), Some(32)).unwrap();
    let m = &r.summary;
    eprintln!("{}", serde_json::to_string_pretty(m).unwrap());
    assert!(m.valid, "a field became non-finite or negative");
    assert!(m.precipitated_g > 0.0, "the test must exercise precipitation");
    assert!(m.cloud_cover.iter().any(|&c| c > 0.0), "the test must exercise condensation");
    assert!(m.water_total_rel_error <= 1e-5, "total water drifted by {:e}", m.water_total_rel_error);
    // Stricter: the drift measured against the water in the air alone.
    assert!(m.water_air_rel_error <= 1e-5, "air-relative drift {:e}", m.water_air_rel_error);
}

#[test]
fn painted_hot_spot_makes_an_updraft_above_it() {
    let s = Scenario::builtin("convection").unwrap();
    let r = run(&s, Some(20), None, Some(64)).unwrap();
    let st = &r.state;
    let n = st.grid.n;
    // Cell nearest the first painted spot (−12 km, −8 km).
    let k = st
        .grid
        .cells()
        .checked_sub(0)
        .map(|cells| {
            (0..cells)
                .min_by(|&a, &b| {
                    let d = |k: usize| {
                        let (x, y) = st.grid.centre(k);
                        (x + 12000.0).powi(2) + (y + 8000.0).powi(2)
                    };
                    d(a).total_cmp(&d(b))
                })
                .unwrap()
        })
        .unwrap();
    let d0 = st.layers[0].d.data();
    let mean = d0.iter().map(|&d| d as f64).sum::<f64>() / d0.len() as f64;
    eprintln!("D above the spot {} m/s, domain mean {mean}", d0[k]);
    assert!(d0[k] > 0.2, "updraft above the hot spot: {}", d0[k]);
    // Inflow toward the spot in the lowest layer: the wind west of it blows east, east of it
    // blows west.
    let (i, j) = (k % n, k / n);
    let u = st.layers[0].u.data();
    let west = u[j * n + (i + n - 3) % n];
    let east = u[j * n + (i + 4) % n];
    eprintln!("u west {west}, east {east}");
    assert!(west > 0.0 && east < 0.0, "converging inflow: west {west}, east {east}");
}

#[test]
fn orographic_lift_is_windward_only() {
    let s = Scenario::builtin("orographic").unwrap();
    let r = run(&s, None, None, Some(64)).unwrap();
    let m = &r.summary;
    eprintln!("{}", serde_json::to_string_pretty(m).unwrap());
    let (ww, lw) = (m.windward_updraft_m_s.unwrap(), m.lee_updraft_m_s.unwrap());
    let (wc, lc) = (m.windward_cloud_cover.unwrap(), m.lee_cloud_cover.unwrap());
    assert!(ww > 0.1, "windward updraft {ww}");
    assert!(lw < 0.0, "lee should sink: {lw}");
    assert!(wc > 0.2, "windward cloud cover {wc}");
    assert!(lc < 0.5 * wc, "lee cloud {lc} vs windward {wc}");
}

#[test]
fn shore_breeze_turns_between_day_and_night() {
    let s = Scenario::builtin("sea-breeze").unwrap();
    let r = run(&s, None, None, Some(64)).unwrap();
    let m = &r.summary;
    eprintln!("{}", serde_json::to_string_pretty(m).unwrap());
    let (day, night) = (m.onshore_wind_noon_m_s.unwrap(), m.onshore_wind_night_m_s.unwrap());
    assert!(day > 0.2, "onshore by day: {day}");
    assert!(night < 0.0, "offshore by night: {night}");
}

#[test]
fn bad_scenario_files_give_clear_errors() {
    let good = include_str!("../scenarios/convection.ron");
    Scenario::from_ron(good).unwrap();
    // Unknown field.
    let e = Scenario::from_ron(&good.replace("latitude_deg", "latitude")).unwrap_err().to_string();
    assert!(e.contains("latitude"), "{e}");
    // Layers out of order.
    let e =
        Scenario::from_ron(&good.replace("altitude_m: 1500.0", "altitude_m: 100.0")).unwrap_err().to_string();
    assert!(e.contains("increasing order"), "{e}");
    // NaN.
    let e = Scenario::from_ron(&good.replace("extent_m: 51200.0", "extent_m: NaN")).unwrap_err().to_string();
    assert!(e.contains("extent_m"), "{e}");
    let e = Scenario::from_ron(&good.replace("amount: 4.0", "amount: NaN")).unwrap_err().to_string();
    assert!(e.contains("spot amount"), "{e}");
    // Grid not a power of two; unknown built-in.
    let e = Scenario::from_ron(&good.replace("grid: 128", "grid: 100")).unwrap_err().to_string();
    assert!(e.contains("power of two"), "{e}");
    let e = Scenario::builtin("tornado").unwrap_err().to_string();
    assert!(e.contains("sea-breeze"), "{e}");
    // Unknown field inside a terrain variant.
    let e = Scenario::from_ron(&good.replace(
        "terrain: Flat(height_m: 0.0, cover: Ground)",
        "terrain: Flat(height_m: 0.0, cover: Ground, slope: 1.0)",
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("slope"), "{e}");
    let e = Scenario::load(std::path::Path::new("/nonexistent/storm.ron")).unwrap_err().to_string();
    assert!(e.contains("storm.ron"), "{e}");
    // Every shipped scenario parses.
    for (name, _) in volcano_atmosphere::model::scenario::BUILTIN {
        Scenario::builtin(name).unwrap();
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let s = Scenario::builtin("mixed").unwrap();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let three = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
    let a = one.install(|| run(&s, Some(80), None, Some(32)).unwrap());
    let b = three.install(|| run(&s, Some(80), None, Some(32)).unwrap());
    assert_eq!(a.state, b.state, "parallel loops must be deterministic");
    assert!(a.summary.valid);
}

#[test]
fn a_stratovolcano_from_the_foundation_cuts_through_the_low_layers() {
    let text = include_str!("../scenarios/convection.ron").replace(
        "terrain: Flat(height_m: 0.0, cover: Ground),",
        "terrain: Stratovolcano((resolution: 257, cell: 100.0, summit_height: 2500.0)),",
    );
    let s = Scenario::from_ron(&text).unwrap();
    let st = s.build(Some(32)).unwrap();
    // The cone (2.5 km) closes the 500 m layer (slab 0–1000 m) near the summit and leaves it
    // open far away, where the foot of the cone (≈ 120 m) fills the bottom of the slab.
    let lowest = st.ground.height.data().iter().cloned().fold(f32::MAX, f32::min) as f64;
    let most = st.layers[0].sigma.data().iter().cloned().fold(0.0f32, f32::max) as f64;
    eprintln!("lowest ground {lowest} m, largest σ of layer 0 {most}");
    assert!(st.layers[0].sigma.data().contains(&0.0));
    assert!(most > 0.8 && (most - (1000.0 - lowest) / 1000.0).abs() < 1e-6, "σ {most}, ground {lowest} m");
    assert!(st.ground.lowest.iter().any(|&l| l >= 1));
    let r = run(&s, Some(30), None, Some(32)).unwrap();
    assert!(r.summary.valid);
    assert!(r.summary.water_total_rel_error < 1e-12);
    // A bad generator parameter is reported by name.
    let bad = include_str!("../scenarios/convection.ron")
        .replace("terrain: Flat(height_m: 0.0, cover: Ground),", "terrain: Stratovolcano((cell: -1.0)),");
    let e = Scenario::from_ron(&bad).unwrap_err().to_string();
    assert!(e.contains("cell"), "{e}");
}
