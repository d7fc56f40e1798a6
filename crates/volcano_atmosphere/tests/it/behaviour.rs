//! Thesis behaviours (§4.2.7.2) and budgets on the shipped scenarios, at reduced grids so the
//! tests stay fast.

use volcano_atmosphere::model::run::run;
use volcano_atmosphere::model::scenario::WeatherScenario;
use volcano_atmosphere::model::step::{Workspace, step};

#[test]
fn water_is_conserved_over_1000_steps_and_nothing_goes_negative() {
    // Island scenario: sea evaporation, land ground water, condensation, convection, wind,
    // terrain cutting layers; a low precipitation threshold so rain really falls.
    let mut s = WeatherScenario::builtin("island").unwrap();
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
    let s = WeatherScenario::builtin("convection").unwrap();
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
    let s = WeatherScenario::builtin("orographic").unwrap();
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
    let s = WeatherScenario::builtin("sea-breeze").unwrap();
    let r = run(&s, None, None, Some(64)).unwrap();
    let m = &r.summary;
    eprintln!("{}", serde_json::to_string_pretty(m).unwrap());
    let (day, night) = (m.onshore_wind_noon_m_s.unwrap(), m.onshore_wind_night_m_s.unwrap());
    assert!(day > 0.2, "onshore by day: {day}");
    assert!(night < 0.0, "offshore by night: {night}");
}

#[test]
fn bad_scenario_files_give_clear_errors() {
    let good = include_str!("../../scenarios/convection.ron");
    WeatherScenario::from_ron(good).unwrap();
    // Unknown field.
    let e = WeatherScenario::from_ron(&good.replace("latitude_deg", "latitude")).unwrap_err().to_string();
    assert!(e.contains("latitude"), "{e}");
    // Layers out of order.
    let e = WeatherScenario::from_ron(&good.replace("altitude_m: 1500.0", "altitude_m: 100.0"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("increasing order"), "{e}");
    // NaN.
    let e = WeatherScenario::from_ron(&good.replace("extent_m: 51200.0", "extent_m: NaN"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("extent_m"), "{e}");
    let e = WeatherScenario::from_ron(&good.replace("amount: 4.0", "amount: NaN")).unwrap_err().to_string();
    assert!(e.contains("spot amount"), "{e}");
    // Grid not a power of two; unknown built-in.
    let e = WeatherScenario::from_ron(&good.replace("grid: 128", "grid: 100")).unwrap_err().to_string();
    assert!(e.contains("power of two"), "{e}");
    let e = WeatherScenario::builtin("tornado").unwrap_err().to_string();
    assert!(e.contains("sea-breeze"), "{e}");
    // Unknown field inside a terrain variant.
    let e = WeatherScenario::from_ron(&good.replace(
        "terrain: Flat(height_m: 0.0, cover: Ground)",
        "terrain: Flat(height_m: 0.0, cover: Ground, slope: 1.0)",
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("slope"), "{e}");
    let e = WeatherScenario::load(std::path::Path::new("/nonexistent/storm.ron")).unwrap_err().to_string();
    assert!(e.contains("storm.ron"), "{e}");
    // Every shipped scenario parses.
    for (name, _) in volcano_atmosphere::model::scenario::BUILTIN {
        WeatherScenario::builtin(name).unwrap();
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    // The loops run in fixed row bands (volcano_core::parallel): one thread running every band
    // in order gives what the task pool's threads give. 128² has 4 bands of 32 rows and runs
    // the multigrid's sweeps in parallel too.
    let s = WeatherScenario::builtin("mixed").unwrap();
    let a = volcano_core::parallel::run_inline(|| run(&s, Some(40), None, Some(128)).unwrap());
    let b = run(&s, Some(40), None, Some(128)).unwrap();
    assert_eq!(a.state, b.state, "parallel loops must be deterministic");
    assert!(a.summary.valid);
}

#[test]
fn a_stratovolcano_from_the_foundation_cuts_through_the_low_layers() {
    let text = include_str!("../../scenarios/convection.ron").replace(
        "terrain: Flat(height_m: 0.0, cover: Ground),",
        "terrain: Stratovolcano((resolution: 257, cell: 100.0, summit_height: 2500.0)),",
    );
    let s = WeatherScenario::from_ron(&text).unwrap();
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
    let bad = include_str!("../../scenarios/convection.ron")
        .replace("terrain: Flat(height_m: 0.0, cover: Ground),", "terrain: Stratovolcano((cell: -1.0)),");
    let e = WeatherScenario::from_ron(&bad).unwrap_err().to_string();
    assert!(e.contains("cell"), "{e}");
}

/// What a plume spot did over 20 steps of 30 s: the largest D above it, the limiter's report,
/// the condensed water above the spot (layers 1–2, within two cells) and far from it, and the
/// water drift once the water the imposition added is booked.
struct PlumeSpot {
    d_max: f64,
    unlimited: f64,
    limited: u64,
    near: f64,
    far: f64,
    drift: f64,
}

/// Imposes `dt_k` kelvin above the layer's reference and `hum` g/m³ on a 3 × 3-cell spot of the
/// lowest layer before every step, as crates/volcano_coupling does under a plume column.
fn plume_spot(dt_k: f32, hum: f64) -> PlumeSpot {
    let s = WeatherScenario::builtin("convection").unwrap();
    let mut st = s.build(Some(32)).unwrap();
    let n = st.grid.n;
    let area = st.grid.dx * st.grid.dx;
    let spot: Vec<usize> = (15..18).flat_map(|j| (15..18).map(move |i| j * n + i)).collect();
    let mut work = Workspace::new(&st).unwrap();
    let (water0, mut added) = (st.water_total(), 0.0);
    let mut r = PlumeSpot { d_max: 0.0, unlimited: 0.0, limited: 0, near: 0.0, far: 0.0, drift: 0.0 };
    for _ in 0..20 {
        let l = &mut st.layers[0];
        let t_ref = l.t_ref;
        for &k in &spot {
            l.t.data_mut()[k] = t_ref + dt_k;
            added += (hum - l.h.data()[k]) * l.sigma.data()[k] as f64 * l.thickness * area;
            l.h.data_mut()[k] = hum;
        }
        let rep = step(&mut st, &s.params, &mut work, s.dt).unwrap();
        assert!(!rep.repaired.any(), "state became non-finite or negative: {rep:?}");
        let d = spot.iter().map(|&k| st.layers[0].d.data()[k] as f64).fold(f64::MIN, f64::max);
        r.d_max = r.d_max.max(d);
        r.unlimited = r.unlimited.max(rep.max_unlimited_vertical_speed);
        r.limited += rep.vertical_limited_cells;
    }
    r.drift = (st.water_total() - water0 - added) / (water0 + added);
    let dist = |k: usize| ((k % n) as i64 - 16).abs().max(((k / n) as i64 - 16).abs());
    let mean = |l: usize, near: bool| {
        let cells: Vec<usize> = (0..n * n).filter(|&k| (dist(k) <= 2) == near).collect();
        cells.iter().map(|&k| st.layers[l].w.data()[k]).sum::<f64>() / cells.len() as f64
    };
    (r.near, r.far) = (mean(1, true).max(mean(2, true)), mean(1, false).max(mean(2, false)));
    eprintln!(
        "+{dt_k} K, {hum} g/m³: D above the spot up to {:.2} m/s (|C + U| up to {:.1}), {} limited \
         cell-steps; condensed water above the spot {:.4} g/m³, far {:.2e}; water drift {:e}",
        r.d_max, r.unlimited, r.limited, r.near, r.far, r.drift
    );
    r
}

/// A volcanic plume imposes hundreds of kelvin and its moisture on the cells under the column.
/// The layers must carry an updraft of tens of m/s above it (a ±2 m/s clamp on the vertical
/// speed would hold it at 2), report the limiter that acts at Δt = 30 s, stay finite and
/// book every gram; a moist spot diluted to +30 K (the plume's edge, where the cap cloud
/// forms) rises at more than twice that 2 m/s bound and condenses a cap cloud above it.
#[test]
fn a_hot_moist_plume_spot_drives_a_fast_updraft_and_a_cap_cloud() {
    let hot = plume_spot(300.0, 20.0);
    assert!(hot.d_max > 10.0, "updraft above a +300 K spot: {} m/s", hot.d_max);
    assert!(hot.limited > 0 && hot.unlimited > hot.d_max, "the limiter must be reported");
    assert!(hot.drift.abs() < 1e-12, "water drift {:e}", hot.drift);
    let edge = plume_spot(30.0, 20.0);
    assert!(edge.d_max > 4.0, "updraft above a +30 K moist spot: {} m/s", edge.d_max);
    assert!(edge.drift.abs() < 1e-12, "water drift {:e}", edge.drift);
    assert!(edge.near > 0.05 && edge.far == 0.0, "cap cloud {} g/m³ vs far {}", edge.near, edge.far);
}
