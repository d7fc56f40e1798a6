//! Smooth motion between ticks: with [`SmoothMotionPlugin`] the plume moves on
//! every rendered frame, and the simulation is the same as without it at any frame rate.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_plume::*;
use volcano_render::SmoothMotionPlugin;

/// A game's own entity moved in the fixed loop by increments of its transform (1 m per tick).
#[derive(Component)]
struct Walker;

fn walk(mut walkers: Query<&mut Transform, With<Walker>>) {
    for mut t in &mut walkers {
        t.translation.x += 1.0;
    }
}

fn app(smooth: bool, frame: Duration) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(frame))
        .add_systems(FixedUpdate, walk);
    if smooth {
        app.add_plugins(SmoothMotionPlugin);
    }
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    app.world_mut().spawn((Volcano::new(100.0, 11).unwrap(), Eruption::plinian(), Transform::default()));
    app.world_mut().spawn((Walker, Transform::default(), TickInterpolation::default()));
    app
}

fn run_to(app: &mut App, tick: u64) {
    while app.world().resource::<SimTick>().0 < tick {
        app.update();
    }
}

/// Slices by index (their state, printed), and the s1 spheres' transforms as the simulation
/// wrote them (by id).
type SimState = (Vec<(u64, String)>, Vec<(u64, Transform)>);

fn sim_state(app: &mut App) -> SimState {
    let world = app.world_mut();
    let mut slices: Vec<_> =
        world.query::<&PlumeSlice>().iter(world).map(|s| (s.index, format!("{:?}", s.state))).collect();
    slices.sort_by_key(|s| s.0);
    let mut spheres: Vec<_> = world
        .query::<(&S1, &Transform, Option<&TickInterpolation>)>()
        .iter(world)
        .map(|(s, t, ticks)| (s.id, ticks.and_then(|k| k.current).unwrap_or(*t)))
        .collect();
    spheres.sort_by_key(|s| s.0);
    (slices, spheres)
}

#[test]
fn the_simulation_is_the_same_with_smooth_motion_at_any_frame_rate() {
    let ticks = 250;
    let mut plain = app(false, Duration::from_millis(20));
    run_to(&mut plain, ticks);
    let mut smooth = app(true, Duration::from_millis(7));
    run_to(&mut smooth, ticks);
    assert_eq!(smooth.world().resource::<SimTick>().0, ticks);
    let (a, b) = (sim_state(&mut plain), sim_state(&mut smooth));
    assert!(a.0.len() > 10, "{} slices", a.0.len());
    assert!(a.0 == b.0, "slice states differ");
    assert!(a.1 == b.1, "the s1 spheres the simulation placed differ");
    // The game's walker moved by its increments only: the simulation side never saw a
    // shown (interpolated) transform. Without the restore before the fixed loop it would
    // have walked from where it was drawn, one tick behind.
    let world = smooth.world_mut();
    let walker = *world.query_filtered::<&TickInterpolation, With<Walker>>().single(world).unwrap();
    assert_eq!(walker.current.unwrap().translation.x, ticks as f32);
    assert_eq!(walker.previous.unwrap().translation.x, ticks as f32 - 1.0);
}

#[test]
fn the_column_moves_on_every_frame_between_ticks() {
    // Four frames per tick: without interpolation three of four frames would show no motion.
    let per_tick = 4;
    for smooth in [true, false] {
        let mut app = app(smooth, Duration::from_millis(20 / per_tick));
        run_to(&mut app, 100);
        let world = app.world_mut();
        let first = world.query::<&PlumeSlice>().iter(world).map(|s| s.index).min().unwrap();
        let mut heights = Vec::new();
        for _ in 0..4 * per_tick as usize {
            app.update();
            let world = app.world_mut();
            let y = world
                .query::<(&PlumeSlice, &Transform)>()
                .iter(world)
                .find(|(s, _)| s.index == first)
                .map(|(_, t)| t.translation.y)
                .expect("the slice lives on");
            heights.push(y);
        }
        let steps: Vec<f32> = heights.windows(2).map(|w| w[1] - w[0]).collect();
        let still = steps.iter().filter(|d| **d == 0.0).count();
        if smooth {
            assert_eq!(still, 0, "frames without motion: {steps:?}");
            let (lo, hi) = steps.iter().fold((f32::MAX, 0.0f32), |(lo, hi), d| (lo.min(*d), hi.max(*d)));
            assert!(lo > 0.0 && hi < 2.0 * lo, "uneven motion between frames: {steps:?}");
        } else {
            assert!(still >= steps.len() / 2, "the plain app moves only on ticks: {steps:?}");
        }
    }
}
