//! Hot paths of the core crate that the domain models lean on: bilinear sampling and finite
//! differences on a 512² field (the atmosphere's per-layer work), vent snapping (height query),
//! and terrain generation (scene start-up). Compare ratios within one run; machines are noisy.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use volcano_core::grid::{Boundary, Grid2};
use volcano_core::{StratovolcanoParams, Terrain};

fn field(n: usize) -> Grid2<f32> {
    let mut g = Grid2::new(n, n, 1.0, bevy::math::Vec2::ZERO, 0.0f32).unwrap();
    for j in 0..n {
        for i in 0..n {
            g.set(i, j, ((i as f32) * 0.05).sin() + ((j as f32) * 0.03).cos());
        }
    }
    g
}

fn bench(c: &mut Criterion) {
    let n = 512;
    let u = field(n);
    let v = field(n);
    let mut out = field(n);
    c.bench_function("grid2 divergence 512²", |b| {
        b.iter(|| Grid2::divergence_into(black_box(&u), black_box(&v), Boundary::Wrap, &mut out).unwrap())
    });
    c.bench_function("grid2 bilinear 512² samples (semi-Lagrangian pattern)", |b| {
        b.iter(|| {
            let mut s = 0.0f32;
            for j in 0..n {
                for i in 0..n {
                    s += u.sample_grid(i as f64 - 0.37, j as f64 + 0.61, Boundary::Wrap);
                }
            }
            black_box(s)
        })
    });
    let terrain: Terrain = StratovolcanoParams { resolution: 256, ..Default::default() }.generate().unwrap();
    c.bench_function("terrain raycast (picking)", |b| {
        b.iter(|| {
            terrain.raycast(
                black_box(bevy::math::Vec3::new(-9_000.0, 6_000.0, -3_000.0)),
                bevy::math::Vec3::new(1.0, -0.45, 0.3),
            )
        })
    });
    c.bench_function("stratovolcano generate 256²", |b| {
        b.iter(|| StratovolcanoParams { resolution: 256, ..Default::default() }.generate().unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
