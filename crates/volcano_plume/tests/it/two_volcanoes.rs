//! Two volcanoes on two terrains share nothing: each stands on its own
//! terrain (`OnTerrain`), its flows deposit on that terrain's `DepositMap`, its books are its
//! own `PyroclasticBudget`, and a volcano run beside another gives what it gives alone.
//! Despawning one removes everything it owns and leaves its deposit on the ground.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_core::terrain::LandCover;
use volcano_plume::*;

/// A flat square terrain of 65 × 65 nodes 150 m apart (9.6 km) centred on world `(x, 0)`.
fn terrain(x: f32, altitude: f32) -> Terrain {
    let n = 65;
    let origin = Vec2::new(x - 32.0 * 150.0, -32.0 * 150.0);
    let heights = Grid2::new(n, n, 150.0, origin, altitude).unwrap();
    let cover = Grid2::new(n, n, 150.0, origin, LandCover::Ground).unwrap();
    Terrain::new(heights, cover, -100.0).unwrap()
}

const WEST: f32 = -15_000.0;
const EAST: f32 = 15_000.0;

/// An app with the west volcano, and the east one if `both`.
fn app(both: bool) -> (App, [Entity; 2], Option<[Entity; 2]>) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)));
    let world = app.world_mut();
    let west_ground = world.spawn(terrain(WEST, 0.0)).id();
    let west = world
        .spawn((
            Volcano::new(100.0, 1).unwrap(),
            Eruption::pyroclastic(),
            Transform::from_xyz(WEST, 0.0, 0.0),
        ))
        .id();
    let east = both.then(|| {
        let ground = world.spawn(terrain(EAST, 500.0)).id();
        let mut eruption = Eruption::pyroclastic();
        // Another vent, so the two do not merely mirror each other.
        eruption.params.v0 = 60.0;
        let volcano = world
            .spawn((Volcano::new(100.0, 2).unwrap(), eruption, Transform::from_xyz(EAST, 0.0, 0.0)))
            .id();
        [ground, volcano]
    });
    (app, [west_ground, west], east)
}

fn run(app: &mut App, ticks: u64) {
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
}

/// (deposited mass on the terrain's map, the volcano's budget, its live particles' mass)
fn books(app: &mut App, [ground, volcano]: [Entity; 2]) -> (f64, PyroclasticBudget, f64) {
    let world = app.world_mut();
    let deposit = world.get::<DepositMap>(ground).map_or(0.0, DepositMap::total);
    let budget = *world.get::<PyroclasticBudget>(volcano).unwrap();
    let airborne = world
        .query::<&PyroParticle>()
        .iter(world)
        .filter(|p| p.volcano == volcano)
        .map(|p| p.particle.mass)
        .sum();
    (deposit, budget, airborne)
}

#[test]
fn two_volcanoes_on_two_terrains_share_no_deposit_or_budget() {
    let ticks = 50 * 25;
    let (mut pair, west, east) = app(true);
    let east = east.unwrap();
    run(&mut pair, ticks);
    let world = pair.world();
    assert_eq!(world.get::<OnTerrain>(west[1]), Some(&OnTerrain(west[0])));
    assert_eq!(world.get::<OnTerrain>(east[1]), Some(&OnTerrain(east[0])));

    for side in [west, east] {
        let (deposit, b, airborne) = books(&mut pair, side);
        assert!(b.collapsed > 0.0 && deposit > 0.0, "{side:?}: {b:?}, deposit {deposit}");
        // Each map holds exactly its own volcano's deposits: nothing from the other.
        assert!((deposit - b.deposited).abs() <= 1e-9 * b.deposited, "{side:?}: map {deposit} vs {b:?}");
        let closes = b.collapsed - (airborne + b.deposited + b.lifted + b.lost);
        assert!(closes.abs() <= 1e-9 * b.collapsed, "{side:?}: books off by {closes} kg: {b:?}");
    }

    // The west volcano alone gives what it gave beside the east one.
    let (mut alone, west_alone, _) = app(false);
    run(&mut alone, ticks);
    let (d_pair, b_pair, _) = books(&mut pair, west);
    let (d_alone, b_alone, _) = books(&mut alone, west_alone);
    assert_eq!(b_pair.spawned, b_alone.spawned);
    assert_eq!(b_pair.secondary_columns, b_alone.secondary_columns);
    for (a, b) in [(d_pair, d_alone), (b_pair.deposited, b_alone.deposited), (b_pair.lost, b_alone.lost)] {
        assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "beside another {a}, alone {b}");
    }

    // Despawning the east volcano removes what it owns and leaves its deposit.
    let (east_deposit, ..) = books(&mut pair, east);
    pair.world_mut().entity_mut(east[1]).despawn();
    run(&mut pair, ticks + 10);
    let world = pair.world_mut();
    let owned = world.query::<&PyroParticle>().iter(world).filter(|p| p.volcano == east[1]).count()
        + world.query::<&PlumeSlice>().iter(world).filter(|s| s.volcano == east[1]).count()
        + world.query::<&Umbrella>().iter(world).filter(|u| u.volcano == east[1]).count();
    assert_eq!(owned, 0, "entities of the despawned volcano are left");
    let left = world.get::<DepositMap>(east[0]).unwrap().total();
    assert!((left - east_deposit).abs() <= 1e-9 * east_deposit, "deposit {east_deposit} became {left}");
}
