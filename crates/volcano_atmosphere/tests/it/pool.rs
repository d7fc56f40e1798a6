//! One deterministic parallel helper on Bevy's pools for every domain, and the off-thread
//! weather pipeline beside it: the weather step's bands run on the async compute pool, so the
//! system that joins the step never waits for itself (`volcano_core::parallel`'s module docs).
//!
//! With the bands on the compute pool, the weather task's thread helped with them by running
//! queued compute-pool tasks, among them the system that joins the weather task: the app hung
//! (first seen as `tests/pipeline.rs` running for over a minute instead of 0.1 s). This test
//! makes that likely: the pools of a two-core machine (one compute thread), a weather step
//! every tick and three systems per tick that run bands of their own on the compute pool, so
//! system tasks queue while the weather step runs. A watchdog turns a hang into a failure.

use std::sync::mpsc;
use std::time::Duration;

use bevy::app::{TaskPoolOptions, TaskPoolPlugin};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_atmosphere::{
    AtmospherePlugin, WeatherPipelineSettings, WeatherPipelineStatus, WeatherScenario, join_weather,
    spawn_scenario,
};
use volcano_core::parallel::{self, Bands};
use volcano_core::prelude::*;

/// A system that runs bands on the compute pool each tick, as lava and pyroclastic steps do.
fn busy(mut buffer: Local<Vec<f64>>) {
    let n = 256;
    if buffer.is_empty() {
        *buffer = vec![1.0; n * 128];
    }
    Bands::of(8).for_each_row(buffer.as_mut_slice(), n, |j, row| {
        for x in row.iter_mut() {
            *x = (*x * 1.000_001 + j as f64).sqrt();
        }
    });
}

const TICKS: u64 = 120;

fn run_app() -> WeatherPipelineStatus {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins.set(TaskPoolPlugin { task_pool_options: TaskPoolOptions::with_num_threads(2) }),
        VolcanoCorePlugin,
        AtmospherePlugin { cadence: Cadence::EveryNthTick(1) },
    ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)))
    .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
    // An hour's start delay: the run can only finish because each join (every tick joins the
    // step before) ends the delay at once.
    .insert_resource(WeatherPipelineSettings { off_thread: true, start_delay: Duration::from_secs(3600) })
    .add_systems(FixedUpdate, (busy, busy, busy));
    let scenario = WeatherScenario::builtin("mixed").unwrap();
    app.add_systems(Startup, move |mut commands: Commands| {
        spawn_scenario(&mut commands, &scenario, Some(64)).unwrap();
    });
    while app.world().resource::<SimTick>().0 < TICKS {
        app.update();
    }
    // The last step in flight would otherwise keep the async pool's thread for the hour.
    join_weather(app.world_mut());
    let world = app.world_mut();
    world.query::<&WeatherPipelineStatus>().single(world).unwrap().clone()
}

#[test]
fn the_off_thread_weather_finishes_beside_systems_running_bands() {
    let (done, finished) = mpsc::channel();
    std::thread::spawn(move || done.send(run_app()).unwrap());
    // Far above the few seconds the run takes (debug build, loaded machine); a hung app never
    // answers. Not a timing assertion: only a run that cannot finish fails here.
    let status = finished
        .recv_timeout(Duration::from_secs(600))
        .expect("the app did not finish 120 ticks in 10 minutes: the weather pipeline deadlocked or a join waited for the start delay");
    assert_eq!(status.off_thread, TICKS, "every weather step ran as a task");
    assert!(status.started >= TICKS);
}

#[test]
fn nested_calls_stay_on_the_pool_of_the_outer_call() {
    // A band started on the async compute pool runs its own bands there too (it carries the
    // pool along), and the caller's setting is restored afterwards.
    let pools = parallel::on_pool(parallel::Pool::AsyncCompute, || {
        parallel::par_map((0..4).collect(), |_, _: u32| {
            let inner = Bands::of(1).map_ranges(4, |_| parallel::Pool::current());
            (parallel::Pool::current(), inner)
        })
    });
    for (outer, inner) in pools {
        assert_eq!(outer, parallel::Pool::AsyncCompute);
        assert!(inner.iter().all(|p| *p == parallel::Pool::AsyncCompute));
    }
    assert_eq!(parallel::Pool::current(), parallel::Pool::Compute);
}
