//! The plume's frame-budget target (docs/PERFORMANCE.md), measured through the ECS: one 1/50 s
//! base tick (10 plume substeps) with ≈1,000 live slices and ≈6,000 s1 spheres, plus the CPU
//! work one rendered frame needs for its ≥500,000 detail-sphere instances, two ways in the same
//! run:
//!
//! - GPU expansion (what the renderer does each frame): gather the parents, light them and plan
//!   what each draws with the prefix sum of their instance counts ([`gather_parents`],
//!   [`light_parents`], [`plan_parents`]); the vertex shader computes the children. Laying the
//!   planned parents out as 64-byte GPU records (`volcano_render::plume::layout`, a copy of
//!   ≈6,000 records) is the render crate's and is not measured here, where the render stack is
//!   not built;
//! - the CPU build of every instance ([`update_instances`], the reference path).
//!
//! The column is grown by the simulation itself (Plinian preset with a 40 m vent; umbrella
//! spheres removed as they form, so the counts are the target's), so slices are spread over
//! the whole rise as in a real frame.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use criterion::{Criterion, criterion_group, criterion_main};
use volcano_core::prelude::*;
use volcano_plume::view::{gather_parents, light_parents, plan_parents, update_instances};
use volcano_plume::{
    AshLightSettings, Eruption, PlumeInstances, PlumePlugin, PlumeSlice, PlumeViewSettings, PlumeViewpoint,
    S1,
};

fn column_app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin))
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

/// The plain-data part of the renderer's frame (what `volcano_render`'s `update_parents` does
/// before the GPU layout): gather, light (unless `lit` is false: what stays on the main thread
/// when the renderer lights the parents off it, `AshLightSettings::off_thread`), plan. Returns
/// the parents drawn and the instances they expand to.
fn frame_parents(world: &mut World, lit: bool) -> (usize, u32) {
    let (eruptions, parents) = gather_parents(world);
    let settings = world.get_resource_or_init::<PlumeViewSettings>().clone();
    let viewpoint = world.get_resource_or_init::<PlumeViewpoint>().0;
    let light = if lit {
        light_parents(&parents, &world.get_resource_or_init::<AshLightSettings>().clone())
    } else {
        Vec::new()
    };
    let (mut drawn, mut total) = (0, 0);
    plan_parents(&settings, viewpoint, &eruptions, &parents, |d| {
        std::hint::black_box(light.get(d.index));
        drawn += 1;
        total = d.end;
    });
    (drawn, total)
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
    update_instances(app.world_mut());
    let instances = app.world().resource::<PlumeInstances>().0.len();
    let (drawn, total) = frame_parents(app.world_mut(), true);
    eprintln!(
        "state: {slices} slices, {s1} s1 spheres, {instances} instances per frame (CPU build), \
         {drawn} parents planned expanding to {total} instances (GPU path)"
    );
    assert_eq!(total as usize, instances, "both paths draw the same instances");
    let mut group = c.benchmark_group("plume ecs");
    group.sample_size(20);
    group.bench_function("one tick (10 substeps) + GPU-path parents", |b| {
        b.iter(|| {
            app.update();
            frame_parents(app.world_mut(), true)
        })
    });
    group.bench_function("one tick (10 substeps) + GPU-path parents, light off the main thread", |b| {
        b.iter(|| {
            app.update();
            frame_parents(app.world_mut(), false)
        })
    });
    group.bench_function("GPU-path parents only (gather + light + plan + prefix sum)", |b| {
        b.iter(|| frame_parents(app.world_mut(), true))
    });
    group.bench_function("gather parents only (ECS queries + sort)", |b| {
        b.iter(|| gather_parents(app.world_mut()))
    });
    let (_, parents) = gather_parents(app.world_mut());
    let light_settings = AshLightSettings::default();
    group.bench_function("light parents only (sun and sky depth grids)", |b| {
        b.iter(|| light_parents(&parents, &light_settings))
    });
    group.bench_function("CPU instances only (old path)", |b| b.iter(|| update_instances(app.world_mut())));
    // The frame on the CPU path: the tick, then the CPU build of every instance.
    group.bench_function("one tick (10 substeps) + CPU instances (old path)", |b| {
        b.iter(|| {
            app.update();
            update_instances(app.world_mut());
        })
    });
    group.bench_function("one tick (10 substeps), no instances", |b| b.iter(|| app.update()));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
