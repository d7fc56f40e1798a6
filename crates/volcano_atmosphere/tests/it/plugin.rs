//! The Bevy plugin steps the model on the weather cadence and keeps the fields on the layer
//! entities; the result matches calling the model directly with the same steps.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_atmosphere::model::step::{Workspace, step};
use volcano_atmosphere::{
    AirLayer, Atmosphere, AtmospherePlugin, WeatherScenario, WeatherStepped, spawn_atmosphere,
};
use volcano_core::prelude::*;

#[derive(Resource, Default)]
struct Steps(u32);

fn count(mut reader: MessageReader<WeatherStepped>, mut steps: ResMut<Steps>) {
    steps.0 += reader.read().count() as u32;
}

#[test]
fn plugin_steps_layers_like_the_model() {
    let scenario = WeatherScenario::builtin("convection").unwrap();
    let state = scenario.build(Some(16)).unwrap();
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        VolcanoCorePlugin,
        AtmospherePlugin { cadence: Cadence::EveryNthTick(5) },
    ))
    .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)))
    .init_resource::<Steps>()
    .add_systems(Update, count);
    let params = scenario.params.clone();
    let s2 = state.clone();
    app.add_systems(Startup, move |mut commands: Commands| {
        spawn_atmosphere(&mut commands, s2.clone(), params.clone()).unwrap();
    });
    for _ in 0..60 {
        app.update();
    }
    let steps = app.world().resource::<Steps>().0;
    assert!(steps >= 10, "weather stepped {steps} times");
    // Same number of 0.1 s steps directly on the model.
    let mut direct = state;
    let mut work = Workspace::new(&direct).unwrap();
    for _ in 0..steps {
        step(&mut direct, &scenario.params, &mut work, 0.1).unwrap();
    }
    let world = app.world_mut();
    let mut q = world.query::<&AirLayer>();
    let mut layers: Vec<&AirLayer> = q.iter(world).collect();
    layers.sort_by_key(|l| l.index);
    assert_eq!(layers.len(), 3);
    for (l, d) in layers.iter().zip(&direct.layers) {
        assert_eq!(l.fields.t, d.t, "layer {} temperature", l.index);
        assert_eq!(l.fields.h, d.h, "layer {} humidity", l.index);
    }
    let mut qa = world.query::<&Atmosphere>();
    let atmo = qa.single(world).unwrap();
    assert!((atmo.time_s - steps as f64 * 0.1).abs() < 1e-9);
}

#[test]
fn plugin_fires_timeline_events() {
    // The mixed scenario turns layer 2's wind to (−4, 6) m/s at 1800 s: run the weather with
    // 300 s steps (time scale) and check the event fired.
    let scenario = WeatherScenario::builtin("mixed").unwrap();
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        VolcanoCorePlugin,
        AtmospherePlugin { cadence: Cadence::EveryNthTick(1) },
    ))
    .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)));
    app.world_mut()
        .resource_mut::<Time<DomainClock<volcano_atmosphere::WeatherStep>>>()
        .context_mut()
        .set_time_scale(15_000.0)
        .unwrap();
    let sc = scenario.clone();
    app.add_systems(Startup, move |mut commands: Commands| {
        volcano_atmosphere::spawn_scenario(&mut commands, &sc, Some(16)).unwrap();
    });
    for _ in 0..12 {
        app.update();
    }
    let world = app.world_mut();
    let t = world.query::<&Atmosphere>().single(world).unwrap().time_s;
    assert!(t > 1800.0, "weather time {t}");
    let mut q = world.query::<&AirLayer>();
    let layer2 = q.iter(world).find(|l| l.index == 2).unwrap();
    assert_eq!(layer2.fields.wind, Vec2::new(-4.0, 6.0));
    let timeline = world.query::<&volcano_atmosphere::AtmosphereTimeline>().single(world).unwrap();
    assert!(timeline.0.is_empty(), "both events fired");
}

/// The layers' fields and the atmosphere's clock after spawning `spawn` in an empty world.
fn spawned(spawn: impl Fn(&mut Commands) -> Result<Entity, ConfigError>) -> Vec<String> {
    let mut world = World::new();
    spawn(&mut world.commands()).unwrap();
    world.flush();
    let time =
        world.query::<&Atmosphere>().iter(&world).map(|a| format!("t {}", a.time_s)).collect::<Vec<_>>();
    let mut layers: Vec<(usize, String)> =
        world.query::<&AirLayer>().iter(&world).map(|l| (l.index, format!("{:?}", l.fields))).collect();
    layers.sort_by_key(|(i, _)| *i);
    time.into_iter().chain(layers.into_iter().map(|(_, f)| f)).collect()
}

#[test]
fn the_spawner_builds_what_the_positional_call_builds() {
    let terrain =
        StratovolcanoParams { resolution: 64, cell: 400.0, ..Default::default() }.generate().unwrap();
    let t2 = terrain.clone();
    let by_name = spawned(move |c| {
        let scenario = WeatherScenario::builtin("eruption").unwrap();
        volcano_atmosphere::AtmosphereSpawner::new(&scenario).over(&terrain).grid(32).prespin(3).spawn(c)
    });
    let positional = spawned(move |c| {
        let scenario = WeatherScenario::builtin("eruption").unwrap();
        volcano_atmosphere::spawn_scenario_with(c, &scenario, Some(32), Some(&t2), 3)
    });
    assert!(by_name.len() > 2, "an atmosphere and its layers");
    assert_eq!(by_name, positional);
    // The options are not ignored: no prespin starts at the scenario's time zero.
    let fresh = spawned(|c| {
        let scenario = WeatherScenario::builtin("eruption").unwrap();
        volcano_atmosphere::AtmosphereSpawner::new(&scenario).grid(32).spawn(c)
    });
    assert_ne!(fresh[0], by_name[0], "prespun: {} / fresh: {}", by_name[0], fresh[0]);
    let bad = spawned_err(|c| {
        let scenario = WeatherScenario::builtin("eruption").unwrap();
        volcano_atmosphere::AtmosphereSpawner::new(&scenario).grid(0).spawn(c)
    });
    assert!(bad.contains("grid"), "{bad}");
}

fn spawned_err(spawn: impl Fn(&mut Commands) -> Result<Entity, ConfigError>) -> String {
    let mut world = World::new();
    let err = spawn(&mut world.commands()).unwrap_err().to_string();
    world.flush();
    assert_eq!(world.query::<&Atmosphere>().iter(&world).count(), 0, "an error spawns nothing");
    err
}
