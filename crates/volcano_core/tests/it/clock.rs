//! Multi-rate clock: cadence exactness, ordering, pause/step, time scale, and frame-rate
//! independence of a seeded simulation.

use std::time::Duration;

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use rand::RngExt;
use volcano_core::prelude::*;

#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, bevy::reflect::TypePath)]
struct FastStep;
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, bevy::reflect::TypePath)]
struct SlowStep;

/// (domain, tick, delta, elapsed) for every domain step, in execution order.
#[derive(Resource, Default)]
struct Log(Vec<(&'static str, u64, Duration, Duration)>);

fn log_fast(mut log: ResMut<Log>, time: Res<Time>, tick: Res<SimTick>) {
    log.0.push(("fast", tick.0, time.delta(), time.elapsed()));
}
fn log_slow(mut log: ResMut<Log>, time: Res<Time>, tick: Res<SimTick>) {
    log.0.push(("slow", tick.0, time.delta(), time.elapsed()));
}

/// An app whose every update advances virtual time by `ticks_per_update` base ticks.
fn app(ticks_per_update: u32) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20) * ticks_per_update));
    app
}

fn run_until_tick(app: &mut App, tick: u64) {
    for _ in 0..100_000 {
        if app.world().resource::<SimTick>().0 >= tick {
            break;
        }
        app.update();
    }
    assert_eq!(app.world().resource::<SimTick>().0, tick, "overshot the target tick");
}

fn logging_app(ticks_per_update: u32) -> App {
    let mut app = app(ticks_per_update);
    app.init_resource::<Log>()
        // Registered in reverse order on purpose: the set order must win.
        .add_sim_domain::<SlowStep>(SimSystems::Weather, Cadence::EveryNthTick(5))
        .add_sim_domain::<FastStep>(SimSystems::Plume, Cadence::Substeps(10))
        .add_systems(SlowStep, log_slow)
        .add_systems(FastStep, log_fast);
    app
}

#[test]
fn cadences_are_exact_and_ordered() {
    const K: u64 = 200;
    let mut app = logging_app(1);
    run_until_tick(&mut app, K);
    let log = &app.world().resource::<Log>().0;
    let fast: Vec<_> = log.iter().filter(|e| e.0 == "fast").collect();
    let slow: Vec<_> = log.iter().filter(|e| e.0 == "slow").collect();
    assert_eq!(fast.len() as u64, 10 * K, "Substeps(10) must run 10 steps per base tick");
    assert_eq!(slow.len() as u64, K / 5, "EveryNthTick(5) must run once per 5 ticks");
    assert!(fast.iter().all(|e| e.2 == Duration::from_millis(2)), "fast Δt must be exactly 2 ms");
    assert!(slow.iter().all(|e| e.2 == Duration::from_millis(100)), "slow Δt must be exactly 100 ms");
    assert_eq!(fast.last().unwrap().3, Duration::from_millis(20) * K as u32);
    assert_eq!(slow.last().unwrap().3, Duration::from_millis(20) * K as u32);
    // Slow steps happen at ticks 5, 10, …, and within a tick after all fast steps.
    assert!(slow.iter().all(|e| e.1 % 5 == 0));
    for (i, e) in log.iter().enumerate() {
        if e.0 == "slow" {
            let same_tick_fast_after = log[i..].iter().any(|f| f.0 == "fast" && f.1 == e.1);
            assert!(!same_tick_fast_after, "weather ran before the plume in tick {}", e.1);
            assert_eq!(log[..i].iter().filter(|f| f.0 == "fast" && f.1 == e.1).count(), 10);
        }
    }
    // The generic clock is restored after the domains ran.
    assert_eq!(app.world().resource::<Time>().delta(), Duration::from_millis(20));
}

#[test]
fn pause_single_step_and_time_scale() {
    let mut app = logging_app(1);
    run_until_tick(&mut app, 10);
    app.world_mut().resource_mut::<SimControl>().paused = true;
    for _ in 0..20 {
        app.update();
    }
    assert_eq!(app.world().resource::<SimTick>().0, 10, "paused simulation must not tick");
    app.world_mut().resource_mut::<SimControl>().step_ticks(3);
    for _ in 0..20 {
        app.update();
    }
    assert_eq!(app.world().resource::<SimTick>().0, 13, "three single steps");
    app.world_mut().resource_mut::<SimControl>().paused = false;

    // Pause the fast domain alone: ticks go on, its steps do not.
    let before = app.world().resource::<Time<DomainClock<FastStep>>>().context().steps_run();
    app.world_mut().resource_mut::<Time<DomainClock<FastStep>>>().context_mut().set_paused(true);
    run_until_tick(&mut app, 20);
    let c = app.world().resource::<Time<DomainClock<FastStep>>>().context().clone();
    assert_eq!(c.steps_run(), before);
    app.world_mut().resource_mut::<Time<DomainClock<FastStep>>>().context_mut().request_steps(2);
    run_until_tick(&mut app, 25);
    let c = app.world().resource::<Time<DomainClock<FastStep>>>().context().clone();
    assert_eq!(c.steps_run(), before + 2, "two single domain steps");

    // Time scale: the weather advancing 30 s per step (standalone skyscape, thesis §4.2.7.2).
    {
        let mut clock = app.world_mut().resource_mut::<Time<DomainClock<SlowStep>>>();
        clock.context_mut().set_cadence(Cadence::EveryNthTick(50)).unwrap();
        clock.context_mut().set_time_scale(300.0).unwrap();
        assert!(clock.context_mut().set_time_scale(f64::NAN).is_err());
        assert!(clock.context_mut().set_time_scale(0.0).is_err());
        assert!(clock.context_mut().set_cadence(Cadence::Substeps(0)).is_err());
    }
    app.world_mut().resource_mut::<Log>().0.clear();
    run_until_tick(&mut app, 125);
    let slow: Vec<_> =
        app.world().resource::<Log>().0.iter().filter(|e| e.0 == "slow").map(|e| e.2).collect();
    assert_eq!(slow, vec![Duration::from_secs(300); 2], "ticks 50 and 100 of the domain → 2 steps");
}

/// A toy seeded process standing in for a domain model: damped velocity with random kicks.
#[derive(Component, Default, Debug, Clone, Copy, PartialEq)]
struct Toy {
    x: f64,
    v: f64,
}

fn toy_step(time: Res<Time>, mut q: Query<(&mut Toy, &mut VolcanoRng)>) {
    let dt = time.delta_secs_f64();
    for (mut toy, mut rng) in &mut q {
        let kick: f64 = rng.rng().random_range(-1.0..1.0);
        toy.v += (-0.5 * toy.v + 3.0 * kick) * dt;
        toy.x += toy.v * dt;
    }
}

fn toy_app(ticks_per_update: u32) -> App {
    let mut app = app(ticks_per_update);
    app.add_sim_domain::<FastStep>(SimSystems::Plume, Cadence::Substeps(3))
        .add_sim_domain::<SlowStep>(SimSystems::Lava, Cadence::EveryNthTick(7))
        .add_systems(FastStep, toy_step)
        .add_systems(SlowStep, toy_step);
    for seed in [1, 2] {
        app.world_mut().spawn((Volcano::new(50.0, seed).unwrap(), Toy::default()));
    }
    app
}

fn toy_state(app: &mut App) -> Vec<(u64, Toy)> {
    let mut q = app.world_mut().query::<(&Volcano, &Toy)>();
    let mut v: Vec<_> = q.iter(app.world()).map(|(vol, t)| (vol.seed(), *t)).collect();
    v.sort_by_key(|e| e.0);
    v
}

#[test]
fn frame_rate_independence_is_bit_exact() {
    let mut one = toy_app(1);
    let mut five = toy_app(5);
    run_until_tick(&mut one, 1_000);
    run_until_tick(&mut five, 1_000);
    let a = toy_state(&mut one);
    let b = toy_state(&mut five);
    assert_eq!(a.len(), 2);
    // Bit-identical, not approximately equal.
    for ((sa, ta), (sb, tb)) in a.iter().zip(&b) {
        assert_eq!(sa, sb);
        assert_eq!(ta.x.to_bits(), tb.x.to_bits(), "x differs for seed {sa}: {} vs {}", ta.x, tb.x);
        assert_eq!(ta.v.to_bits(), tb.v.to_bits());
    }
    // The process actually moved, and the two seeds differ.
    assert!(a[0].1.x != 0.0 && a[0].1.x != a[1].1.x);
}

#[test]
fn vent_snaps_to_terrain() {
    let mut app = app(1);
    let mut terrain = Terrain::flat(65, 2.0, 0.0).unwrap();
    let mut g = terrain.heights_mut();
    for j in 0..65 {
        for i in 0..65 {
            let p = g.position(i, j);
            g.set(i, j, 100.0 + 0.5 * p.x);
        }
    }
    drop(g);
    app.world_mut().spawn(terrain);
    let v =
        app.world_mut().spawn((Volcano::new(10.0, 4).unwrap(), Transform::from_xyz(20.0, -999.0, 3.0))).id();
    app.update();
    app.update();
    let e = app.world().entity(v);
    assert!((e.get::<Transform>().unwrap().translation.y - 110.0).abs() < 1e-3);
    assert!((e.get::<VentPosition>().unwrap().0 - Vec3::new(20.0, 110.0, 3.0)).length() < 1e-3);
    assert_eq!(e.get::<VolcanoRng>().unwrap().seed(), 4);
}

/// An app at `hz` whose every update is one base tick.
fn app_at(hz: f64) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin)).insert_resource(Time::<Fixed>::from_hz(hz));
    let step = app.world().resource::<Time<Fixed>>().timestep();
    app.insert_resource(TimeUpdateStrategy::ManualDuration(step));
    app
}

#[test]
fn the_game_keeps_its_fixed_rate_and_periods_follow_it() {
    for (hz, per_second) in [(50.0, 50u64), (64.0, 64)] {
        let mut app = app_at(hz);
        app.init_resource::<Log>()
            .add_sim_domain::<SlowStep>(SimSystems::Weather, Cadence::Period(Duration::from_secs(1)))
            .add_systems(SlowStep, log_slow);
        run_until_tick(&mut app, 3 * per_second);
        let base = app.world().resource::<Time<Fixed>>().timestep();
        assert_eq!(base, Duration::from_nanos(1_000_000_000 / per_second), "{hz} Hz: the game's rate");
        let log = &app.world().resource::<Log>().0;
        let ticks: Vec<u64> = log.iter().map(|e| e.1).collect();
        assert_eq!(ticks, vec![per_second, 2 * per_second, 3 * per_second], "{hz} Hz: once per second");
        assert!(log.iter().all(|e| e.2 == Duration::from_secs(1)), "{hz} Hz: 1 s steps");
        assert_eq!(app.world().resource::<SimControl>().simulated(), Duration::from_secs(3));
    }
    // 60 Hz does not divide a second in whole nanoseconds: still one step per 60 ticks.
    assert_eq!(Cadence::Period(Duration::from_secs(1)).ticks_per_step(Duration::from_nanos(16_666_667)), 60);
    assert!(Cadence::Period(Duration::ZERO).validate().is_err());
}

#[test]
fn once_per_second_work_inside_a_domain_at_50_60_and_64_hz() {
    use volcano_core::clock::crossed_period;
    let second = Duration::from_secs(1);
    for hz in [50u32, 64] {
        let dt = Duration::from_nanos(1_000_000_000 / hz as u64);
        let hits: Vec<u32> = (1..=10 * hz).filter(|&k| crossed_period(dt * k, dt, second)).collect();
        assert_eq!(hits, (1..=10).map(|s| s * hz).collect::<Vec<_>>(), "{hz} Hz: on every 1 s step");
    }
    // 60 Hz steps are 16,666,666 ns: once per whole second of the domain's own time.
    let dt = Duration::from_nanos(16_666_666);
    let hits = (1..=6000u32).filter(|&k| crossed_period(dt * k, dt, second)).count() as u64;
    assert_eq!(hits, (dt * 6000).as_secs());
    assert!(!crossed_period(second, second, Duration::ZERO));
}

#[test]
fn work_at_quarter_seconds_offset_by_an_eighth_never_falls_on_a_whole_second() {
    use volcano_core::clock::{crossed_period, crossings};
    let (quarter, eighth) = (Duration::from_millis(250), Duration::from_millis(125));
    for hz in [50u32, 64] {
        let dt = Duration::from_nanos(1_000_000_000 / hz as u64);
        let n = |k: u32| crossings(dt * k, dt, quarter, eighth);
        // Four a second, whatever the rate, and none on the tick a whole second is crossed.
        assert_eq!((1..=10 * hz).map(&n).sum::<u64>(), 40, "{hz} Hz");
        assert!((1..=10 * hz).all(|k| n(k) == 0 || !crossed_period(dt * k, dt, Duration::from_secs(1))));
        // The first falls on the tick ending at or just after 0.125 s.
        let first = (1..=hz).find(|&k| n(k) > 0).unwrap();
        assert!(dt * first >= eighth && dt * (first - 1) < eighth, "{hz} Hz: tick {first}");
    }
    // A long step crosses several; a zero period none.
    assert_eq!(crossings(Duration::from_secs(1), Duration::from_secs(1), quarter, eighth), 4);
    assert_eq!(crossings(Duration::from_secs(1), Duration::from_secs(1), Duration::ZERO, eighth), 0);
}

#[test]
fn speed_scales_the_simulation_not_the_games_clocks() {
    let mut app = logging_app(1);
    app.world_mut().resource_mut::<SimControl>().set_speed(2.0).unwrap();
    run_until_tick(&mut app, 10);
    let fast = app.world().resource::<Time<DomainClock<FastStep>>>().elapsed();
    assert_eq!(fast, Duration::from_millis(400), "10 ticks of 20 ms at 2×");
    assert_eq!(app.world().resource::<SimControl>().simulated(), Duration::from_millis(400));
    assert_eq!(app.world().resource::<Time<Virtual>>().relative_speed(), 1.0, "the game's time untouched");
    assert_eq!(app.world().resource::<Time<Fixed>>().timestep(), Duration::from_millis(20));
    let mut control = app.world_mut().resource_mut::<SimControl>();
    assert!(control.set_speed(f64::NAN).is_err() && control.set_speed(0.0).is_err());
    assert!(control.set_speed(1e3).is_err());
    assert_eq!(control.speed(), 2.0, "a rejected speed leaves the old one");
}

/// Values written through reflection (an inspector, a loaded scene) bypass the setters'
/// validation: a NaN or negative speed, a NaN time scale and a zero or absurd substep count
/// are corrected at the next base tick, with the simulation still running and no panic
/// (`Duration::mul_f64` panics on a negative or NaN factor).
#[test]
fn reflected_speed_scale_and_cadence_are_corrected_not_fatal() {
    use bevy::reflect::{GetPath, PartialReflect};
    for (speed, scale, cadence, want_speed, want_scale, want_cadence) in [
        (f64::NAN, f64::NAN, Cadence::Substeps(0), 1.0, 1.0, Cadence::Substeps(1)),
        (-2.0, -3.0, Cadence::Substeps(u32::MAX), 0.01, 1e-6, Cadence::Substeps(Cadence::MAX_SUBSTEPS)),
        (1e9, f64::INFINITY, Cadence::EveryNthTick(0), 100.0, 1e6, Cadence::EveryNthTick(1)),
    ] {
        let mut app = logging_app(1);
        run_until_tick(&mut app, 3);
        let world = app.world_mut();
        *world
            .resource_mut::<SimControl>()
            .reflect_path_mut("speed")
            .unwrap()
            .try_downcast_mut::<f64>()
            .unwrap() = speed;
        {
            let mut clock = world.resource_mut::<Time<DomainClock<FastStep>>>();
            let ctx = clock.context_mut();
            *ctx.reflect_path_mut("time_scale").unwrap().try_downcast_mut::<f64>().unwrap() = scale;
            ctx.reflect_path_mut("cadence").unwrap().apply(cadence.as_partial_reflect());
        }
        let steps_before = world.resource::<Log>().0.len();
        run_until_tick(&mut app, 6);
        let world = app.world();
        assert_eq!(world.resource::<SimControl>().speed(), want_speed, "speed {speed}");
        let clock = world.resource::<Time<DomainClock<FastStep>>>().context();
        assert_eq!(clock.time_scale(), want_scale, "time scale {scale}");
        assert_eq!(clock.cadence(), want_cadence);
        assert!(world.resource::<Log>().0.len() > steps_before, "the domains kept stepping");
        assert!(world.resource::<SimControl>().simulated() > Duration::ZERO);
    }
}

#[test]
fn a_cadence_of_more_substeps_than_the_limit_is_refused() {
    assert!(Cadence::Substeps(Cadence::MAX_SUBSTEPS).validate().is_ok());
    assert!(Cadence::Substeps(Cadence::MAX_SUBSTEPS + 1).validate().is_err());
    assert!(DomainClock::<FastStep>::new(Cadence::Substeps(u32::MAX)).is_err());
}
