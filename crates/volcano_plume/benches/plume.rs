//! The plume's hot paths (frame-budget target: one 1/50 s tick of 10 substeps with 1,000
//! slices and 6,000 s1 spheres, plus ≥ 500,000 detail-sphere instances, ≤ 4 ms together).
//! This bench measures the model parts alone: the slice steps, the whole plume domain step
//! (`volcano_plume::model::domain::step`: emission, slices, rings, umbrella, books) without ECS, and
//! enumerating the detail spheres of 2,500 s1 spheres × 200 children. ECS overhead is not
//! included (`plume_ecs` measures the same tick through the plugin).

use bevy::math::{DQuat, DVec3};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use volcano_core::VolcanoRng;
use volcano_plume::model::domain::step;
use volcano_plume::model::domain::{Emitter, StepCaps};
use volcano_plume::model::params::PlumeParams;
use volcano_plume::model::slice::{Slice, SliceEnv};
use volcano_plume::model::spheres::{SphereParams, detail_spheres};
use volcano_plume::{Eruption, PlumeAir, PlumeInputs, PlumeState};

fn bench(c: &mut Criterion) {
    let p = PlumeParams { v0: 200.0, ..Default::default() };
    let air = p.atmosphere.profile();
    let wind = |z: f64| p.wind.at(z);
    let env = SliceEnv { air, vent_altitude: 0.0, wind: &wind };
    // 1,000 slices spread along a column (ages 0..130 s).
    let base: Vec<Slice> = (0..1_000)
        .map(|i| {
            let mut s = Slice::at_vent(&p);
            for _ in 0..(i * 65) {
                s.step(&p, &env, 0.002);
            }
            s
        })
        .collect();
    c.bench_function("1000 slices x 10 substeps (one base tick)", |b| {
        b.iter_batched_ref(
            || base.clone(),
            |slices| {
                for _ in 0..10 {
                    for s in slices.iter_mut() {
                        black_box(s.step(&p, &env, 0.002));
                    }
                }
            },
            criterion::BatchSize::LargeInput,
        )
    });
    plume_domain(c);
    let sp = SphereParams { s2_per_s1: 200, ..Default::default() };
    c.bench_function("500k detail spheres (2500 s1 x 200)", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for parent in 0..2_500u64 {
                let center = DVec3::new(parent as f64, 1_000.0, 0.0);
                for s in detail_spheres(&sp, 7, parent, center, 40.0, DQuat::IDENTITY) {
                    acc += s.center.x + s.radius;
                }
            }
            black_box(acc)
        })
    });
}

/// The whole domain step of one volcano, model only: the Plinian column with a 40 m vent (a
/// slice every 0.1 s, as `plume_ecs` grows it) stepped until 1,000 slices are alive (100 s,
/// before its first umbrella); then one base tick (10 steps of 0.002 s).
fn plume_domain(c: &mut Criterion) {
    let mut eruption = Eruption::plinian();
    eruption.params.r0 = 40.0;
    let rng = VolcanoRng::new(3);
    let inputs = PlumeInputs {
        params: &eruption.params,
        spheres: &eruption.spheres,
        active: true,
        frozen: false,
        emitter: Some(Emitter { vent: bevy::math::Vec3::ZERO, rng: &rng }),
        umbrella_lifetime: eruption.umbrella_lifetime,
        umbrella_fallout_s: eruption.umbrella_fallout_s,
        air: PlumeAir::Own,
        caps: StepCaps::default(),
        rings: None,
        dt: 0.002,
        umbrella_dt: 0.002,
    };
    let mut state = PlumeState::default();
    let mut steps = 0;
    while state.slices.len() < 1_000 && steps < 500 * 300 {
        step(&mut state, &inputs);
        steps += 1;
    }
    eprintln!(
        "plume domain after {:.0} s: {} slices, {} s1 spheres, {} umbrella spheres",
        steps as f64 * 0.002,
        state.slices.len(),
        state.rings.len(),
        state.umbrella.len()
    );
    c.bench_function("plume domain step, model only (one base tick)", |b| {
        b.iter_batched_ref(
            || state.clone(),
            |state| {
                for _ in 0..10 {
                    black_box(step(state, &inputs));
                }
            },
            criterion::BatchSize::LargeInput,
        )
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
