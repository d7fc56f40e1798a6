//! The lava domain's guard in a running app: non-finite state edited into a live field is
//! repaired on the next step, reported as a `SimFault` and booked in the volume budget.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_lava::*;

use crate::plugin::run;

#[derive(Resource, Default, Debug)]
struct Faults(Vec<SimFault>);

fn record(mut seen: ResMut<Faults>, mut r: MessageReader<SimFault>) {
    seen.0.extend(r.read().cloned());
}

#[test]
fn non_finite_crust_and_folds_are_repaired_and_reported() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .init_resource::<Faults>()
        .add_systems(FixedUpdate, record.in_set(SimSystems::End));
    let placement = Placement { centre: Vec2::ZERO, nx: 48, ny: 48, cell: 0.5 };
    let field = app.world_mut().spawn(LavaField::new(placement, LavaParams::default()).unwrap()).id();
    let src = LavaSource::new(0.2).unwrap().at(Vec3::new(0.0, 0.0, 0.0)).unwrap();
    app.world_mut().spawn(src);
    run(&mut app, 50 * 10);
    assert!(app.world().resource::<Faults>().0.is_empty(), "a healthy field has no faults");
    let mut state = app.world_mut().get_mut::<LavaState>(field).unwrap();
    let wet: Vec<usize> = (0..48 * 48).filter(|&k| state.flow.thickness().data()[k] > 0.01).collect();
    assert!(wet.len() > 20, "{} wet cells", wet.len());
    let lava_in = |s: &LavaState, k: usize| s.flow.thickness().data()[k] * 0.25;
    let held = lava_in(&state, wet[0]) + lava_in(&state, wet[5]);
    state.surface.crust[wet[0]] = f64::NAN;
    state.surface.crust[wet[5]] = f64::INFINITY;
    let folds = state.folds.particles.len();
    if let Some(q) = state.folds.particles.first_mut() {
        q.pos.x = f64::NAN;
    }
    run(&mut app, 1);
    let faults = std::mem::take(&mut app.world_mut().resource_mut::<Faults>().0);
    assert_eq!(faults.len(), 1, "{faults:?}");
    let f = &faults[0];
    assert_eq!((f.entity, f.domain), (field, SimDomain::Lava));
    assert_eq!(f.repaired, 2 + u64::from(folds > 0), "{f:?}");
    assert!((f.lost_lava_m3 - held).abs() < 1e-12, "{} m³ lost, {held} m³ held", f.lost_lava_m3);
    // It keeps flowing, finite, with closed accounts and no further faults.
    run(&mut app, 50 * 5);
    assert!(app.world().resource::<Faults>().0.is_empty());
    let state = app.world().get::<LavaState>(field).unwrap();
    let b = *state.flow.budget();
    assert!(state.flow.is_valid() && state.surface.crust.iter().all(|c| c.is_finite()));
    assert!(state.folds.particles.iter().all(|q| q.pos.is_finite()));
    assert_eq!(b.faulted, f.lost_lava_m3);
    assert!(b.error_rel(state.flow.lava_volume()) < 1e-12, "{b:?}");
}
