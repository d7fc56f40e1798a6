//! Whatever fixed timestep a game runs at, from 1 ms to 1 s, the whole volcano keeps going:
//! the column emits at its rate, the weather steps once a simulated second, the lava is fed
//! at its rate with closed accounts, no guard has to act, and the same simulated time passes.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::lava::LavaState;
use volcano::plume::EmissionState;
use volcano::prelude::*;

use crate::worlds;

#[derive(Resource, Default)]
struct Seen {
    weather: usize,
    faults: Vec<SimFault>,
}

fn record(mut w: MessageReader<WeatherStepped>, mut f: MessageReader<SimFault>, mut seen: ResMut<Seen>) {
    seen.weather += w.read().count();
    seen.faults.extend(f.read().cloned());
}

/// What one run ended with.
#[derive(Debug)]
struct Outcome {
    ticks: u64,
    emitted: u64,
    expected_emitted: f64,
    weather: usize,
    fed_m3: f64,
    lava_error: f64,
}

const SECONDS: u64 = 6;
const LAVA_RATE: f64 = 0.05;

fn run_at(step: Duration) -> Outcome {
    let mut app = App::new();
    // Frames of at least 20 ms and at most Time<Virtual>'s 250 ms clamp.
    let frame = step.clamp(Duration::from_millis(20), Duration::from_millis(250));
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins))
        .insert_resource(Time::<Fixed>::from_duration(step))
        .insert_resource(TimeUpdateStrategy::ManualDuration(frame))
        .init_resource::<Seen>()
        .add_systems(Last, record);
    let terrain = worlds::small_island();
    let world = app.world_mut();
    let mut commands = world.commands();
    worlds::air_and_flank_lava(&mut commands, &terrain, LAVA_RATE);
    commands.spawn(terrain);
    let eruption = Eruption::plinian();
    let interval = eruption.params.emission_interval();
    let volcano = commands.spawn((Volcano::new(100.0, 3).unwrap(), eruption, Transform::default())).id();
    world.flush();
    let ticks = SECONDS * 1_000_000_000 / step.as_nanos() as u64;
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
    let world = app.world_mut();
    let emitted = world.get::<EmissionState>(volcano).unwrap().emitted;
    let state = world.query::<&LavaState>().single(world).unwrap();
    let b = *state.flow.budget();
    let seen = world.resource::<Seen>();
    assert!(seen.faults.is_empty(), "{step:?}: {:?}", seen.faults);
    Outcome {
        ticks: world.resource::<SimTick>().0,
        emitted,
        expected_emitted: world.resource::<SimControl>().simulated().as_secs_f64() / interval,
        weather: seen.weather,
        fed_m3: b.sources,
        lava_error: b.error_rel(state.flow.lava_volume()),
    }
}

#[test]
fn every_fixed_timestep_from_1_ms_to_1_s_keeps_the_volcano_going() {
    for ms in [1, 4, 20, 100, 250, 500, 1000] {
        let step = Duration::from_millis(ms);
        let o = run_at(step);
        let simulated = o.ticks as f64 * step.as_secs_f64();
        assert!((simulated - SECONDS as f64).abs() < 1e-9, "{ms} ms: {o:?}");
        // Emission follows simulated time (one slice in hand at most either way).
        assert!((o.emitted as f64 - o.expected_emitted).abs() <= 1.0, "{ms} ms: {o:?}");
        assert!(o.emitted > 5, "{ms} ms: {o:?}");
        // One weather step per simulated second, the last one possibly still in flight.
        assert!(o.weather + 1 >= SECONDS as usize && o.weather <= SECONDS as usize, "{ms} ms: {o:?}");
        // The lava is fed for every simulated second and its accounts close.
        assert!((o.fed_m3 - LAVA_RATE * SECONDS as f64).abs() < 1e-9, "{ms} ms: {o:?}");
        assert!(o.lava_error < 1e-12, "{ms} ms: {o:?}");
    }
}
