//! The weather's background priority (`WeatherPipelineSettings::background_nice`, Linux): an
//! off-thread step runs on threads of its own, lowered by the setting's nice increment when
//! they were created; Bevy's threads and the main thread keep their nice; with the setting at 0
//! the step runs on Bevy's async compute pool as before and no such thread exists; the state
//! is bit-identical either way.
//!
//! One test function on purpose: the checks look at every thread of the process
//! (`/proc/self/task`), so nothing else may create weather threads while they run.
#![cfg(target_os = "linux")]

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_atmosphere::model::fields::LayerFields;
use volcano_atmosphere::{
    AirLayer, AtmospherePlugin, Scenario, WeatherPipelineSettings, WeatherPipelineStatus,
    current_thread_nice, join_weather, spawn_scenario,
};
use volcano_core::prelude::*;

/// Runs the `mixed` scenario (32²) for 60 base ticks, a weather step every 5, and returns the
/// pipeline's status and the layers' fields.
fn run(background_nice: u8) -> (WeatherPipelineStatus, Vec<LayerFields>) {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        VolcanoCorePlugin,
        AtmospherePlugin { cadence: Cadence::EveryNthTick(5) },
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)))
    .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
    .insert_resource(WeatherPipelineSettings { background_nice, ..default() });
    let scenario = Scenario::builtin("mixed").unwrap();
    app.add_systems(Startup, move |mut commands: Commands| {
        spawn_scenario(&mut commands, &scenario, Some(32)).unwrap();
    });
    while app.world().resource::<SimTick>().0 < 60 {
        app.update();
    }
    join_weather(app.world_mut());
    let world = app.world_mut();
    let status = world.query::<&WeatherPipelineStatus>().single(world).unwrap().clone();
    let mut layers: Vec<(usize, LayerFields)> =
        world.query::<&AirLayer>().iter(world).map(|l| (l.index, (*l.fields).clone())).collect();
    layers.sort_by_key(|l| l.0);
    (status, layers.into_iter().map(|l| l.1).collect())
}

/// Every thread of this process whose name starts with `prefix`, with its nice value, read
/// from `/proc/self/task/TID/{comm,stat}` (nice is the 19th field of `stat`).
fn threads(prefix: &str) -> Vec<(String, i32)> {
    let mut found = Vec::new();
    for task in std::fs::read_dir("/proc/self/task").unwrap().flatten() {
        let (Ok(comm), Ok(stat)) = (
            std::fs::read_to_string(task.path().join("comm")),
            std::fs::read_to_string(task.path().join("stat")),
        ) else {
            continue; // the thread ended meanwhile
        };
        let name = comm.trim_end().to_string();
        if !name.starts_with(prefix) {
            continue;
        }
        // The fields after the parenthesised name start at the 3rd (the state).
        let rest = &stat[stat.rfind(')').unwrap() + 1..];
        let nice: i32 = rest.split_whitespace().nth(19 - 3).unwrap().parse().unwrap();
        found.push((name, nice));
    }
    found
}

#[test]
fn the_weather_runs_on_its_own_lowered_threads_and_no_other_thread_changes() {
    let base = current_thread_nice().expect("nice readable on Linux");
    assert!(base < 19, "run this test below nice 19 (is {base}): nothing could be lowered");

    // Off: the step runs on Bevy's async compute pool at the game's nice, as before.
    let (off, off_layers) = run(0);
    assert!(off.off_thread >= 10 && off.applied >= 10, "{off:?}");
    assert_eq!(off.last_step_nice, Some(base), "with background_nice 0 the step runs at the game's nice");
    assert!(threads("Weather+").is_empty(), "no weather pool without the setting: {:?}", threads("Weather+"));
    let bevy_async = threads("Async Compute");
    assert!(!bevy_async.is_empty(), "the app built Bevy's async compute pool");

    // On (the default, +10): the step ran on a weather thread lowered by 10.
    let default = WeatherPipelineSettings::default().background_nice;
    assert_eq!(default, 10);
    let (on, on_layers) = run(default);
    let lowered = (base + 10).min(19);
    assert!(on.off_thread >= 10 && on.applied >= 10, "{on:?}");
    assert_eq!(on.last_step_nice, Some(lowered), "the step ran on a lowered thread");
    let weather = threads("Weather+10");
    assert!(!weather.is_empty(), "the weather pool's threads exist");
    assert!(weather.iter().all(|(_, n)| *n == lowered), "weather threads: {weather:?}");
    // Bevy's threads and this one keep the game's nice: nothing was lowered and left so.
    for prefix in ["Async Compute", "Compute Task", "IO Task"] {
        let bevy = threads(prefix);
        assert!(bevy.iter().all(|(_, n)| *n == base), "{prefix} threads changed: {bevy:?}");
    }
    assert_eq!(current_thread_nice(), Some(base));

    // The state does not depend on the thread or its priority (Debug prints tell -0.0 from 0.0).
    assert!(on_layers == off_layers, "the layers differ with and without the background pool");
    assert_eq!(format!("{on_layers:?}"), format!("{off_layers:?}"));

    // A level above 19 is capped: the step runs at nice 19.
    let (capped, _) = run(200);
    assert_eq!(capped.last_step_nice, Some(19));
}
