//! The target, measured through the ECS: one 1/50 s base tick (10 plume substeps) with
//! ≈1,000 live slices and ≈6,000 s1 spheres, plus producing the detail-sphere instances one
//! rendered frame needs, exactly as the renderer does it ([`PlumeViewPlugin`]'s system).
//!
//! The column is grown by the simulation itself (Plinian preset with a 40 m vent; umbrella
//! spheres removed as they form, so the counts are the target's), so slices are spread over
//! the whole rise as in a real frame.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use criterion::{Criterion, criterion_group, criterion_main};
use volcano_core::prelude::*;
use volcano_plume::view::update_instances;
use volcano_plume::{
    Eruption, PlumeInstances, PlumePlugin, PlumeSlice, PlumeViewPlugin, PlumeViewSettings, S1,
};

fn column_app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin, PlumeViewPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(PlumeViewSettings { max_instances: u32::MAX, ..Default::default() });
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).expect("flat terrain"));
    let mut eruption = Eruption::plinian();
    // Smaller vent → more slices per second, so ~1,000 are alive within a short warm-up.
    eruption.params.r0 = 40.0;
    // Umbrella spheres are not part of the target's count: remove them as they form.
    eruption.umbrella_lifetime = 0.0;
    app.world_mut().spawn((Volcano::new(40.0, 3).expect("volcano"), eruption, Transform::default()));
    app
}

fn count<C: Component>(app: &mut App) -> usize {
    app.world_mut().query::<&C>().iter(app.world()).count()
}

fn bench(c: &mut Criterion) {
    let mut app = column_app();
    while count::<PlumeSlice>(&mut app) < 1_000 {
        app.update();
        assert!(app.world().resource::<SimTick>().0 < 50 * 600, "column never reached 1,000 slices");
    }
    let slices = count::<PlumeSlice>(&mut app);
    let s1 = count::<S1>(&mut app);
    app.update();
    let instances = app.world().resource::<PlumeInstances>().0.len();
    eprintln!("state: {slices} slices, {s1} s1 spheres, {instances} instances per frame");
    let mut group = c.benchmark_group("plume ecs");
    group.sample_size(20);
    group.bench_function("one tick (10 substeps) + instances", |b| b.iter(|| app.update()));
    group.bench_function("instances only", |b| b.iter(|| update_instances(app.world_mut())));
    app.world_mut().resource_mut::<PlumeViewSettings>().enabled = false;
    group.bench_function("one tick (10 substeps), no instances", |b| b.iter(|| app.update()));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
