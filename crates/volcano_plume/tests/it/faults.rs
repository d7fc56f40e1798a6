//! The guard in a running app: slices, umbrella spheres and pyroclastic particles edited into
//! non-finite states are removed on the next step, reported as one `SimFault` per volcano and
//! domain, and their ash is booked as lost so the budgets still close.

use crate::common;

use bevy::math::DVec3;
use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_plume::model::slice::Slice;
use volcano_plume::model::umbrella::{Spread, UmbrellaSphere};
use volcano_plume::pyroclastic::airborne_mass;
use volcano_plume::*;

#[derive(Resource, Default, Debug)]
struct Faults(Vec<SimFault>);

fn record(mut seen: ResMut<Faults>, mut r: MessageReader<SimFault>) {
    seen.0.extend(r.read().cloned());
}

fn take_faults(app: &mut App) -> Vec<SimFault> {
    std::mem::take(&mut app.world_mut().resource_mut::<Faults>().0)
}

#[test]
fn non_finite_slices_and_umbrella_spheres_are_removed_and_reported() {
    let mut app = common::plume_app(1);
    app.init_resource::<Faults>().add_systems(FixedUpdate, record.in_set(SimSystems::End));
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    let eruption = Eruption::plinian();
    let volcano = app
        .world_mut()
        .spawn((Volcano::new(100.0, 11).unwrap(), eruption.clone(), Transform::default()))
        .id();
    // Two umbrella spheres of this volcano, as a detachment leaves them.
    let sphere = |id: u64| Umbrella {
        volcano,
        sphere: UmbrellaSphere::detach(&Slice::at_vent(&eruption.params), DVec3::X * 100.0, Spread::Thesis),
        radius: 50.0,
        density: 0.5,
        age: 1.0,
        vent: Vec3::ZERO,
        id,
        ash: 40.0,
        ash_pending: 0.0,
    };
    let healthy = app.world_mut().spawn((sphere(1), Transform::default())).id();
    let broken = app.world_mut().spawn((sphere(2), Transform::default())).id();
    common::run(&mut app, 50);
    assert!(take_faults(&mut app).is_empty(), "a healthy eruption has no faults");
    let world = app.world_mut();
    let (slice, ash) = {
        let mut q = world.query::<(Entity, &mut PlumeSlice)>();
        let (e, mut s) = q.iter_mut(world).next().expect("the eruption has slices after 1 s");
        s.state.velocity.z = f64::INFINITY;
        (e, s.state.solid_mass + s.ash_pending)
    };
    let mut u = world.get_mut::<Umbrella>(broken).unwrap();
    u.sphere.axis.x = f64::NAN;
    let sphere_ash = u.ash + u.ash_pending;
    let lost_before = world.get::<PlumeAshBudget>(volcano).unwrap().lost_kg;
    common::run(&mut app, 51);
    let mut faults = take_faults(&mut app);
    faults.sort_by_key(|f| f.domain as u8);
    let got: Vec<(Entity, SimDomain, u64)> =
        faults.iter().map(|f| (f.entity, f.domain, f.repaired)).collect();
    assert_eq!(got, vec![(volcano, SimDomain::Plume, 1), (volcano, SimDomain::Umbrella, 1)], "{faults:?}");
    // The slice's ash after its step (it sheds a little into its pending ash) and the sphere's.
    assert!((faults[0].lost_ash_kg - ash).abs() <= 1e-6 * ash, "{} vs {ash}", faults[0].lost_ash_kg);
    assert!((faults[1].lost_ash_kg - sphere_ash).abs() < 1e-9, "{} vs {sphere_ash}", faults[1].lost_ash_kg);
    let world = app.world();
    assert!(world.get_entity(slice).is_err() && world.get_entity(broken).is_err());
    assert!(world.get::<Umbrella>(healthy).is_some_and(|u| u.sphere.axis.is_finite()));
    let lost = world.get::<PlumeAshBudget>(volcano).unwrap().lost_kg - lost_before;
    assert!((lost - faults[0].lost_ash_kg - faults[1].lost_ash_kg).abs() < 1e-6, "{lost}");
    // Its ring went with it; the eruption goes on without faults.
    let orphans = app.world_mut().query::<&S1>().iter(app.world()).filter(|s| s.slice == slice).count();
    assert_eq!(orphans, 0);
    common::run(&mut app, 200);
    assert!(take_faults(&mut app).is_empty());
}

#[test]
fn a_non_finite_pyroclastic_particle_is_removed_and_the_budget_closes() {
    let mut app = common::plume_app(5);
    app.init_resource::<Faults>().add_systems(FixedUpdate, record.in_set(SimSystems::End));
    let mut eruption = Eruption::pyroclastic();
    eruption.active = true;
    common::spawn_collapsing_cone(&mut app, eruption);
    let mut t = 0;
    while app.world_mut().query::<&PyroParticle>().iter(app.world()).count() < 10 {
        t += 50;
        assert!(t <= 50 * 60, "no collapse within 60 s");
        common::run(&mut app, t);
    }
    assert!(take_faults(&mut app).is_empty());
    let world = app.world_mut();
    let (particle, mass) = {
        let mut q = world.query::<(Entity, &mut PyroParticle)>();
        let (e, mut p) = q.iter_mut(world).next().unwrap();
        p.particle.velocity.x = f64::NAN;
        (e, p.particle.mass)
    };
    common::run(&mut app, t + 1);
    let faults = take_faults(&mut app);
    assert_eq!(faults.len(), 1, "{faults:?}");
    assert_eq!((faults[0].domain, faults[0].repaired), (SimDomain::Pyroclastic, 1));
    // What it held after its step (a little may have settled first).
    assert!(faults[0].lost_ash_kg > 0.5 * mass && faults[0].lost_ash_kg <= mass, "{faults:?}, {mass}");
    let world = app.world_mut();
    assert!(world.get_entity(particle).is_err());
    let b = volcano_plume::ground::all_budgets(world);
    let total = airborne_mass(world) + b.deposited + b.lifted + b.lost;
    assert!((total - b.collapsed).abs() <= 1e-9 * b.collapsed, "budget: {b:?}");
}
