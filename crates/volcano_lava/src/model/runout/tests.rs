use bevy::math::DVec2;

use super::*;
use crate::scenario::terrains::runout_valley;

/// Runs `seconds` of `vents` on `terrain` in steps of `dt`, handing what froze to the
/// terrain after each step; returns the runout and the reports' sums.
fn run(
    terrain: &mut Terrain,
    params: &LavaParams,
    settings: RunoutSettings,
    vents: &[Vent],
    seconds: f64,
    dt: f64,
) -> (Runout, RunoutReport) {
    let mut r = Runout::new(terrain, settings, params).unwrap();
    let mut sum = RunoutReport::default();
    for _ in 0..(seconds / dt).round() as usize {
        let s = r.step(terrain, params, vents, dt);
        sum.emitted += s.emitted;
        sum.frozen += s.frozen;
        sum.quenched += s.quenched;
        sum.quench_heat += s.quench_heat;
        sum.outflow += s.outflow;
        sum.woke += s.woke;
        sum.slept += s.slept;
        sum.substeps = sum.substeps.max(s.substeps);
        sum.mobility_capped |= s.mobility_capped;
        r.write_frozen(terrain).unwrap();
    }
    (r, sum)
}

/// The vent 60 m below the top row of a valley, on its axis.
fn vent_on(terrain: &Terrain, rate: f64, radius: f64) -> Vent {
    let g = terrain.heights();
    let top = g.origin().as_dvec2();
    let x = top.x + 0.5 * (g.nx() - 1) as f64 * g.cell();
    Vent::point(DVec2::new(x, top.y + 60.0), radius, rate, 1450.0)
}

#[test]
fn isothermal_flow_crosses_tiles_with_exact_mass() {
    let mut terrain = runout_valley((32, 96, 10.0), 5.0, 500.0, (0.0, 0.0), false).unwrap();
    let params = LavaParams::isothermal(100.0).unwrap();
    let settings = RunoutSettings { refine: 2, ..Default::default() };
    let vent = vent_on(&terrain, 4.0, 8.0);
    let (r, sum) = run(&mut terrain, &params, settings, &[vent], 300.0, 0.5);
    assert!(r.tiles().len() >= 3, "the flow must cross tile borders: {} tiles", r.tiles().len());
    let err = r.budget().error_rel(r.lava_volume());
    assert!(err < 1e-12, "budget error {err:e}");
    assert!((sum.emitted - 1200.0).abs() < 1e-9, "{}", sum.emitted);
    // Halfway down the flow on its axis the lava moves downslope (+z) at about Jeffreys'
    // depth-averaged speed for its thickness, ρ g h² sin θ/(3η).
    let s = r.stats(vent.centre, 1e-3);
    let mid = vent.centre + DVec2::new(0.0, 0.5 * s.runout_m);
    let (a, b) = r.grid().cell_of(mid).unwrap();
    let (h, ..) = r.cell_state(a, b).unwrap();
    let tile = &r.tiles()[r.tiles.get(tile_of(a, b)).unwrap()];
    let (u, v) = (tile.velocity().0[local(a, b)], tile.velocity().1[local(a, b)]);
    let jeffreys = params.density * 9.81 * h * h * 5f64.to_radians().sin() / (3.0 * 100.0);
    eprintln!("mid-flow: h {h:.3} m, ({u:.4}, {v:.4}) m/s, Jeffreys {jeffreys:.4} m/s");
    assert!(v > 0.0 && u.abs() < 0.2 * v, "({u}, {v}) at {mid}");
    assert!((0.6..1.5).contains(&(v / jeffreys)), "{v} m/s vs Jeffreys {jeffreys} m/s for {h} m");
    assert!((r.speed(a, b).unwrap() - u.hypot(v)).abs() < 1e-12);
}

#[test]
fn frozen_lava_goes_into_the_terrain_and_dry_tiles_sleep() {
    let mut terrain = runout_valley((32, 64, 8.0), 5.0, 300.0, (2.0, 40.0), false).unwrap();
    let params = LavaParams { viscosity: crate::ViscosityModel::CHANNEL_BASALT, ..Default::default() };
    let settings = RunoutSettings { refine: 4, sleep_after: 10.0 };
    let vent = vent_on(&terrain, 0.2, 3.0);
    let (mut r, fed) = run(&mut terrain, &params, settings, &[vent], 600.0, 1.0);
    assert!(r.lava_volume() > 50.0 && fed.emitted > 119.0, "{} {}", r.lava_volume(), fed.emitted);
    // The vent stops; the flow freezes where it lies and its tiles go to sleep.
    let mut slept = 0;
    for _ in 0..200_000 {
        slept += r.step(&terrain, &params, &[], 1.0).slept;
        r.write_frozen(&mut terrain).unwrap();
        if r.tiles().is_empty() {
            break;
        }
    }
    assert!(r.tiles().is_empty(), "{} tiles left, {} m³ liquid", r.tiles().len(), r.lava_volume());
    assert!(slept >= 2, "{slept}");
    let b = r.budget();
    assert_eq!(r.lava_volume(), 0.0);
    assert!((b.solidified - b.sources).abs() < 1e-9 * b.sources, "{b:?}");
    // Every frozen cubic metre is in the terrain's added layer.
    let added = terrain.added_volume();
    assert!((added - b.solidified).abs() < 1e-9 * b.solidified, "terrain {added} vs frozen {}", b.solidified);
    // A tile that wakes where the flow froze thickest stands on its lava.
    let added = terrain.added().unwrap();
    let (k, &most) = added.data().iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap();
    assert!(most > 0.05, "{most}");
    let rf = settings.refine as i64;
    let (a, bb) = ((k % added.nx()) as i64 * rf + rf / 2, (k / added.nx()) as i64 * rf + rf / 2);
    let grid = *r.grid();
    let tile = Tile::wake(&grid, &terrain, tile_of(a, bb), 300.0);
    let c = grid.centre(a, bb);
    let at = bevy::math::Vec2::new(c.x as f32, c.y as f32);
    let base = terrain.base_heights().sample(at, volcano_core::Boundary::Clamp) as f64;
    let ground = tile.ground()[local(a, bb)];
    assert!(
        ground > base + 0.5 * most,
        "a later flow's ground {ground} must stand on the first's lava over {base}"
    );
}

#[test]
fn a_run_is_deterministic() {
    let go = || {
        let mut terrain = runout_valley((32, 64, 8.0), 6.0, 300.0, (2.0, 40.0), false).unwrap();
        let params = LavaParams { viscosity: crate::ViscosityModel::CHANNEL_BASALT, ..Default::default() };
        let vent = vent_on(&terrain, 0.5, 5.0);
        run(&mut terrain, &params, RunoutSettings::default(), &[vent], 300.0, 0.5).0
    };
    let (a, b) = (go(), go());
    assert!(a.lava_volume() > 100.0);
    assert_eq!(a, b);
}

#[test]
fn a_gully_channels_the_flow() {
    let width = |gully: (f64, f64)| {
        let mut terrain = runout_valley((48, 96, 8.0), 4.0, 400.0, gully, false).unwrap();
        let params = LavaParams { viscosity: crate::ViscosityModel::CHANNEL_BASALT, ..Default::default() };
        let vent = vent_on(&terrain, 0.5, 3.0);
        let r = run(&mut terrain, &params, RunoutSettings::default(), &[vent], 1200.0, 1.0).0;
        r.stats(vent.centre, 1e-3)
    };
    let (plane, gully) = (width((0.0, 0.0)), width((3.0, 24.0)));
    // Same volume: in the gully it is narrower and runs farther.
    assert!(gully.mean_width_m < 0.75 * plane.mean_width_m, "{gully:?}\n{plane:?}");
    assert!(gully.runout_m > plane.runout_m, "{gully:?}\n{plane:?}");
}

#[test]
fn bad_settings_and_vents_are_errors() {
    let terrain = runout_valley((16, 16, 8.0), 5.0, 100.0, (0.0, 0.0), false).unwrap();
    let p = LavaParams::default();
    assert!(Runout::new(&terrain, RunoutSettings { refine: 0, ..Default::default() }, &p).is_err());
    assert!(
        Runout::new(&terrain, RunoutSettings { sleep_after: f64::NAN, ..Default::default() }, &p).is_err()
    );
    let v = vent_on(&terrain, 1.0, 2.0);
    assert!(v.validate().is_ok());
    assert!(Vent { rate: -1.0, ..v }.validate().is_err());
    assert!(Vent { centre: DVec2::new(f64::NAN, 0.0), ..v }.validate().is_err());
    assert!(Vent { temperature: 5000.0, ..v }.validate().is_err());
    assert!(Vent { fissure: DVec2::new(f64::INFINITY, 0.0), ..v }.validate().is_err());
    // A vent off the terrain emits nothing and says so.
    let mut r = Runout::new(&terrain, RunoutSettings::default(), &p).unwrap();
    let off = Vent { centre: DVec2::new(1e5, 0.0), ..v };
    let rep = r.step(&terrain, &p, &[off], 1.0);
    assert_eq!(rep.emitted, 0.0);
    assert!(rep.vent_lost > 0.0);
    // An invalid vent emits nothing and is counted; no NaN reaches the state.
    let rep = r.step(&terrain, &p, &[Vent { rate: f64::NAN, ..v }], 1.0);
    assert_eq!((rep.emitted, rep.vents_rejected), (0.0, 1));
    assert_eq!(r.lava_volume(), 0.0);
}

#[test]
fn a_fissure_feeds_a_curtain_of_cells_along_its_length() {
    let mut terrain = runout_valley((48, 64, 8.0), 5.0, 300.0, (0.0, 0.0), false).unwrap();
    let params = LavaParams { viscosity: crate::ViscosityModel::CHANNEL_BASALT, ..Default::default() };
    // 200 m long across the slope (x), 3 m wide.
    let vent = Vent { fissure: DVec2::new(100.0, 0.0), ..vent_on(&terrain, 2.0, 3.0) };
    let r = Runout::new(&terrain, RunoutSettings::default(), &params).unwrap();
    let cells = r.vent_cells(&vent);
    // 2 m cells: a 200 m line of cells, three or four rows deep (centres within 3 m of the
    // line), plus its rounded ends.
    assert!((300..=420).contains(&cells.len()), "{} cells", cells.len());
    let xs: Vec<f64> = cells.iter().map(|&(a, b)| r.grid().centre(a, b).x).collect();
    let span = xs.iter().copied().fold(f64::MIN, f64::max) - xs.iter().copied().fold(f64::MAX, f64::min);
    assert!((span - 200.0).abs() <= 2.0 * r.grid().cell(), "{span}");
    let (r, sum) = run(&mut terrain, &params, RunoutSettings::default(), &[vent], 120.0, 1.0);
    assert!((sum.emitted - 240.0).abs() < 1e-9);
    let s = r.stats(vent.centre, 1e-3);
    let (lo, hi) = s.bounds.unwrap();
    assert!(hi.x - lo.x >= 196.0, "a sheet as wide as the fissure: {lo} – {hi}");
}

#[test]
fn state_that_is_no_longer_finite_is_reset_and_booked() {
    let mut terrain = runout_valley((32, 64, 10.0), 5.0, 400.0, (0.0, 0.0), false).unwrap();
    let params = LavaParams::isothermal(100.0).unwrap();
    let vent = vent_on(&terrain, 2.0, 8.0);
    let (mut r, _) = run(&mut terrain, &params, RunoutSettings::default(), &[vent], 60.0, 0.5);
    let (a, b) = r.grid().cell_of(vent.centre + DVec2::new(0.0, 20.0)).unwrap();
    let ti = r.tiles.get(tile_of(a, b)).unwrap();
    let k = local(a, b);
    // Both cells lose what they held.
    let held = (r.tiles.list[ti].h[k] + r.tiles.list[ti].h[k + 1]) * r.grid().cell() * r.grid().cell();
    assert!(held > 0.0);
    // A NaN thickness and an infinite temperature next to it.
    r.tiles.list[ti].h[k] = f64::NAN;
    r.tiles.list[ti].t[k + 1] = f64::INFINITY;
    let rep = r.step(&terrain, &params, &[vent], 0.5);
    assert_eq!(rep.repaired_cells, 2);
    assert!((rep.lost_m3 - held).abs() < 1e-9 * held.max(1.0), "{} vs {held}", rep.lost_m3);
    for _ in 0..20 {
        r.step(&terrain, &params, &[vent], 0.5);
    }
    let finite = r.tiles().iter().all(|t| t.thickness().iter().chain(t.temperature()).all(|v| v.is_finite()));
    assert!(finite, "no NaN spreads");
    let b = r.budget();
    assert!(b.error_rel(r.lava_volume()) < 1e-12, "{b:?}");
    assert!((b.faulted - rep.lost_m3).abs() < 1e-12);
}
