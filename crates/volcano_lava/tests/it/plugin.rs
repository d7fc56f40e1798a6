//! The lava plugin on a headless app: live sources, budget, zones, queries, rejections.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_lava::*;

#[derive(Resource, Default, Debug)]
struct Reached(Vec<(Entity, u64)>);

fn record(mut seen: ResMut<Reached>, tick: Res<SimTick>, mut r: MessageReader<LavaReached>) {
    for m in r.read() {
        seen.0.push((m.entity, tick.0));
    }
}

#[derive(Resource, Default, Debug)]
struct Probe(Option<LavaProbe>);

fn probe(mut out: ResMut<Probe>, lava: LavaQuery) {
    out.0 = lava.at(Vec2::new(0.0, 0.0));
}

/// A source of `rate` m³/s at `kelvin` K at the world position `at` (no `Transform`).
pub(crate) fn source(at: Vec3, rate: f64, kelvin: f64) -> Result<LavaSource, ConfigError> {
    LavaSource::new(rate)?.at(at)?.with_temperature(kelvin)
}

fn app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .init_resource::<Reached>()
        .init_resource::<Probe>()
        .add_systems(FixedUpdate, (record, probe).in_set(SimSystems::End));
    // 64 m of terrain tilted 2° toward +z.
    let mut terrain = Terrain::flat(65, 1.0, 10.0).unwrap();
    let origin = terrain.heights().origin();
    for (k, h) in terrain.heights_mut().data_mut().iter_mut().enumerate() {
        let z = origin.y + (k / 65) as f32;
        *h = 10.0 - z * 2f32.to_radians().tan();
    }
    app.world_mut().spawn(terrain);
    app
}

/// Updates until `ticks` more base ticks have run.
pub(crate) fn run(app: &mut App, ticks: u64) {
    let target = app.world().resource::<SimTick>().0 + ticks;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
    }
}

#[test]
fn live_source_fills_the_field_and_reaches_a_zone() {
    let mut app = app();
    let placement = Placement { centre: Vec2::ZERO, nx: 64, ny: 64, cell: 0.5 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    let source = app.world_mut().spawn(source(Vec3::new(0.0, 10.0, -6.0), 0.3, 1473.0).unwrap()).id();
    let zone = app.world_mut().spawn(LavaZone::new(Vec2::new(0.0, 2.0), 1.0).unwrap()).id();
    let far = app.world_mut().spawn(LavaZone::new(Vec2::new(-14.0, -14.0), 0.5).unwrap()).id();
    run(&mut app, 50 * 40);
    let w = app.world();
    assert_eq!(w.get::<LavaSourceStatus>(source), Some(&LavaSourceStatus::Active(field)));
    assert_eq!(w.get::<LavaFieldStatus>(field), Some(&LavaFieldStatus::Ok));
    let state = w.get::<LavaState>(field).unwrap();
    let b = *state.flow.budget();
    // 40 s at 0.3 m³/s (the field is built and stepped in the first tick).
    assert!((b.sources - 0.3 * 40.0).abs() < 1e-9, "{b:?}");
    assert!(b.error_rel(state.flow.lava_volume()) < 1e-12);
    // The lava runs downhill (+z) and reaches the zone 8 m below the vent, not the far one.
    let reached = &w.resource::<Reached>().0;
    assert!(reached.iter().any(|(e, _)| *e == zone), "{reached:?}");
    assert!(!reached.iter().any(|(e, _)| *e == far));
    assert!(w.get::<LavaZone>(zone).unwrap().reached);
    let p = w.resource::<Probe>().0.expect("the query sees the lava at (0, 0)");
    assert!(p.thickness > 0.01 && p.temperature > 1273.0, "{p:?}");
    assert!(p.surface_temperature <= p.temperature);
    assert!(p.surface_altitude > 10.0 - 0.1 && p.surface_altitude < 11.5, "{p:?}");
    // Removing the source stops the supply; the budget still closes.
    let before = b.sources;
    app.world_mut().entity_mut(source).despawn();
    run(&mut app, 50);
    let state = app.world().get::<LavaState>(field).unwrap();
    assert_eq!(state.flow.budget().sources, before);
    assert!(state.flow.budget().error_rel(state.flow.lava_volume()) < 1e-12);
}

#[test]
fn bad_sources_and_fields_are_rejected_not_panicking() {
    assert!(source(Vec3::ZERO, -1.0, 1400.0).is_err());
    assert!(source(Vec3::ZERO, 1.0, f64::NAN).is_err());
    assert!(source(Vec3::new(f32::NAN, 0.0, 0.0), 1.0, 1400.0).is_err());
    let bad_params = LavaParams { emissivity: 2.0, ..Default::default() };
    assert!(LavaField::new(Placement::default(), bad_params).is_err());

    let mut app = app();
    let placement = Placement { centre: Vec2::ZERO, nx: 32, ny: 32, cell: 0.5 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    // Off the field (and off the terrain).
    let off = app.world_mut().spawn(source(Vec3::new(100.0, 0.0, 0.0), 1.0, 1400.0).unwrap()).id();
    // A valid source later edited to a negative rate (as a panel or reflection could do).
    let edited = app.world_mut().spawn(source(Vec3::ZERO, 1.0, 1400.0).unwrap()).id();
    // A field placed off the terrain.
    let outside = Placement { centre: Vec2::new(500.0, 0.0), ..placement };
    let bad_field = app.world_mut().spawn(LavaField::new(outside, LavaParams::default()).unwrap()).id();
    run(&mut app, 5);
    app.world_mut().get_mut::<LavaSource>(edited).unwrap().rate = -3.0;
    run(&mut app, 5);
    let w = app.world();
    assert!(matches!(w.get::<LavaSourceStatus>(off), Some(LavaSourceStatus::Rejected(_))));
    assert!(matches!(w.get::<LavaSourceStatus>(edited), Some(LavaSourceStatus::Rejected(_))));
    assert!(matches!(w.get::<LavaFieldStatus>(bad_field), Some(LavaFieldStatus::Rejected(_))));
    assert!(w.get::<LavaState>(bad_field).is_none());
    let state = w.get::<LavaState>(field).unwrap();
    assert!(state.flow.is_valid() && state.flow.budget().faulted == 0.0, "no cell needed the guard");
    // The edited source emitted only while valid: 5 steps.
    assert!((state.flow.budget().sources - 1.0 * 0.02 * 5.0).abs() < 1e-12, "{:?}", state.flow.budget());
}

fn run_with_frame(ms: u64, ticks: u64) -> (Vec<f64>, usize) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(ms)));
    let mut terrain = Terrain::flat(65, 1.0, 10.0).unwrap();
    for (k, h) in terrain.heights_mut().data_mut().iter_mut().enumerate() {
        *h = 10.0 - (k / 65) as f32 * 0.05;
    }
    app.world_mut().spawn(terrain);
    let placement = Placement { centre: Vec2::ZERO, nx: 48, ny: 48, cell: 0.5 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    app.world_mut().spawn(source(Vec3::new(0.0, 10.0, -6.0), 0.5, 1473.0).unwrap());
    run(&mut app, ticks);
    let state = app.world().get::<LavaState>(field).unwrap();
    (state.flow.thickness().data().to_vec(), state.folds.particle_count())
}

#[test]
fn same_ticks_same_state_at_any_frame_rate() {
    let ticks = 50 * 20;
    let (a, fa) = run_with_frame(20, ticks);
    let (b, fb) = run_with_frame(100, ticks);
    assert!(a.iter().any(|&h| h > 0.1));
    assert_eq!(a, b, "bitwise identical thickness after {ticks} ticks");
    assert_eq!(fa, fb);
}

#[test]
fn frozen_lava_is_written_back_into_the_terrain() {
    let mut app = app();
    let placement = Placement { centre: Vec2::ZERO, nx: 64, ny: 64, cell: 0.5 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    run(&mut app, 1);
    let terrain_heights = |app: &mut App| {
        let w = app.world_mut();
        w.query::<&Terrain>().single(w).unwrap().heights().data().to_vec()
    };
    let before = terrain_heights(&mut app);
    // 3 m³ (about 10 cm thick) just above the solidus (1273 K): it freezes within seconds.
    let mut state = app.world_mut().get_mut::<LavaState>(field).unwrap();
    state.flow.place_volume(Vec2::new(0.0, -4.0), 3.0, 3.0, 1273.2).unwrap();
    // Cells span [−16, 16] m: the footprints of nodes −16..16 m.
    assert!(state.imprint.as_ref().is_some_and(|l| l.imprint.len() == 33 * 33), "nodes −16..16 m");
    // To tick 225: the last one writes back (once a second at half past: ticks 25, 75, …).
    run(&mut app, 224);
    let after = terrain_heights(&mut app);
    let state = app.world().get::<LavaState>(field).unwrap();
    let frozen = state.flow.budget().solidified;
    assert!(frozen > 2.5, "only {frozen} m³ of 3 froze");
    let solid_max = state.flow.solid().data().iter().fold(0.0f64, |m, &v| m.max(v));
    // Terrain nodes are 1 m apart, field cells 0.5 m: each node takes the volume of the cells
    // over its footprint, so the terrain's record gains the frozen volume exactly, and its
    // f32 heights to their rounding.
    let rise: Vec<f64> = after.iter().zip(&before).map(|(&a, &b)| (a - b) as f64).collect();
    let gained: f64 = rise.iter().sum();
    assert!((gained - frozen).abs() < 1e-4 * frozen, "terrain gained {gained} m³, {frozen} m³ froze");
    let w = app.world_mut();
    let recorded = w.query::<&Terrain>().single(w).unwrap().added_volume();
    assert!((recorded - frozen).abs() < 1e-12 * frozen, "terrain record {recorded} m³, {frozen} m³ froze");
    let peak = rise.iter().fold(0.0f64, |m, &r| m.max(r));
    assert!(peak > 0.5 * solid_max && peak <= solid_max + 1e-4, "peak rise {peak}, layer up to {solid_max}");
    assert!(rise.iter().all(|&r| r >= -1e-6), "the terrain only rises");
}

/// The despawn rule for lava: despawning a patch removes its lava (state, supply,
/// probes) and leaves what froze in the terrain; a patch built later over the same nodes starts
/// on that raised ground.
#[test]
fn despawning_a_patch_removes_its_lava_and_keeps_what_froze_in_the_terrain() {
    let mut app = app();
    let placement = Placement { centre: Vec2::ZERO, nx: 64, ny: 64, cell: 0.5 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    let source = app.world_mut().spawn(source(Vec3::new(0.0, 10.0, -6.0), 0.1, 1473.0).unwrap()).id();
    run(&mut app, 1);
    let ground_before: Vec<f64> = app.world().get::<LavaState>(field).unwrap().flow.ground().data().to_vec();
    // 3 m³ just above the solidus beside the live source: it freezes within seconds.
    let mut state = app.world_mut().get_mut::<LavaState>(field).unwrap();
    state.flow.place_volume(Vec2::new(0.0, 4.0), 3.0, 3.0, 1273.2).unwrap();
    // To tick 225: the last one writes back (once a second at half past: ticks 25, 75, …).
    run(&mut app, 224);
    let terrain = |app: &mut App| {
        let w = app.world_mut();
        let t = w.query::<&Terrain>().single(w).unwrap();
        (t.added_volume(), t.heights().data().to_vec())
    };
    let (added, heights) = terrain(&mut app);
    assert!(added > 2.5, "only {added} m³ written back");
    assert!(app.world().resource::<Probe>().0.is_some(), "lava under the probe before the despawn");

    app.world_mut().entity_mut(field).despawn();
    // Past two more write-back ticks (275, 325).
    run(&mut app, 120);
    let w = app.world_mut();
    assert_eq!(w.query::<&LavaState>().iter(w).count(), 0, "no lava state survives its patch");
    assert!(w.resource::<Probe>().0.is_none(), "the query sees no lava");
    assert!(
        matches!(w.get::<LavaSourceStatus>(source), Some(LavaSourceStatus::Rejected(_))),
        "the source feeds nothing: {:?}",
        w.get::<LavaSourceStatus>(source)
    );
    let (added_after, heights_after) = terrain(&mut app);
    assert_eq!(added_after, added, "the frozen lava stays in the terrain's record");
    assert_eq!(heights_after, heights, "and in its heights");

    // A new patch over the same nodes stands on the frozen lava.
    let again = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    app.world_mut().entity_mut(source).despawn();
    run(&mut app, 1);
    let ground_after: Vec<f64> = app.world().get::<LavaState>(again).unwrap().flow.ground().data().to_vec();
    let raised: f64 = ground_after.iter().zip(&ground_before).map(|(a, b)| a - b).sum::<f64>() * 0.25;
    assert!(
        (raised - added).abs() < 0.05 * added,
        "the new patch's ground holds {raised} m³ more, the terrain {added} m³"
    );
    assert!(ground_after.iter().zip(&ground_before).all(|(a, b)| a >= &(b - 1e-4)));
}

/// A patch spawned with the scene (at startup) is built while the scene loads, so its first
/// tick carries no build (≈ 6 ms for a 256² patch in release): after the first update, which
/// runs the startup schedules and no fixed tick, it already has its state.
#[test]
fn a_patch_spawned_at_startup_is_built_before_the_first_tick() {
    let mut app = app();
    let placement = Placement { centre: Vec2::ZERO, nx: 64, ny: 64, cell: 0.5 };
    app.add_systems(Startup, move |mut commands: Commands| {
        commands.spawn(LavaField::new(placement, LavaParams::default()).unwrap());
    });
    app.update();
    assert_eq!(app.world().resource::<SimTick>().0, 0, "a fixed tick ran in the first update");
    let w = app.world_mut();
    let built = w.query::<(&LavaState, &LavaFieldStatus)>().iter(w).count();
    assert_eq!(built, 1, "the patch is not built before its first tick");
}

/// The despawn rule for a terrain under lava: the patch keeps its lava and goes on flowing on
/// its own ground (which holds the shape of the terrain it was built on), stops writing back
/// and says why (`TerrainLink::detached`); it is not rebuilt on flat ground.
#[test]
fn despawning_the_terrain_under_a_patch_keeps_its_lava() {
    let mut app = app();
    let placement = Placement { centre: Vec2::ZERO, nx: 64, ny: 64, cell: 0.5 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    app.world_mut().spawn(source(Vec3::new(0.0, 10.0, -6.0), 0.3, 1473.0).unwrap());
    run(&mut app, 100);
    let state = app.world().get::<LavaState>(field).unwrap();
    let (volume, ground) = (state.flow.lava_volume(), state.flow.ground().data().to_vec());
    assert!(volume > 0.5, "only {volume} m³ of lava before the despawn");
    let w = app.world_mut();
    let terrain = w.query_filtered::<Entity, With<Terrain>>().single(w).unwrap();
    w.entity_mut(terrain).despawn();
    run(&mut app, 60);
    let w = app.world();
    let state = w.get::<LavaState>(field).expect("the patch keeps its state");
    let moved =
        state.flow.ground().data().iter().zip(&ground).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    // Rebuilt on flat ground it would have moved by metres (the slope); lava freezing into the
    // ground moves it by micrometres here.
    assert!(moved < 1e-3, "the ground is the terrain's, not rebuilt: moved by up to {moved} m");
    assert!(
        state.flow.lava_volume() > volume,
        "the lava kept flowing: {} m³, {volume} before",
        state.flow.lava_volume()
    );
    let link = state.imprint.as_ref().expect("the link to the terrain is kept");
    assert!(link.detached.is_some(), "the patch says why it no longer writes back");
    assert_eq!(w.get::<LavaFieldStatus>(field), Some(&LavaFieldStatus::Ok));
}
