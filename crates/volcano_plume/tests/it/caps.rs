//! The caps of `volcano_plume::caps` act, book what they remove, and stay deterministic: a
//! Plinian column under a cap of 16 live slices, a collapsing column under a cap of 150
//! particles, and flows limited to one secondary column per step.

use crate::common;

use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_plume::pyroclastic::airborne_mass;
use volcano_plume::*;

/// Released ash and secondary columns seen per base tick.
#[derive(Resource, Default, Debug)]
struct Seen {
    released_kg: f64,
    most_secondary_per_tick: usize,
}

fn count(
    mut seen: ResMut<Seen>,
    mut released: MessageReader<AshReleased>,
    mut formed: MessageReader<SecondaryColumnFormed>,
) {
    seen.released_kg += released.read().map(|m| m.mass).sum::<f64>();
    seen.most_secondary_per_tick = seen.most_secondary_per_tick.max(formed.read().count());
}

fn app(eruption: Eruption, caps: PlumeCaps, ticks_per_update: u32) -> App {
    let mut app = common::plume_app(ticks_per_update);
    app.insert_resource(caps).init_resource::<Seen>().add_systems(FixedUpdate, count.in_set(SimSystems::End));
    common::spawn_collapsing_cone(&mut app, eruption);
    app
}

use common::run;

fn live_slices(world: &mut World) -> usize {
    world.query::<&PlumeSlice>().iter(world).count()
}

#[test]
fn the_live_slice_cap_retires_the_oldest_and_releases_their_ash() {
    let caps = PlumeCaps { max_live_slices: 16, ..default() };
    let mut app = app(Eruption::plinian(), caps, 5);
    run(&mut app, 50 * 20);
    let world = app.world_mut();
    let live = live_slices(world);
    let report = *world.resource::<PlumeCapReport>();
    assert!(live <= 16, "{live} live slices under a cap of 16");
    assert!(report.slices_retired > 0 && report.slice_ash_released_kg > 0.0, "{report:?}");
    // The oldest went: the youngest slices are still there.
    let emitted = world.query::<&EmissionState>().single(world).unwrap().emitted;
    let newest = world.query::<&PlumeSlice>().iter(world).map(|s| s.index).max().unwrap();
    assert_eq!(newest + 1, emitted);
    // The plume's ash books close: what was emitted is in the slices and spheres, or went to
    // the flows, was lost, or was released (by the umbrella and by the cap).
    let b = *world.query::<&PlumeAshBudget>().single(world).unwrap();
    let in_slices: f64 =
        world.query::<&PlumeSlice>().iter(world).map(|s| s.state.solid_mass.max(0.0) + s.ash_pending).sum();
    let in_spheres: f64 = world.query::<&Umbrella>().iter(world).map(|u| u.ash + u.ash_pending).sum();
    let accounted = in_slices + in_spheres + b.to_flows_kg + b.lost_kg + b.released_kg;
    assert!(b.emitted_kg > 0.0 && b.capped_kg > 0.0, "{b:?}");
    assert!((accounted - b.emitted_kg).abs() <= 1e-9 * b.emitted_kg, "books: {b:?}, {accounted}");
    assert!((b.capped_kg - report.slice_ash_released_kg).abs() <= 1e-9 * b.capped_kg);
    // The released ash was handed over as messages, not only booked.
    let seen = world.resource::<Seen>().released_kg;
    assert!((seen - b.released_kg).abs() <= 1e-9 * b.released_kg, "messages {seen} vs booked {b:?}");
}

#[test]
fn the_umbrella_cap_retires_the_oldest_spheres_and_the_books_close() {
    // 150 spheres of 10 t of ash each, detached one per 0.1 s of age (the column would take
    // minutes to reach its umbrella); the eruption is off.
    let caps = PlumeCaps { max_umbrella_spheres: 100, ..default() };
    let mut app = app(Eruption::plinian(), caps, 5);
    let world = app.world_mut();
    let (volcano, params) = {
        let (v, e) = world.query::<(Entity, &Eruption)>().single(world).unwrap();
        (v, e.params.clone())
    };
    world.get_mut::<Eruption>(volcano).unwrap().active = false;
    let mut slice = volcano_plume::model::slice::Slice::at_vent(&params);
    slice.position.z = 9_000.0;
    for k in 0..150u64 {
        let sphere = volcano_plume::model::umbrella::UmbrellaSphere::detach(
            &slice,
            bevy::math::DVec3::X * 100.0,
            volcano_plume::model::umbrella::Spread::Thesis,
        );
        let u = Umbrella {
            volcano,
            sphere,
            radius: 100.0,
            density: 1.0,
            age: 0.1 * (150 - k) as f64,
            vent: Vec3::ZERO,
            id: k,
            ash: 1.0e4,
            ash_pending: 0.0,
        };
        world.spawn((Transform::default(), u));
    }
    world.get_mut::<PlumeAshBudget>(volcano).unwrap().emitted_kg = 150.0 * 1.0e4;
    run(&mut app, 50);
    let world = app.world_mut();
    // The oldest went (ids 0–49 were the oldest).
    let first_left = world.query::<&Umbrella>().iter(world).map(|u| u.id).min();
    assert_eq!(first_left, Some(50));
    let n = world.query::<&Umbrella>().iter(world).count();
    let report = *world.resource::<PlumeCapReport>();
    assert_eq!(n, 100, "umbrella spheres under a cap of 100");
    assert!(report.umbrella_retired > 0 && report.umbrella_ash_released_kg > 0.0, "{report:?}");
    let b = *world.query::<&PlumeAshBudget>().single(world).unwrap();
    let in_slices: f64 =
        world.query::<&PlumeSlice>().iter(world).map(|s| s.state.solid_mass.max(0.0) + s.ash_pending).sum();
    let in_spheres: f64 = world.query::<&Umbrella>().iter(world).map(|u| u.ash + u.ash_pending).sum();
    let accounted = in_slices + in_spheres + b.to_flows_kg + b.lost_kg + b.released_kg;
    assert!((accounted - b.emitted_kg).abs() <= 1e-9 * b.emitted_kg, "books: {b:?}, {accounted}");
    assert!((b.capped_kg - report.umbrella_ash_released_kg).abs() <= 1e-9 * b.capped_kg, "{b:?} {report:?}");
}

fn slices_fingerprint(app: &mut App) -> Vec<(u64, [u64; 3])> {
    let world = app.world_mut();
    let mut v: Vec<_> = world
        .query::<&PlumeSlice>()
        .iter(world)
        .map(|s| (s.index, [s.state.position.z.to_bits(), s.state.mass.to_bits(), s.ash_pending.to_bits()]))
        .collect();
    v.sort();
    v
}

#[test]
fn a_capped_column_is_frame_rate_independent() {
    let caps = PlumeCaps { max_live_slices: 16, ..default() };
    let (mut a, mut b) = (app(Eruption::plinian(), caps.clone(), 1), app(Eruption::plinian(), caps, 5));
    run(&mut a, 50 * 6);
    run(&mut b, 50 * 6);
    assert!(a.world().resource::<PlumeCapReport>().slices_retired > 0);
    assert_eq!(slices_fingerprint(&mut a), slices_fingerprint(&mut b));
    assert_eq!(*a.world().resource::<PlumeCapReport>(), *b.world().resource::<PlumeCapReport>());
}

#[test]
fn the_particle_cap_settles_the_oldest_and_the_flow_budget_closes() {
    let caps = PlumeCaps { max_particles: 150, ..default() };
    let mut app = app(Eruption::pyroclastic(), caps, 5);
    run(&mut app, 50 * 30);
    let world = app.world_mut();
    let n = world.query::<&PyroParticle>().iter(world).count();
    let report = *world.resource::<PlumeCapReport>();
    assert!(n <= 150, "{n} particles under a cap of 150");
    assert!(report.particles_settled > 0, "{report:?}");
    let b = volcano_plume::ground::all_budgets(world);
    let airborne = airborne_mass(world);
    let total = airborne + b.deposited + b.lifted + b.lost;
    assert!(b.capped > 0.0 && b.capped_particles == report.particles_settled, "{b:?} {report:?}");
    assert!((total - b.collapsed).abs() <= 1e-9 * b.collapsed, "budget: {b:?}, airborne {airborne}");
    let map_total = volcano_plume::ground::all_deposits(world);
    assert!((map_total - b.deposited).abs() <= 1e-9 * b.deposited, "{map_total} vs {}", b.deposited);
}

/// Six buoyant particles far apart, 100 m above a flank (more than r_pyr = 50 m: each lifts
/// off alone on the first step, as in tests/pyroclastic_plugin.rs) under a cap of one
/// secondary column per step: the first (they weigh the same; ties go to the
/// lower index) becomes a column, the five
/// others lift off without one, and the budget closes.
#[test]
fn at_most_the_capped_number_of_secondary_columns_forms_per_step() {
    let caps = PlumeCaps { max_secondary_per_step: 1, ..default() };
    let mut app = app(Eruption::pyroclastic(), caps, 5);
    let world = app.world_mut();
    for mut e in world.query::<&mut Eruption>().iter_mut(world) {
        e.active = false;
    }
    let volcano = world.query_filtered::<Entity, With<Eruption>>().single(world).unwrap();
    let terrain = world.query::<&Terrain>().single(world).unwrap().clone();
    let radius = 8.0;
    let mut m0 = 0.0;
    for k in 0..6u64 {
        // Plume frame: x east, y north (world z = −y).
        let (x, y) = (1_500.0 + 300.0 * k as f64, -800.0 + 300.0 * k as f64);
        let ground = terrain.height_at(x as f32, -y as f32) as f64;
        let particle = volcano_plume::model::pyroclastic::Particle {
            position: bevy::math::DVec3::new(x, y, ground + 100.0),
            velocity: bevy::math::DVec3::ZERO,
            radius,
            // 0.6 kg/m³, lighter than the air on the flank.
            mass: 0.6 * 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
            temperature: 700.0,
            grounded: false,
        };
        m0 += particle.mass;
        world.spawn((
            Transform::default(),
            PyroParticle { volcano, particle, vent: Vec3::ZERO, id: k, buoyant: false },
        ));
    }
    run(&mut app, 50 * 5);
    let world = app.world_mut();
    let seen = world.resource::<Seen>().most_secondary_per_tick;
    let report = *world.resource::<PlumeCapReport>();
    let b = volcano_plume::ground::all_budgets(world);
    let left = world.query::<&PyroParticle>().iter(world).count();
    assert!(seen <= 1, "{seen} secondary columns in one step under a cap of 1");
    assert_eq!(report.secondary_retired, 5, "the cap did not act: {report:?} {b:?}");
    assert_eq!((left, b.secondary_columns), (0, 1), "{b:?}");
    assert!((b.capped - report.secondary_retired_kg).abs() < 1e-9 * m0, "{b:?} {report:?}");
    assert!((b.lifted + b.deposited + b.lost - m0).abs() < 1e-9 * m0, "{b:?}");
}
