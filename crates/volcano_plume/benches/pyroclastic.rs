//! Frame-budget target: one 1/50 s tick with 50,000 pyroclastic particles on a 512² terrain,
//! including terrain collision and clustering (≤ 5 ms). What the plugin does per tick: the
//! particle step on the task pool in fixed chunks (`par_map_ordered`), then the grid
//! clustering of the buoyant ones, over particles spread on the flanks of the procedural
//! volcano, a quarter of them buoyant. The sequential step is measured too, for the ratio, and
//! the whole domain step (`model::flows::step`: the same particles, their deposits, books, cap
//! and lift-off) as the plugin calls it, without the ECS gathering and write-back; and one pass
//! of the deposit's relaxation, which the plugin runs four times a second; and the renderer's
//! ash light of those particles.

use bevy::math::{DVec2, DVec3};
use criterion::{Criterion, criterion_group, criterion_main};
use rand::RngExt;
use std::hint::black_box;
use volcano_core::StratovolcanoParams;
use volcano_core::VolcanoRng;
use volcano_core::rng::derive_stream;
use volcano_plume::model::flows::{
    FlowInputs, FlowParticle, FlowsState, VolcanoFlows, VolcanoInputs, par_map_ordered, step as flows_step,
};
use volcano_plume::model::params::PlumeParams;
use volcano_plume::model::pyroclastic::{Particle, PyroclasticParams, find_clusters, step_particle};
use volcano_plume::model::slice::SliceEnv;
use volcano_plume::view::{AshLightSettings, ParentSphere, light_parents};

fn bench(c: &mut Criterion) {
    let terrain =
        StratovolcanoParams { resolution: 512, cell: 40.0, ..Default::default() }.generate().unwrap();
    let vent_y = terrain.height_at(0.0, 0.0) as f64;
    let ground = |x: f64, y: f64| terrain.height_at(x as f32, -y as f32) as f64 - vent_y;
    let p = PlumeParams::default();
    let calm = |_: f64| DVec2::ZERO;
    let env = SliceEnv { air: p.atmosphere.profile(), vent_altitude: vent_y, wind: &calm };
    let params = PyroclasticParams::default();
    let mut rng = derive_stream(3, 4);
    let base: Vec<Particle> = (0..50_000)
        .map(|_| {
            let (a, r): (f64, f64) =
                (rng.random_range(0.0..std::f64::consts::TAU), rng.random_range(200.0..4_000.0));
            let (x, y) = (r * a.cos(), r * a.sin());
            Particle {
                position: DVec3::new(x, y, ground(x, y) + 1.0),
                velocity: DVec3::new(a.cos(), a.sin(), 0.0) * 20.0,
                radius: 10.0,
                mass: 4.0 * 4_189.0,
                temperature: 900.0,
                grounded: true,
            }
        })
        .collect();
    let buoyant: Vec<bool> = (0..base.len()).map(|i| i % 4 == 0).collect();
    // The plugin builds the environment per particle (each may belong to another eruption).
    let step = |q: &mut Particle| {
        let env = SliceEnv { air: p.atmosphere.profile(), vent_altitude: vent_y, wind: &calm };
        step_particle(q, &params, &env, &ground, 0.02)
    };
    let candidates: Vec<usize> = (0..base.len()).filter(|i| buoyant[*i]).collect();
    c.bench_function("pyroclastic tick: 50k particles parallel step + collide + cluster", |b| {
        b.iter_batched_ref(
            || base.clone(),
            |ps| {
                let reports = par_map_ordered(ps, step);
                let deposited: f64 = reports.iter().map(|r| r.deposited).sum();
                // As the plugin: only the buoyant candidates are clustered.
                let list: Vec<Particle> = candidates.iter().map(|&i| ps[i]).collect();
                let all = vec![true; list.len()];
                let clusters = find_clusters(&list, &all, params.cluster_radius, params.min_cluster as usize);
                black_box((deposited, clusters.members.len()))
            },
            criterion::BatchSize::LargeInput,
        )
    });
    // The domain step on plain data: one volcano at the terrain's centre, no collapse handed over.
    let vent = bevy::math::Vec3::new(0.0, vent_y as f32, 0.0);
    let mut state = FlowsState {
        volcanoes: vec![VolcanoFlows {
            particles: base
                .iter()
                .zip(&buoyant)
                .enumerate()
                .map(|(k, (&particle, &buoyant))| FlowParticle { id: k as u64, vent, particle, buoyant })
                .collect(),
            ..Default::default()
        }],
        grounds: vec![Default::default()],
    };
    let rng = VolcanoRng::new(1);
    let volcanoes =
        [VolcanoInputs { plume: &p, pyroclastic: &params, rng: &rng, ground: Some(0), collapsed: &[] }];
    let inputs = FlowInputs {
        dt: 0.02,
        relax_passes: 0,
        max_particles: 1_000_000,
        max_secondary_per_step: 1_000,
        volcanoes: &volcanoes,
        terrains: &[&terrain],
    };
    // The deposit map exists after the first step (an empty one creates it).
    let mut first =
        FlowsState { volcanoes: vec![VolcanoFlows::default()], grounds: vec![Default::default()] };
    flows_step(&mut first, &inputs);
    state.grounds = first.grounds;
    c.bench_function("pyroclastic domain step, model only: 50k particles", |b| {
        b.iter_batched_ref(
            || state.clone(),
            |s| black_box(flows_step(s, &inputs).volcanoes[0].kept.len()),
            criterion::BatchSize::LargeInput,
        )
    });
    c.bench_function("pyroclastic: 50k particles parallel step + collide only", |b| {
        b.iter_batched_ref(
            || base.clone(),
            |ps| black_box(par_map_ordered(ps, step).len()),
            criterion::BatchSize::LargeInput,
        )
    });
    c.bench_function("pyroclastic: 50k particles step + collide only", |b| {
        b.iter_batched_ref(
            || base.clone(),
            |ps| {
                for q in ps.iter_mut() {
                    black_box(step_particle(q, &params, &env, &ground, 0.02));
                }
            },
            criterion::BatchSize::LargeInput,
        )
    });
    // One deposit relaxation pass (the plugin runs one every quarter second) over the deposit
    // the particles leave after a while: each has dropped 50 times its mass where it is.
    let mut map = volcano_plume::DepositMap::default();
    for q in &base {
        let at = bevy::math::Vec2::new(q.position.x as f32, -q.position.y as f32);
        map.add_on(&terrain, at, 50.0 * q.mass, params.deposit_density);
    }
    c.bench_function("pyroclastic: one deposit relaxation pass, 512² (+ surface)", |b| {
        b.iter_batched_ref(
            || map.clone(),
            |m| black_box(m.relax(&terrain, 1)),
            criterion::BatchSize::LargeInput,
        )
    });
    // The renderer lights every particle as a parent sphere (`light_parents`, off the main
    // thread one frame behind by default): the cost of a frame's light for the particles alone.
    let parents: Vec<ParentSphere> = base
        .iter()
        .enumerate()
        .map(|(k, q)| ParentSphere {
            id: k as u64,
            eruption: 0,
            center: bevy::math::Vec3::new(
                q.position.x as f32,
                (vent_y + q.position.z) as f32,
                -q.position.y as f32,
            ),
            radius: q.radius as f32,
            rotation: bevy::math::Quat::IDENTITY,
            density: q.density() as f32,
            umbrella: false,
            flow: true,
            cloud: false,
        })
        .collect();
    let light = AshLightSettings::default();
    c.bench_function("pyroclastic: ash light of 50k particles (light_parents)", |b| {
        b.iter(|| black_box(light_parents(&parents, &light)))
    });
    c.bench_function("pyroclastic: clustering 50k (12.5k buoyant) only", |b| {
        b.iter(|| {
            black_box(find_clusters(&base, &buoyant, params.cluster_radius, params.min_cluster as usize))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
