//! One weather step of 512² × 3 layers (target ≤ 25 ms on 2 cores and ≤ 4× a memory
//! sweep over the state; thesis 2.73 s) and 512² × 7 layers (≤ 60 ms; thesis 6.75 s),
//! Δt = 30 s, each beside a same-run memory sweep: one read-modify-write pass over every
//! byte of the layers' fields (the bandwidth floor of anything that touches the whole state).
//! Before the timings, the mean wall time of the step's phases over 10 steps is printed
//! (`WeatherStepReport::phase_ms`) with the V-cycles and flux substeps, as the profile. First, the
//! cloud volume a renderer rebuilds off the main thread after each weather step.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use volcano_atmosphere::model::fields::AtmosphereState;
use volcano_atmosphere::model::step::{Workspace, step};
use volcano_atmosphere::view::{ClusterMemory, VolumeSpec, cloud_density};
use volcano_atmosphere::{AtmosphereParams, WeatherScenario};

/// One read-modify-write pass over every field of every layer (f32 and f64 grids alike).
fn sweep(state: &mut AtmosphereState) {
    for l in state.layers.iter_mut() {
        for g in [&mut l.t, &mut l.u, &mut l.v, &mut l.c, &mut l.up, &mut l.d, &mut l.sigma] {
            g.data_mut().iter_mut().for_each(|x| *x = *x * 0.999_999 + 1e-9);
        }
        for g in [&mut l.h, &mut l.w, &mut l.ash, &mut l.p] {
            g.data_mut().iter_mut().for_each(|x| *x = *x * 0.999_999 + 1e-12);
        }
    }
    black_box(&state.layers);
}

#[path = "support/cpu_time.rs"]
mod cpu_time;

/// CPU time (ms) this process has used so far, all threads.
fn cpu_ms() -> f64 {
    cpu_time::cpu_ms("/proc/self/stat")
}

/// Mean phase times over 10 steps, printed as the profile of the step.
fn profile(state: &mut AtmosphereState, params: &AtmosphereParams, work: &mut Workspace, label: &str) {
    let (mut phases, mut cycles, mut substeps, mut total) = ([0.0; 4], 0, 0, 0.0);
    let steps = 10;
    let cpu0 = cpu_ms();
    for _ in 0..steps {
        let t0 = std::time::Instant::now();
        let r = step(state, params, work, 30.0).unwrap();
        total += t0.elapsed().as_secs_f64() * 1e3;
        phases.iter_mut().zip(r.phase_ms).for_each(|(a, b)| *a += b);
        cycles += r.v_cycles;
        substeps = substeps.max(r.flux_substeps);
    }
    let cpu = cpu_ms() - cpu0;
    let f = |x: f64| x / steps as f64;
    eprintln!(
        "{label}: step {:.1} ms (CPU {:.0} ms, all threads) = ground {:.1} + phase change {:.1} + vertical {:.1} + dynamics {:.1} + rest; \
         {:.1} V-cycles/step (all layers), flux substeps ≤ {substeps}",
        f(total),
        f(cpu),
        f(phases[0]),
        f(phases[1]),
        f(phases[2]),
        f(phases[3]),
        cycles as f64 / steps as f64,
    );
}

fn bench_step(c: &mut Criterion, scenario: &str, label: &str) {
    let sc = WeatherScenario::builtin(scenario).unwrap();
    let mut state = sc.build(Some(512)).unwrap();
    let mut work = Workspace::new(&state).unwrap();
    // A few steps so the fields are not trivially uniform.
    for _ in 0..3 {
        step(&mut state, &sc.params, &mut work, 30.0).unwrap();
    }
    profile(&mut state, &sc.params, &mut work, label);
    let mut copy = state.clone();
    c.bench_function(label, |b| {
        b.iter(|| black_box(step(&mut state, &sc.params, &mut work, 30.0).unwrap()));
    });
    c.bench_function(&format!("{label}: memory sweep"), |b| b.iter(|| sweep(&mut copy)));
}

/// The cloud volume a renderer rebuilds after each weather step (thesis §4.2.6: forms,
/// k-means coherence, amplification): the `mixed` scenario on 128² cells after one hour of
/// weather, onto the renderer's default 256 × 256 × 96 voxels.
fn bench_clouds(c: &mut Criterion) {
    let sc = WeatherScenario::builtin("mixed").unwrap();
    let mut state = sc.build(Some(128)).unwrap();
    let mut work = Workspace::new(&state).unwrap();
    for _ in 0..120 {
        step(&mut state, &sc.params, &mut work, 30.0).unwrap();
    }
    let top = state.layers.last().map_or(1000.0, |l| l.altitude + l.thickness);
    let spec = VolumeSpec { nxy: 256, nz: 96, z_min: state.layers[0].bottom.max(0.0), z_max: top, seed: 7 };
    c.bench_function("cloud volume 256x256x96, mixed 128x128x7", |b| {
        b.iter(|| {
            let mut memory = ClusterMemory::default();
            black_box(cloud_density(&state, sc.params.cloud_threshold, 8, 0.3, &mut memory, &spec))
        });
    });
}

fn benches(c: &mut Criterion) {
    bench_clouds(c);
    bench_step(c, "convection", "step 512x512x3 layers");
    bench_step(c, "mixed", "step 512x512x7 layers");
}

criterion_group! {
    name = atmosphere;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(8));
    targets = benches
}
criterion_main!(atmosphere);
