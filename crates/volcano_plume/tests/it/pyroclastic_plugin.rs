//! The pyroclastic plugin on a headless app: a collapsing eruption on a cone hands its slices
//! over to particles that stay on the terrain, run down, deposit, close the mass budget, lift
//! off as secondary columns, and do so identically at any frame rate.

use crate::common;

use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_plume::pyroclastic::airborne_mass;
use volcano_plume::*;

#[derive(Resource, Default, Debug)]
struct Seen {
    flows: usize,
    secondary: usize,
}

fn count(
    mut seen: ResMut<Seen>,
    mut f: MessageReader<PyroclasticFlowStarted>,
    mut s: MessageReader<SecondaryColumnFormed>,
) {
    seen.flows += f.read().count();
    seen.secondary += s.read().count();
}

fn app(ticks_per_update: u32) -> App {
    let mut app = common::plume_app(ticks_per_update);
    app.init_resource::<Seen>().add_systems(FixedUpdate, count.in_set(SimSystems::End));
    let mut eruption = Eruption::pyroclastic();
    eruption.active = true;
    common::spawn_collapsing_cone(&mut app, eruption);
    app
}

use common::run;

#[test]
fn collapse_runs_down_deposits_and_closes_the_budget() {
    let mut app = app(5);
    // 30 s: several collapses; the first particles land after ≈15 s and run down the flanks.
    run(&mut app, 50 * 30);
    let seen = app.world().resource::<Seen>();
    assert!(seen.flows > 0, "collapses handed over: {seen:?}");
    let world = app.world_mut();
    let terrain = world.query::<&Terrain>().single(world).unwrap().clone();
    let vent = world.query::<&VentPosition>().single(world).unwrap().0;
    let mut far = 0.0f32;
    for (p, t) in world.query::<(&PyroParticle, &Transform)>().iter(world) {
        let ground = terrain.height_at(t.translation.x, t.translation.z);
        assert!(
            t.translation.y >= ground - 0.01,
            "particle below the terrain: {} < {ground}",
            t.translation.y
        );
        assert!(p.particle.mass.is_finite() && p.particle.mass >= 0.0);
        far = far.max(Vec2::new(t.translation.x - vent.x, t.translation.z - vent.z).length());
    }
    assert!(far > 500.0, "flow ran out from the vent: {far} m");
    let airborne = airborne_mass(world);
    let b = volcano_plume::ground::all_budgets(world);
    let total = airborne + b.deposited + b.lifted + b.lost;
    assert!(b.collapsed > 0.0);
    assert!((total - b.collapsed).abs() <= 1e-9 * b.collapsed, "budget: {b:?}, airborne {airborne}");
    let map_total = volcano_plume::ground::all_deposits(world);
    assert!((map_total - b.deposited).abs() <= 1e-9 * b.deposited.max(1.0), "{map_total} vs {}", b.deposited);
    assert!(b.deposited > 0.0);
}

/// Within 110 s of the collapse some flow lifts off (checked every simulated second, so the
/// test stops at the first secondary column).
#[test]
fn flows_lift_off_as_secondary_columns() {
    let mut app = app(10);
    for second in 1..=110 {
        run(&mut app, 50 * second);
        let b = volcano_plume::ground::all_budgets(app.world_mut());
        if app.world().resource::<Seen>().secondary > 0 && b.secondary_columns > 0 && b.lifted > 0.0 {
            break;
        }
    }
    let b = volcano_plume::ground::all_budgets(app.world_mut());
    let seen = app.world().resource::<Seen>();
    eprintln!("after {:.0} s: {seen:?} {b:?}", app.world().resource::<SimTick>().0 as f64 / 50.0);
    assert!(seen.secondary > 0 && b.secondary_columns > 0, "{seen:?} {b:?}");
    assert!(b.lifted > 0.0);
}

fn fingerprint(app: &mut App) -> Vec<(u64, [u64; 4])> {
    let world = app.world_mut();
    let mut v: Vec<_> = world
        .query::<&PyroParticle>()
        .iter(world)
        .map(|p| {
            let q = &p.particle;
            (p.id, [q.position.x.to_bits(), q.position.y.to_bits(), q.position.z.to_bits(), q.mass.to_bits()])
        })
        .collect();
    v.sort();
    v
}

#[test]
fn pyroclastic_flow_is_frame_rate_independent() {
    let mut a = app(1);
    let mut b = app(7);
    run(&mut a, 50 * 14);
    run(&mut b, 50 * 14);
    let (fa, fb) = (fingerprint(&mut a), fingerprint(&mut b));
    assert!(!fa.is_empty());
    assert_eq!(fa, fb);
}

/// One buoyant particle with no others near it cannot make a cluster of 19; once it has risen
/// clear of the flows (more than r_pyr above the ground) it lifts off alone as a secondary
/// column, so no particle hangs in the air for ever. (Left a particle, it would rise until the
/// simulation ended.)
#[test]
fn an_isolated_buoyant_particle_lifts_off_alone() {
    let mut app = app(5);
    let world = app.world_mut();
    for mut e in world.query::<&mut Eruption>().iter_mut(world) {
        e.active = false;
    }
    let volcano = world.query_filtered::<Entity, With<Eruption>>().single(world).unwrap();
    let ground = world.query::<&Terrain>().single(world).unwrap().height_at(1_500.0, 0.0) as f64;
    let radius = 8.0;
    let particle = volcano_plume::model::pyroclastic::Particle {
        position: bevy::math::DVec3::new(1_500.0, 0.0, ground + 20.0),
        velocity: bevy::math::DVec3::ZERO,
        radius,
        // 0.6 kg/m³, lighter than the air on the flank.
        mass: 0.6 * 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
        temperature: 700.0,
        grounded: false,
    };
    let m0 = particle.mass;
    world.spawn((
        Transform::default(),
        PyroParticle { volcano, particle, vent: Vec3::ZERO, id: 0, buoyant: false },
    ));
    run(&mut app, 50 * 60);
    let world = app.world_mut();
    let left = world.query::<&PyroParticle>().iter(world).count();
    let b = volcano_plume::ground::all_budgets(world);
    assert_eq!(left, 0, "the particle is still there after 60 s: {b:?}");
    assert_eq!(b.secondary_columns, 1, "{b:?}");
    assert!(b.lifted > 0.0 && (b.lifted + b.deposited + b.lost - m0).abs() < 1e-9 * m0, "{b:?}");
}
