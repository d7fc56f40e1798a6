//! An eruption scripted by a timeline: a Plinian column that weakens collapses into
//! pyroclastic flows after the ramp and not before, while the same column left alone stands;
//! a preset key switches the preset once and keeps the eruption's environment.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_plume::*;

#[derive(Resource, Default, Debug)]
struct Collapses(Vec<u64>);

fn count(mut seen: ResMut<Collapses>, tick: Res<SimTick>, mut c: MessageReader<PlumeCollapsed>) {
    for _ in c.read() {
        seen.0.push(tick.0);
    }
}

fn app(script: Option<EruptionScript>, ticks_per_update: u32) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20) * ticks_per_update))
        .init_resource::<Collapses>()
        .add_systems(FixedUpdate, count.in_set(SimSystems::End));
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    let mut volcano =
        app.world_mut().spawn((Volcano::new(100.0, 11).unwrap(), Eruption::plinian(), Transform::default()));
    if let Some(script) = script {
        volcano.insert(script);
    }
    app
}

fn run(app: &mut App, ticks: u64) {
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
}

fn eruption(app: &mut App) -> Eruption {
    app.world_mut().query::<&Eruption>().single(app.world()).unwrap().clone()
}

#[test]
fn a_plinian_column_that_weakens_collapses_after_the_ramp() {
    // 200 m/s for 20 s, down to 70 m/s (the collapsing showcase's speed) by 25 s.
    let timeline = EruptionTimeline::from_ron(
        "(keys: [(at_s: 0, v0: Some(200)), (at_s: 20, v0: Some(200)), (at_s: 25, v0: Some(70))])",
    )
    .unwrap();
    let ticks = 50 * 55;
    let mut scripted = app(Some(EruptionScript::new(timeline).unwrap()), 5);
    run(&mut scripted, ticks);
    let collapses = scripted.world().resource::<Collapses>().0.clone();
    assert_eq!(eruption(&mut scripted).params.v0, 70.0);
    assert!(!collapses.is_empty(), "the weakened column never collapsed");
    assert!(collapses[0] > 50 * 20, "collapsed at tick {} before the ramp began", collapses[0]);

    let mut alone = app(None, 5);
    run(&mut alone, ticks);
    assert!(
        alone.world().resource::<Collapses>().0.is_empty(),
        "the Plinian column collapsed without a script"
    );
}

#[test]
fn a_preset_key_switches_once_and_keeps_the_environment() {
    let timeline =
        EruptionTimeline::from_ron("(keys: [(at_s: 0), (at_s: 1, preset: Some(PyroclasticShowcase))])")
            .unwrap();
    let mut app = app(Some(EruptionScript::new(timeline).unwrap()), 1);
    let wind = WindProfile::Linear { max: 7.0, top: 5_000.0, direction_deg: 30.0 };
    {
        let world = app.world_mut();
        let mut e = world.query::<&mut Eruption>().single_mut(world).unwrap();
        e.params.wind = wind.clone();
    }
    run(&mut app, 40);
    assert_eq!(eruption(&mut app).params.v0, 200.0, "before the key");
    run(&mut app, 60);
    let e = eruption(&mut app);
    let before = Preset::PlinianShowcase.params();
    let expected = PlumeParams {
        wind: wind.clone(),
        atmosphere: before.atmosphere,
        relative_humidity: before.relative_humidity,
        vent_altitude: before.vent_altitude,
        ..Preset::PyroclasticShowcase.params()
    };
    assert_eq!(e.params, expected);
    assert_eq!(e.params.v0, 70.0);
    // A later edit by the game is not undone by the same key.
    {
        let world = app.world_mut();
        world.query::<&mut Eruption>().single_mut(world).unwrap().params.tau = 3.0;
    }
    run(&mut app, 100);
    assert_eq!(eruption(&mut app).params.tau, 3.0);
}

#[test]
fn a_script_follows_plume_time_whatever_the_frame_rate() {
    let timeline = EruptionTimeline::from_ron(
        "(keys: [(at_s: 0, v0: Some(200)), (at_s: 3, v0: Some(120), active: Some(false))])",
    )
    .unwrap();
    let params = |ticks_per_update| {
        let mut app = app(Some(EruptionScript::new(timeline.clone()).unwrap()), ticks_per_update);
        run(&mut app, 100);
        let script = app.world_mut().query::<&EruptionScript>().single(app.world()).unwrap().clone();
        (eruption(&mut app).params.v0, script.elapsed_s)
    };
    let (one, five) = (params(1), params(5));
    assert_eq!(one, five);
    // 100 ticks = 2 s of plume time: two thirds of the way down the ramp.
    assert!((one.1 - 2.0).abs() < 1e-9, "{one:?}");
    assert!((one.0 - (200.0 - 80.0 * (2.0 - 0.002) / 3.0)).abs() < 1e-9, "{one:?}");
}
