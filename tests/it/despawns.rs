//! Entities a game despawns at any tick, with work in flight: the atmosphere while its weather
//! step runs on a worker, the volcano while its collapse runs down the flanks. Nothing panics,
//! nothing is written into what is gone, the rest of the world goes on, and what the despawned
//! entity owned goes with it.

use std::time::Duration;

use bevy::prelude::*;
use volcano::atmosphere::{AirLayer, WeatherPipelineStatus};
use volcano::plume::{PlumeSlice, PyroParticle, S1};
use volcano::prelude::*;

use crate::worlds;

#[derive(Resource, Default)]
struct Faults(Vec<SimFault>);

fn record(mut f: MessageReader<SimFault>, mut seen: ResMut<Faults>) {
    seen.0.extend(f.read().cloned());
}

/// A collapsing eruption on a cone with the weather over it (every part of the volcano).
fn world() -> (App, Entity) {
    let mut app = worlds::sim_app(Duration::from_millis(20));
    app.init_resource::<Faults>().add_systems(Last, record);
    let terrain = worlds::collapsing_cone();
    let world = app.world_mut();
    let mut commands = world.commands();
    worlds::air_over(&mut commands, &terrain, 32);
    commands.spawn(terrain);
    let eruption = worlds::collapsing_eruption();
    let volcano = commands.spawn((Volcano::new(100.0, 5).unwrap(), eruption, Transform::default())).id();
    world.flush();
    (app, volcano)
}

fn run(app: &mut App, ticks: u64) {
    let target = app.world().resource::<SimTick>().0 + ticks;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
    }
}

fn count<C: Component>(app: &mut App) -> usize {
    let world = app.world_mut();
    world.query::<&C>().iter(world).count()
}

#[test]
fn the_atmosphere_despawned_while_its_step_runs() {
    let (mut app, _) = world();
    // Weather steps start on whole seconds: 10 ticks in, one is on its worker.
    run(&mut app, 60);
    let world = app.world_mut();
    let (atmosphere, status) = world
        .query::<(Entity, &WeatherPipelineStatus)>()
        .iter(world)
        .map(|(e, s)| (e, s.clone()))
        .next()
        .unwrap();
    assert!(status.in_flight_since.is_some(), "a weather step is in flight: {status:?}");
    world.entity_mut(atmosphere).despawn();
    run(&mut app, 200);
    assert_eq!(count::<AirLayer>(&mut app), 0, "its layers went with it");
    assert!(count::<PlumeSlice>(&mut app) > 0, "the eruption goes on without weather");
    assert!(app.world().resource::<Faults>().0.is_empty());
}

#[test]
fn the_volcano_despawned_while_its_collapse_runs_down() {
    let (mut app, volcano) = world();
    let mut t = 0;
    while count::<PyroParticle>(&mut app) < 100 {
        run(&mut app, 50);
        t += 50;
        assert!(t <= 50 * 60, "no collapse within 60 s");
    }
    let terrain_deposit_before = volcano::plume::ground::all_deposits(app.world_mut());
    app.world_mut().entity_mut(volcano).despawn();
    run(&mut app, 100);
    // Its particles, slices and ring spheres are gone with it; its deposit stays on the
    // terrain (it belongs to the ground); the weather goes on.
    assert_eq!(count::<PyroParticle>(&mut app), 0);
    assert_eq!(count::<PlumeSlice>(&mut app), 0);
    assert_eq!(count::<S1>(&mut app), 0);
    let deposit = volcano::plume::ground::all_deposits(app.world_mut());
    assert!(
        deposit >= terrain_deposit_before && deposit.is_finite(),
        "{deposit} vs {terrain_deposit_before}"
    );
    assert_eq!(count::<AirLayer>(&mut app), 5);
    assert!(app.world().resource::<Faults>().0.is_empty());
}
