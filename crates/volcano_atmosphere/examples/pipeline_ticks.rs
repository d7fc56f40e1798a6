//! Main-thread cost of base ticks with and without the weather step off the main thread (not a
//! benchmark, no thresholds): a headless app with one `convection` atmosphere (3 layers) on an
//! `n × n` grid, weather every 50 ticks, ticks paced at 50 Hz of wall time like a game.
//!
//! `cargo run --release -p volcano_atmosphere --example pipeline_ticks -- 512 6`
//! (grid, simulated seconds).

use std::time::{Duration, Instant};

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_atmosphere::{
    AtmospherePlugin, WeatherPipelineSettings, WeatherPipelineStatus, WeatherScenario, spawn_scenario,
};
use volcano_core::prelude::*;

fn run(grid: usize, seconds: u64, off_thread: bool) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, AtmospherePlugin::default()))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(WeatherPipelineSettings { off_thread, ..default() });
    let scenario = WeatherScenario::builtin("convection").expect("built-in scenario");
    app.add_systems(Startup, move |mut commands: Commands| {
        spawn_scenario(&mut commands, &scenario, Some(grid)).expect("valid scenario");
    });
    app.finish();
    app.cleanup();
    app.update(); // Startup; zero delta, no tick.
    let (mut weather, mut other) = (Vec::new(), Vec::new());
    let period = Duration::from_millis(20);
    while app.world().resource::<SimTick>().0 < 50 * seconds {
        let t0 = Instant::now();
        app.update();
        let spent = t0.elapsed();
        let tick = app.world().resource::<SimTick>().0;
        if tick.is_multiple_of(50) {
            weather.push(spent)
        } else {
            other.push(spent)
        }
        if let Some(rest) = period.checked_sub(spent) {
            std::thread::sleep(rest);
        }
    }
    let world = app.world_mut();
    let status = world.query::<&WeatherPipelineStatus>().single(world).expect("one atmosphere").clone();
    let ms = |d: &Duration| d.as_secs_f64() * 1e3;
    let stats = |v: &[Duration]| {
        let mean = v.iter().map(ms).sum::<f64>() / v.len().max(1) as f64;
        let max = v.iter().map(ms).fold(0.0, f64::max);
        (mean, max)
    };
    let (wm, wx) = stats(&weather[1..]);
    let (om, ox) = stats(&other);
    println!(
        "{grid}² × 3, off_thread {off_thread}: weather ticks mean {wm:.2} ms max {wx:.2} ms ({} ticks, first \
         skipped: {:.2} ms); other ticks mean {om:.3} ms max {ox:.2} ms ({} ticks); last start {:.2} ms, \
         last write-back {:.2} ms, write-backs that waited {} of {}",
        weather.len() - 1,
        ms(&weather[0]),
        other.len(),
        status.last_start_ms,
        status.last_apply_ms,
        status.waited,
        status.applied,
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let grid = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(512);
    let seconds = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(6);
    for off_thread in [false, true] {
        run(grid, seconds, off_thread);
    }
}
