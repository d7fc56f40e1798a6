//! Criterion benches (the frame-budget targets, docs/PERFORMANCE.md): one flow substep on a
//! 512² grid (η = 1000 Pa·s, lava up to 1 m thick), also on one thread, one crust update, and
//! a same-run memory sweep over the same field bytes (the bandwidth limit) for the ratio.

use std::hint::black_box;
use std::time::Duration;

use bevy::math::DVec2;
use bevy::math::Vec2;
use criterion::{Criterion, criterion_group, criterion_main};
use volcano_core::Grid2;
use volcano_core::parallel::run_inline;
use volcano_lava::model::flow::advance_flow;
use volcano_lava::model::folds::{Fold, FoldParams, FoldParticle, FoldSystem, update_folds};
use volcano_lava::model::surface::{SurfaceState, update_surface};
use volcano_lava::{Edges, FlowField, LavaParams, LavaScenario, ScenarioConfig, ScenarioKind};

const N: usize = 512;

/// A 512² × 0.5 m gentle slope with bumps, covered by a lava mound up to 1 m thick.
fn field() -> FlowField {
    let mut g = Grid2::new(N, N, 0.5, Vec2::ZERO, 0.0).unwrap();
    for j in 0..N {
        for i in 0..N {
            let (x, y) = (i as f64 * 0.5, j as f64 * 0.5);
            g.set(i, j, -0.05 * y + 0.3 * (0.2 * x).sin() * (0.15 * y).cos());
        }
    }
    let mut f = FlowField::new(g, Edges::default(), 300.0).unwrap();
    // Mound: 1 m at the centre, radius 110 m → most of the grid is wet.
    let c = Vec2::new(128.0, 128.0);
    let r: f64 = 110.0;
    let vol = std::f64::consts::PI * r * r * 0.5; // paraboloid volume with h0 = 1 m
    f.place_volume(c, r, vol, 1400.0).unwrap();
    f
}

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("lava_512");
    g.sample_size(20).measurement_time(Duration::from_secs(6)).warm_up_time(Duration::from_secs(2));
    let one_substep = LavaParams { max_substeps: 1, ..LavaParams::isothermal(1000.0).unwrap() };
    let mut f = field();
    g.bench_function("flow_substep", |b| {
        b.iter(|| black_box(advance_flow(&mut f, &one_substep, 0.002)));
    });
    // The same on the calling thread alone (the bands in order, no pool): on a loaded machine
    // its ratio to the single-threaded memory sweep does not depend on how many cores the
    // pool gets.
    g.bench_function("flow_substep_one_thread", |b| {
        b.iter(|| run_inline(|| black_box(advance_flow(&mut f, &one_substep, 0.002))));
    });
    let p = LavaParams::isothermal(1000.0).unwrap();
    let mut f = field();
    for _ in 0..20 {
        advance_flow(&mut f, &p, 0.02);
    }
    let mut s = SurfaceState::new(N, N);
    g.bench_function("crust_update", |b| {
        b.iter(|| update_surface(black_box(&mut s), &f, &p, 0.02));
    });
    // The same without the Lagrangian samples (grid crust only), for the samples' share.
    let grid_only = LavaParams { surface_samples: 0, ..p.clone() };
    let mut s0 = SurfaceState::new(N, N);
    g.bench_function("crust_update_grid_only", |b| {
        b.iter(|| update_surface(black_box(&mut s0), &f, &grid_only, 0.02));
    });
    // 2,000 fold particles: 20 parallel folds of 100 particles, 0.3 m apart (ℓ = 0.35 m, so
    // neighbouring folds collide), motion + springs + collisions (detection off).
    s.crust.iter_mut().for_each(|c| *c = 0.02);
    let mut folds = FoldSystem::new(1);
    for f in 0..20u32 {
        let mut chain = Vec::new();
        for i in 0..100 {
            folds.particles.push(FoldParticle {
                pos: DVec2::new(103.0 + 0.5 * i as f64, 120.0 + 0.3 * f as f64),
                spring_vel: DVec2::ZERO,
                vel: DVec2::ZERO,
                tangent: DVec2::X,
                thickness: 0.35,
                age: 0.0,
                offset: -0.175,
                roll_height: 0.0,
                roll_angle: 0.0,
                fold: f,
                blocked_by: None,
            });
            chain.push(folds.particles.len() as u32 - 1);
        }
        folds.folds.push(Fold { chain, follower: None, first: f == 0 });
    }
    let fp = FoldParams { detect_every: u32::MAX, ..Default::default() };
    g.bench_function("folds_2000_particles", |b| {
        b.iter(|| black_box(update_folds(&mut folds, &f, &s, &p, &fp, 0.02)));
    });
    // The guard's healthy pass (every step, before it): the carried grids, samples and folds.
    let mut b0 = volcano_lava::model::breakout::BreakoutState::new(N * N);
    g.bench_function("guard_healthy", |b| {
        b.iter(|| {
            let layers = volcano_lava::LayersMut {
                flow: &mut f,
                surface: &mut s,
                folds: &mut folds,
                breakouts: &mut b0,
            };
            black_box(volcano_lava::model::guard::repair(layers, 300.0))
        })
    });
    // Bandwidth reference: read ground, h, T and write h, T (the bytes a substep must touch).
    let n = N * N;
    let (ground, mut h, mut t) = (vec![0.1f64; n], vec![0.5f64; n], vec![1400.0f64; n]);
    g.bench_function("memory_sweep_same_bytes", |b| {
        b.iter(|| {
            for k in 0..n {
                let v = h[k] + 1e-12 * ground[k];
                h[k] = v;
                t[k] = t[k] * 0.999_999 + 1e-9 * v;
            }
            black_box((&h, &t));
        });
    });
    g.finish();
}

/// The late obstacle scenario (Fig 5.10 left, 128² × 0.5 m) at 320 s, where the pond in front
/// of the obstacle keeps converging and about 4,000 fold particles cover it: one whole domain
/// step (flow, surface, breakouts, folds; every 25th step also burial, detection and growth,
/// so criterion's mean includes them at their rate), and the folds' share of it. The state
/// keeps evolving over the samples (a few hundred steps), as in a game.
fn late_obstacle(c: &mut Criterion) {
    let config = ScenarioConfig::new(ScenarioKind::Obstacle);
    let mut s = LavaScenario::build(&config).unwrap();
    s.run_until(320.0);
    let mut g = c.benchmark_group("obstacle_320s");
    g.sample_size(20).measurement_time(Duration::from_secs(8)).warm_up_time(Duration::from_secs(2));
    g.bench_function("domain_step", |b| b.iter(|| s.step()));
    let (field, surface, params, fold_params) =
        (s.field.clone(), s.surface.clone(), s.params.clone(), s.fold_params.clone());
    let mut folds = s.folds.clone();
    g.bench_function("folds_only", |b| {
        b.iter(|| black_box(update_folds(&mut folds, &field, &surface, &params, &fold_params, 0.02)))
    });
    g.finish();
}

/// Vent lava over a whole terrain: the effusive scenario's valley (20 m nodes, 5 m cells) with
/// a 5 m³/s flow an hour old (about 1.3 km, 18 tiles), stepped 20 ms at a time (a base tick at
/// time scale 1) and 2.4 s at a time (time scale 120, as the `effusive_night` scene). The
/// flow keeps evolving over the samples.
fn runout(c: &mut Criterion) {
    use volcano_lava::scenario::effusive::EffusiveConfig;
    use volcano_lava::{Runout, RunoutSettings};
    let config = EffusiveConfig::default();
    let params = config.params();
    let (mut terrain, vent) = config.terrain().unwrap();
    let mut r = Runout::new(&terrain, RunoutSettings::default(), &params).unwrap();
    for _ in 0..3600 {
        r.step(&terrain, &params, &[vent], 1.0);
        r.write_frozen(&mut terrain).unwrap();
    }
    let mut g = c.benchmark_group("runout_1h");
    g.sample_size(20).measurement_time(Duration::from_secs(6)).warm_up_time(Duration::from_secs(2));
    for (name, dt) in [("step_20ms", 0.02), ("step_2400ms", 2.4)] {
        let mut r = r.clone();
        g.bench_function(name, |b| b.iter(|| black_box(r.step(&terrain, &params, &[vent], dt))));
    }
    g.finish();
}

criterion_group!(lava, benches, late_obstacle, runout);
criterion_main!(lava);
