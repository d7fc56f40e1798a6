//! One weather step of 512² × 3 layers (issue target ≤ 25 ms on 2 cores; thesis 2.73 s) and
//! 512² × 7 layers (≤ 60 ms; thesis 6.75 s), Δt = 30 s.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use volcano_atmosphere::Scenario;
use volcano_atmosphere::model::step::{Workspace, step};

fn bench_step(c: &mut Criterion, scenario: &str, label: &str) {
    let sc = Scenario::builtin(scenario).unwrap();
    let mut state = sc.build(Some(512)).unwrap();
    let mut work = Workspace::new(&state).unwrap();
    // A few steps so the fields are not trivially uniform.
    for _ in 0..3 {
        step(&mut state, &sc.params, &mut work, 30.0).unwrap();
    }
    c.bench_function(label, |b| {
        b.iter(|| black_box(step(&mut state, &sc.params, &mut work, 30.0).unwrap()));
    });
}

fn benches(c: &mut Criterion) {
    bench_step(c, "convection", "step 512x512x3 layers");
    bench_step(c, "mixed", "step 512x512x7 layers");
}

criterion_group! {
    name = atmosphere;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(8));
    targets = benches
}
criterion_main!(atmosphere);
