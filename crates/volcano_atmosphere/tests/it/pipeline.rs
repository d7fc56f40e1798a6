//! The weather pipeline: a step started at weather tick k is written back at the next weather
//! tick, whichever thread ran it; the state does not depend on the frame rate; a flush writes a
//! step in flight back at once.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_atmosphere::model::fields::{Ground, LayerFields};
use volcano_atmosphere::model::step::{Workspace, step};
use volcano_atmosphere::{
    AirLayer, Atmosphere, AtmospherePlugin, AtmosphereState, WeatherPipelineSettings, WeatherPipelineStatus,
    WeatherScenario, WeatherStep, WeatherStepped, flush_weather, join_weather, spawn_atmosphere,
    spawn_scenario,
};
use volcano_core::prelude::*;

#[derive(Resource, Default)]
struct Stepped(Vec<(u64, u64)>);

fn record(mut reader: MessageReader<WeatherStepped>, mut seen: ResMut<Stepped>) {
    seen.0.extend(reader.read().map(|m| (m.started_tick, m.applied_tick)));
}

fn app(cadence: u32, ticks_per_update: u32, off_thread: bool) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        VolcanoCorePlugin,
        AtmospherePlugin { cadence: Cadence::EveryNthTick(cadence) },
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20) * ticks_per_update))
    .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
    .insert_resource(WeatherPipelineSettings { off_thread, ..default() })
    .init_resource::<Stepped>()
    .add_systems(Last, record);
    app
}

fn run(app: &mut App, ticks: u64) {
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
    assert_eq!(app.world().resource::<SimTick>().0, ticks, "overshot the tick count");
}

/// The components' layers (by index), ground and clock fields.
fn components(app: &mut App) -> (Vec<LayerFields>, f64, f64) {
    let world = app.world_mut();
    let mut layers: Vec<(usize, LayerFields)> =
        world.query::<&AirLayer>().iter(world).map(|l| (l.index, (*l.fields).clone())).collect();
    layers.sort_by_key(|l| l.0);
    let atmo = world.query::<&Atmosphere>().single(world).unwrap();
    (layers.into_iter().map(|l| l.1).collect(), atmo.time_s, atmo.precipitated)
}

fn direct(
    state: &AtmosphereState,
    params: &volcano_atmosphere::AtmosphereParams,
    steps: u32,
    dt: f64,
) -> AtmosphereState {
    let mut s = state.clone();
    let mut work = Workspace::new(&s).unwrap();
    for _ in 0..steps {
        step(&mut s, params, &mut work, dt).unwrap();
    }
    s
}

/// The built-in `convection` scenario on a 16² grid, spawned at start-up in an [`app`] that
/// steps the weather every 5 ticks off the main thread; the scenario and its initial state.
fn convection_app() -> (App, WeatherScenario, AtmosphereState) {
    let scenario = WeatherScenario::builtin("convection").unwrap();
    let state = scenario.build(Some(16)).unwrap();
    let mut app = app(5, 1, true);
    let (s2, params) = (state.clone(), scenario.params.clone());
    app.add_systems(Startup, move |mut commands: Commands| {
        spawn_atmosphere(&mut commands, s2.clone(), params.clone()).unwrap();
    });
    (app, scenario, state)
}

#[test]
fn components_hold_the_state_one_weather_step_behind_the_clock() {
    let (mut app, scenario, state) = convection_app();
    // Weather ticks 5, 10, …, 40: eight steps started, seven written back.
    run(&mut app, 42);
    let clock_steps = app.world().resource::<Time<DomainClock<WeatherStep>>>().context().steps_run();
    assert_eq!(clock_steps, 8);
    let behind = direct(&state, &scenario.params, 7, 0.1);
    let (layers, time_s, precipitated) = components(&mut app);
    assert!(layers == behind.layers, "the components hold seven steps, the eighth is in flight");
    assert_eq!((time_s, precipitated), (behind.time_s, behind.precipitated));
    let seen = app.world().resource::<Stepped>().0.clone();
    let want: Vec<(u64, u64)> = (1..8).map(|j| (5 * j, 5 * j + 5)).collect();
    assert_eq!(seen, want, "each step written back one cadence after it started");
    let world = app.world_mut();
    let status = world.query::<&WeatherPipelineStatus>().single(world).unwrap().clone();
    assert_eq!((status.started, status.applied, status.in_flight_since), (8, 7, Some(40)));
    assert_eq!(status.off_thread, 8, "MinimalPlugins has the AsyncComputeTaskPool");

    // Joining changes nothing; flushing writes the eighth step back now.
    assert_eq!(join_weather(app.world_mut()), 1);
    assert!(components(&mut app).0 == behind.layers, "joining changed the components");
    assert_eq!(flush_weather(app.world_mut()), 1);
    assert_eq!(flush_weather(app.world_mut()), 0, "nothing left in flight");
    let now = direct(&state, &scenario.params, 8, 0.1);
    let (layers, time_s, _) = components(&mut app);
    assert!(layers == now.layers, "the flush wrote back the eighth step");
    assert_eq!(time_s, now.time_s);
    assert_eq!(app.world().resource::<Stepped>().0.len(), 7, "the flush's message is read next update");
    app.update();
    assert_eq!(app.world().resource::<Stepped>().0.last(), Some(&(40, 42)));
}

/// Layers, ground, weather time, precipitation and events left of the single atmosphere.
type Full = (Vec<LayerFields>, Ground, f64, f64, usize);

/// Full state of the single atmosphere, for bit-for-bit comparisons.
fn snapshot_of(app: &mut App) -> Full {
    let (layers, time_s, precipitated) = components(app);
    let world = app.world_mut();
    let ground =
        world.query::<&volcano_atmosphere::plugin::AtmosphereGround>().single(world).unwrap().0.clone();
    let timeline = world.query::<&volcano_atmosphere::AtmosphereTimeline>().single(world).unwrap().0.len();
    (layers, ground, time_s, precipitated, timeline)
}

#[test]
fn off_thread_equals_on_the_spot_at_any_frame_rate() {
    // The mixed scenario (7 layers, terrain, timeline events at 1800 s and later) with 300 s
    // weather steps every 2 ticks, so the events fire inside the run.
    let scenario = WeatherScenario::builtin("mixed").unwrap();
    let runs: Vec<_> = [(true, 1), (true, 5), (false, 1), (false, 5)]
        .into_iter()
        .map(|(off_thread, per_update)| {
            let mut a = app(2, per_update, off_thread);
            a.world_mut()
                .resource_mut::<Time<DomainClock<WeatherStep>>>()
                .context_mut()
                .set_time_scale(7_500.0)
                .unwrap();
            let sc = scenario.clone();
            a.add_systems(Startup, move |mut commands: Commands| {
                spawn_scenario(&mut commands, &sc, Some(16)).unwrap();
            });
            run(&mut a, 30);
            let world = a.world_mut();
            let status = world.query::<&WeatherPipelineStatus>().single(world).unwrap().clone();
            assert_eq!(status.off_thread, if off_thread { 15 } else { 0 });
            (snapshot_of(&mut a), a.world().resource::<Stepped>().0.clone())
        })
        .collect();
    assert!(runs[0].0.2 > 1800.0, "weather time {} s: the first event is due", runs[0].0.2);
    assert!(runs[0].0.4 < scenario.events.len(), "a timeline event fired");
    for (i, r) in runs.iter().enumerate().skip(1) {
        assert!(r.0 == runs[0].0, "run {i} differs from off-thread at 1 tick per update");
        assert_eq!(r.1, runs[0].1, "run {i} wrote back at other ticks");
    }
}

#[test]
fn pausing_the_weather_writes_back_so_edits_while_paused_stay() {
    let (mut app, scenario, state) = convection_app();
    // Steps started at ticks 5 and 10; the first is written back at 10.
    run(&mut app, 12);
    app.world_mut().resource_mut::<Time<DomainClock<WeatherStep>>>().context_mut().set_paused(true);
    run(&mut app, 20);
    let mut expected = direct(&state, &scenario.params, 2, 0.1);
    assert!(components(&mut app).0 == expected.layers, "the paused weather shows both steps");
    // A stroke while paused (as the atmosphere window paints).
    {
        let world = app.world_mut();
        let mut q = world.query::<&mut AirLayer>();
        let mut layer = q.iter_mut(world).find(|l| l.index == 0).unwrap();
        layer.fields.t.data_mut()[17] = 250.0;
    }
    expected.layers[0].t.data_mut()[17] = 250.0;
    run(&mut app, 24);
    app.world_mut().resource_mut::<Time<DomainClock<WeatherStep>>>().context_mut().set_paused(false);
    // The clock saw 24 ticks, so the weather steps at 25 and 30; pause again to see the second.
    run(&mut app, 31);
    app.world_mut().resource_mut::<Time<DomainClock<WeatherStep>>>().context_mut().set_paused(true);
    run(&mut app, 32);
    let mut work = Workspace::new(&expected).unwrap();
    for _ in 0..2 {
        step(&mut expected, &scenario.params, &mut work, 0.1).unwrap();
    }
    let (layers, time_s, _) = components(&mut app);
    assert_eq!(time_s, expected.time_s);
    assert!(layers == expected.layers, "the stroke made while paused was kept and stepped");
}

/// A layer despawned and replaced by another of the same shape while a step is in flight does
/// not receive that step's result (computed from the layer it replaced): the result is dropped
/// and the new layer keeps what it was spawned with until a step started from it comes back.
#[test]
fn a_layer_replaced_during_a_step_keeps_its_own_fields() {
    let (mut app, ..) = convection_app();
    // A step started at tick 5 is in flight; replace layer 1 with a warmer copy.
    run(&mut app, 7);
    let world = app.world_mut();
    let (old, atmosphere, mut fields) = world
        .query::<(Entity, &AirLayer)>()
        .iter(world)
        .find(|(_, l)| l.index == 1)
        .map(|(e, l)| (e, l.atmosphere, (*l.fields).clone()))
        .unwrap();
    for t in fields.t.data_mut() {
        *t += 10.0;
    }
    world.entity_mut(old).despawn();
    let new = world
        .spawn((AirLayer { atmosphere, index: 1, fields: fields.clone().into() }, ChildOf(atmosphere)))
        .id();
    // Tick 10 writes back the step started at 5 and starts the next from the components.
    run(&mut app, 10);
    let world = app.world();
    let now = &*world.get::<AirLayer>(new).unwrap().fields;
    assert!(*now == fields, "the new layer received the step started before it existed");
    assert!(
        world.resource::<Stepped>().0.iter().all(|&(started, _)| started != 5),
        "the stale step was reported"
    );
}

#[derive(Resource, Default)]
struct Faults(Vec<SimFault>);

fn record_faults(mut reader: MessageReader<SimFault>, mut seen: ResMut<Faults>) {
    seen.0.extend(reader.read().cloned());
}

/// The water (g/m³ × m) of the cell `edit_nan` sets to NaN, once it did.
#[derive(Resource, Default)]
struct Edited(Option<(Entity, f64)>);

const EDIT_CELL: usize = 8 * 16 + 8;

/// At tick 10, after the write-back and before the next step starts (where the coupling writes
/// into the air), sets one temperature of the lowest layer to NaN.
fn edit_nan(tick: Res<SimTick>, mut layers: Query<&mut AirLayer>, mut edited: ResMut<Edited>) {
    if tick.0 != 10 {
        return;
    }
    let mut layer = layers.iter_mut().find(|l| l.index == 0).unwrap();
    let atmosphere = layer.atmosphere;
    let f = &mut *layer.fields;
    let k = EDIT_CELL;
    let held = (f.h.data()[k] + f.w.data()[k]) * f.thickness * f.sigma.data()[k] as f64;
    f.t.data_mut()[k] = f32::NAN;
    edited.0 = Some((atmosphere, held));
}

/// A cell made NaN between steps is reset by the next step's guard (on the worker) and reported
/// once as a `SimFault` when that step is written back; the water it held is booked.
#[test]
fn a_non_finite_cell_is_repaired_by_the_next_step_and_reported() {
    let (mut app, ..) = convection_app();
    app.init_resource::<Faults>().init_resource::<Edited>().add_systems(Last, record_faults).add_systems(
        FixedUpdate,
        edit_nan.in_set(SimSystems::BeforeWeather).after(volcano_atmosphere::WeatherSystems::Apply),
    );
    // The step started at tick 10 reads the edit; it is written back at tick 15.
    run(&mut app, 14);
    assert!(app.world().resource::<Faults>().0.is_empty());
    let (atmosphere, held) = app.world().resource::<Edited>().0.unwrap();
    run(&mut app, 15);
    let faults = std::mem::take(&mut app.world_mut().resource_mut::<Faults>().0);
    assert_eq!(faults.len(), 1, "{faults:?}");
    let f = &faults[0];
    assert_eq!((f.entity, f.domain, f.repaired), (atmosphere, SimDomain::Atmosphere, 1));
    let dx = app.world().get::<Atmosphere>(atmosphere).unwrap().dx;
    let held_kg = held * dx * dx * 1e-3;
    assert!(held_kg > 0.0 && (f.lost_water_kg - held_kg).abs() <= 1e-9 * held_kg, "{f:?}, {held_kg}");
    let (layers, ..) = components(&mut app);
    assert!(layers.iter().all(|l| l.is_valid()));
    run(&mut app, 40);
    assert!(app.world().resource::<Faults>().0.is_empty(), "one repair, one report");
}

/// An event a game pushes into the timeline is checked when it fires: a NaN wind (which on its
/// worker would turn the layer's wind to NaN and panic in the advection's indexing) is dropped
/// with a warning, and the weather goes on stepping.
#[test]
fn a_bad_timeline_event_is_dropped_not_run() {
    use volcano_atmosphere::AtmosphereTimeline;
    use volcano_atmosphere::model::scenario::{Event, EventAction};
    let (mut app, ..) = convection_app();
    run(&mut app, 7);
    let world = app.world_mut();
    let atmosphere = world.query_filtered::<Entity, With<Atmosphere>>().single(world).unwrap();
    let bad = Event { at_s: 0.0, layer: 0, action: EventAction::SetWind(f32::NAN, 0.0) };
    let good = Event { at_s: 0.0, layer: 1, action: EventAction::SetWind(3.0, 0.0) };
    world.entity_mut(atmosphere).insert(AtmosphereTimeline(vec![bad, good]));
    let steps = world.resource::<Stepped>().0.len();
    run(&mut app, 40);
    assert!(app.world().resource::<Stepped>().0.len() >= steps + 5, "the weather kept stepping");
    let (layers, ..) = components(&mut app);
    assert!(layers.iter().all(|l| l.is_valid() && l.wind.is_finite()));
    assert_eq!(layers[1].wind, Vec2::new(3.0, 0.0), "the valid event ran");
    let left = app.world().get::<AtmosphereTimeline>(atmosphere).unwrap();
    assert!(left.0.is_empty(), "both fired (one dropped)");
}
