//! Cost of the plume ↔ atmosphere transfers of one weather step at 256² × 5 layers with 300
//! column slices: imposition, the ambient profile and the ash hand-over.

use bevy::math::DVec2;
use criterion::{Criterion, criterion_group, criterion_main};
use volcano_atmosphere::model::fields::{GridSpec, LayerFields, layer_geometry};
use volcano_coupling::model::column::{
    ColumnSlice, ambient_levels, impose, nearest_slice_per_layer, release_columns,
};
use volcano_coupling::model::inject::inject_ash;

fn setup() -> (GridSpec, Vec<LayerFields>, Vec<ColumnSlice>) {
    let g = GridSpec::new(256, 100.0).unwrap();
    let alts = [500.0, 1500.0, 3000.0, 6000.0, 10_000.0];
    let geo = layer_geometry(&alts).unwrap();
    let layers = alts.iter().zip(geo).map(|(&a, (b, h))| LayerFields::new(g, a, b, h, 280.0)).collect();
    // 300 slices up a 12 km column bent 3 km downwind, radii growing from 100 m to 1.2 km.
    let slices = (0..300)
        .map(|i| {
            let f = i as f64 / 299.0;
            ColumnSlice {
                centre: DVec2::new(3_000.0 * f * f, 0.0),
                altitude: 200.0 + 12_000.0 * f,
                radius: 100.0 + 1_100.0 * f,
                temperature: 900.0 - 650.0 * f,
                water_fraction: 0.03 * (1.0 - f),
            }
        })
        .collect();
    (g, layers, slices)
}

fn bench(c: &mut Criterion) {
    let (g, layers, slices) = setup();
    let mut ground = vec![0.0; g.cells()];
    c.bench_function("coupling transfers 256² × 5, 300 slices", |b| {
        let mut l = layers.clone();
        b.iter(|| {
            let near = nearest_slice_per_layer(&l, &slices);
            release_columns(&mut l);
            let r = impose(&mut l, g, &slices, &near);
            let a = ambient_levels(&l, g, &slices, &near, DVec2::ZERO, 100.0);
            for s in &slices {
                inject_ash(&mut l, &mut ground, g, (s.centre.x, s.altitude, s.centre.y), 1.0);
            }
            (r, a)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
