//! Splatting spheres onto a sparse grid and writing it: the cost of one exported ash frame.
//! `cargo bench -p volcano_export --bench splat`.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use volcano_export::splat::{Combine, Fill, Sphere, splat_spheres};
use volcano_export::vdb::{FloatGrid, GridClass, Transform, write_vdb};

/// 20,000 spheres of 60–300 m in a 20 km column of 2 km radius (a column's s1 and s2 spheres
/// at High), splatted on 50 m voxels.
fn spheres() -> Vec<Sphere> {
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..20_000)
        .map(|_| {
            let (a, r, y) = (rnd() * std::f64::consts::TAU, 2_000.0 * rnd().sqrt(), 20_000.0 * rnd());
            Sphere { center: [r * a.cos(), y, r * a.sin()], radius: 60.0 + 240.0 * rnd(), density: 0.5 }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let s = spheres();
    let t = Transform::new(50.0, [0.0; 3]).unwrap();
    let mut g = c.benchmark_group("export");
    g.sample_size(10);
    g.bench_function("splat_20k_spheres_50m", |b| {
        b.iter(|| {
            let mut grid = FloatGrid::new("ash", GridClass::FogVolume, t).unwrap();
            splat_spheres(&mut grid, s.iter().copied(), Fill::Density, Combine::Max, u64::MAX).unwrap();
            black_box(grid.active_voxel_count())
        })
    });
    let mut grid = FloatGrid::new("ash", GridClass::FogVolume, t).unwrap();
    splat_spheres(&mut grid, s.iter().copied(), Fill::Density, Combine::Max, u64::MAX).unwrap();
    g.bench_function("write_vdb_20k_spheres_50m", |b| {
        b.iter(|| {
            let mut out = std::io::Cursor::new(Vec::new());
            write_vdb(&mut out, &[&grid], &[]).unwrap();
            black_box(out.into_inner().len())
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
