//! Lava patches on the flank of a procedural volcano: each patch is built on whichever terrain
//! lies under it, conserves volume, and writes exactly its frozen volume into that terrain,
//! finer or coarser than the terrain, aligned with its nodes or not.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_lava::*;

/// A small stratovolcano high up (2.4–2.5 km, where an f32 height step is 2.4e-4 m): 97²
/// nodes of 3 m, cone 120 m in radius.
fn volcano() -> Terrain {
    StratovolcanoParams {
        resolution: 97,
        cell: 3.0,
        base_altitude: 2_400.0,
        summit_height: 90.0,
        cone_radius: 120.0,
        flank_exponent: 1.4,
        crater_radius: 8.0,
        crater_depth: 4.0,
        ridge_amplitude: 2.0,
        hills_amplitude: 1.0,
        ..Default::default()
    }
    .generate()
    .unwrap()
}

fn run(app: &mut App, ticks: u64) {
    let target = app.world().resource::<SimTick>().0 + ticks;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
    }
}

/// A patch of `n`² cells of `cell` m centred at `centre` on the flank, fed `rate` m³/s of lava
/// at `kelvin` (just above the solidus, 1273 K, so much of it freezes within seconds) 40 % of
/// the way upslope.
fn patch(app: &mut App, centre: Vec2, n: usize, cell: f64, (rate, kelvin): (f64, f64)) -> Entity {
    let placement = Placement { centre, nx: n, ny: n, cell };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    let half = 0.5 * (n - 1) as f32 * cell as f32;
    let vent = centre - centre.normalize() * 0.4 * half;
    let mut src = crate::plugin::source(Vec3::new(vent.x, 0.0, vent.y), rate, kelvin).unwrap();
    src.radius = cell.max(1.5);
    app.world_mut().spawn(src);
    field
}

#[test]
fn flank_patches_conserve_volume_and_the_terrain_gains_exactly_the_frozen_lava() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ));
    // A flat terrain beside the volcano, spawned first: the patches must not be built on it.
    let origin = Vec2::new(150.0, -160.0);
    let heights = Grid2::new(33, 33, 10.0, origin, 5.0f32).unwrap();
    let far =
        Terrain::new(heights, Grid2::new(33, 33, 10.0, origin, LandCover::Ground).unwrap(), 0.0).unwrap();
    let decoy = if std::env::var("NO_DECOY").is_ok() { None } else { Some(app.world_mut().spawn(far).id()) };
    let terrain = volcano();
    let cell_t = terrain.heights().cell();
    let base: Vec<f32> = terrain.heights().data().to_vec();
    let volcano_e = app.world_mut().spawn(terrain).id();
    // Finer than the terrain (1 m in 3 m nodes), off the node lattice.
    let fine = patch(&mut app, Vec2::new(52.3, 17.9), 40, 1.0, (0.4, 1274.0));
    // Coarser than the terrain (4.5 m cells), off the lattice, on the other flank.
    let coarse = patch(&mut app, Vec2::new(-38.6, -47.2), 12, 4.5, (2.0, 1276.0));
    // 30.5 s: the write-back's tick (once a second, at half past).
    run(&mut app, 1525);

    let w = app.world();
    let mut frozen_total = 0.0;
    for field in [fine, coarse] {
        assert_eq!(w.get::<LavaFieldStatus>(field), Some(&LavaFieldStatus::Ok), "field {field}");
        let state = w.get::<LavaState>(field).unwrap();
        let b = *state.flow.budget();
        // Fed = fluid + frozen + outflow, to rounding.
        let fluid = state.flow.lava_volume();
        let closes = (b.sources - (fluid + b.solidified + b.outflow)).abs();
        assert!(closes <= 1e-12 * b.sources, "{b:?}, fluid {fluid}");
        assert!(b.sources > 4.0, "{b:?}");
        // The frozen layer of the field holds what the budget says froze.
        let c = state.flow.cell();
        let layer = state.flow.solid().data().iter().sum::<f64>() * c * c;
        assert!((layer - b.solidified).abs() <= 1e-12 * b.solidified, "{layer} vs {b:?}");
        assert!(b.solidified > 0.1 * b.sources && fluid > 0.1 * b.sources, "{b:?}, fluid {fluid}");
        eprintln!("patch of {c} m cells: {b:?}, fluid {fluid} m³");
        frozen_total += b.solidified;
    }
    // The decoy is untouched; the volcano gained exactly the frozen volume.
    if let Some(decoy) = decoy {
        let decoy_t = w.get::<Terrain>(decoy).unwrap();
        assert!(decoy_t.heights().data().iter().all(|&h| h == 5.0));
    }
    let t = w.get::<Terrain>(volcano_e).unwrap();
    // The terrain's own record of what it gained.
    let gained = t.added_volume();
    let rel = (gained - frozen_total).abs() / frozen_total;
    eprintln!("frozen {frozen_total} m³, terrain recorded {gained} m³ (rel {rel:e})");
    assert!(rel < 1e-9, "terrain recorded {gained} m³, {frozen_total} m³ froze (rel {rel:e})");
    // Its f32 heights carry the same volume to their rounding (2.4e-4 m a node at 2.4 km).
    let drawn: f64 =
        t.heights().data().iter().zip(&base).map(|(&a, &b)| (a as f64 - b as f64) * cell_t * cell_t).sum();
    let nodes = t.added().unwrap().data().iter().filter(|a| **a != 0.0).count() as f64;
    assert!(
        (drawn - frozen_total).abs() <= nodes * 1.3e-4 * cell_t * cell_t,
        "heights gained {drawn} m³ over {nodes} nodes, {frozen_total} m³ froze"
    );
    assert_eq!(t.base_heights().data(), &base[..], "the ground under the layer is untouched");
}

/// Two overlapping terrains: a patch is built on the finest one that contains it whole; a
/// patch on none of them is rejected.
#[test]
fn a_patch_goes_on_the_terrain_that_contains_it() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ));
    let small = app.world_mut().spawn(Terrain::flat(21, 1.0, 50.0).unwrap()).id();
    let big = app.world_mut().spawn(volcano()).id();
    let inside_both = patch(&mut app, Vec2::new(2.0, 3.0), 8, 1.0, (0.1, 1274.0));
    let only_big = patch(&mut app, Vec2::new(60.0, 0.0), 8, 1.0, (0.1, 1274.0));
    let on_none = patch(&mut app, Vec2::new(140.0, 0.0), 16, 1.0, (0.1, 1274.0));
    run(&mut app, 2);
    let w = app.world();
    let on = |f: Entity| w.get::<LavaState>(f).and_then(|s| s.imprint.as_ref()).map(|l| l.terrain);
    assert_eq!(on(inside_both), Some(small), "the finest terrain that contains it");
    assert_eq!(on(only_big), Some(big));
    let ground = w.get::<LavaState>(only_big).unwrap().flow.ground().get(0, 0);
    assert!(ground > 2_400.0, "resampled from the volcano: {ground}");
    let status = w.get::<LavaFieldStatus>(on_none).unwrap();
    assert!(matches!(status, LavaFieldStatus::Rejected(m) if m.contains("no terrain")), "{status:?}");
}

/// A patch started by a click: on the terrain, holding the click, shifted downslope.
#[test]
fn a_clicked_patch_lies_downslope_and_inside_the_terrain() {
    let t = volcano();
    let click = Vec2::new(30.0, -40.0);
    let p = Placement::downslope_of(&t, click, 64, 1.0).unwrap();
    let (o, half) = (p.origin(), 31.5);
    assert!(t.contains(o.x, o.y) && t.contains(o.x + 63.0, o.y + 63.0));
    assert!((p.centre - click).x.abs() <= half && (p.centre - click).y.abs() <= half);
    // Downslope = away from the summit at the origin.
    assert!(p.centre.length() > click.length() + 15.0, "{:?}", p.centre);
    // Near the edge it is pushed back inside; larger than the terrain or off it, an error.
    let edge = Placement::downslope_of(&t, Vec2::new(140.0, 0.0), 64, 1.0).unwrap();
    let far = edge.origin() + Vec2::splat(63.0);
    assert!(t.contains(far.x, far.y), "{edge:?}");
    assert!(Placement::downslope_of(&t, click, 400, 1.0).is_err());
    assert!(Placement::downslope_of(&t, Vec2::new(500.0, 0.0), 16, 1.0).is_err());
}

/// The `eruption` scene's flank patch alone (its lava entry copied from
/// assets/scenes/eruption.ron), printing what flowed and froze: the numbers quoted in
/// docs/physics/lava.md §6.7. `TICKS` (default 1500) and `KELVIN` (default 1473) override.
/// `cargo test -p volcano_lava --test flank -- --ignored --nocapture` (~20 s per 1500 ticks).
#[test]
#[ignore = "prints numbers for the docs; tens of seconds"]
fn eruption_scene_patch_numbers() {
    let env = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let (ticks, kelvin) = (env("TICKS", 1500.0) as u64, env("KELVIN", 1473.0));
    // The scene's terrain is the generator's default.
    let terrain = StratovolcanoParams::default().generate().unwrap();
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ));
    let t = app.world_mut().spawn(terrain).id();
    let placement = Placement { centre: Vec2::new(1721.0, 2457.0), nx: 256, ny: 256, cell: 1.0 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    let mut src = crate::plugin::source(Vec3::new(1666.0, 0.0, 2379.0), 3.0, kelvin).unwrap();
    src.radius = 2.0;
    app.world_mut().spawn(src);
    run(&mut app, ticks);
    let w = app.world();
    let state = w.get::<LavaState>(field).unwrap();
    let h = state.flow.thickness();
    let wet: Vec<Vec2> =
        (0..h.data().len()).filter(|&k| h.data()[k] > 0.01).map(|k| h.position(k % 256, k / 256)).collect();
    let reach = wet.iter().map(|p| p.distance(Vec2::new(1666.0, 2379.0))).fold(0.0f32, f32::max);
    let frozen_cells = state.flow.solid().data().iter().filter(|v| **v > 0.01).count();
    let added =
        w.get::<Terrain>(t).unwrap().added().map_or(0.0, |a| a.data().iter().copied().fold(0.0, f64::max));
    println!(
        "{ticks} ticks at {kelvin} K: {:?}; {} cells > 1 cm, reaching {reach:.1} m from the source; \
         {frozen_cells} frozen cells > 1 cm; thickest added layer on a node {added:.2e} m",
        state.flow.budget(),
        wet.len()
    );
}
