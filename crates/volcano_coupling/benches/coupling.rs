//! Cost of the plume ↔ atmosphere transfers of one weather step at 256² × 5 layers with 300
//! column slices: the coupling's two steps (`volcano_coupling::model::step`), i.e. imposition,
//! the ash hand-over of every slice, the ambient profile, and the collection of fallen ash.

use bevy::math::{DVec2, DVec3};
use criterion::{Criterion, criterion_group, criterion_main};
use volcano_atmosphere::model::fields::{GridSpec, LayerFields, layer_geometry};
use volcano_coupling::CouplingBudget;
use volcano_coupling::model::column::ColumnSlice;
use volcano_coupling::model::step::{
    AirReadSide, AirSide, AmbientRequest, AshParcel, CoupledColumn, GroundHeat, air_to_plume, plume_to_air,
};

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
    let parcels: Vec<AshParcel> = slices
        .iter()
        .map(|s| AshParcel { at: DVec3::new(s.centre.x, s.altitude, s.centre.y), kg: 1e-3 })
        .collect();
    let mut books = CouplingBudget::default();
    c.bench_function("coupling transfers 256² × 5, 300 slices", |b| {
        let mut l = layers.clone();
        b.iter(|| {
            let mut air = AirSide { grid: g, layers: &mut l, ground_ash: &mut ground, books: &mut books };
            let column = [CoupledColumn { slices: &slices, plume_to_air: true }];
            let r = plume_to_air(&mut air, &column, &parcels, GroundHeat::default());
            let ask = [AmbientRequest { slices: &slices, vent: DVec2::ZERO, r0: 100.0 }];
            let read: Vec<&LayerFields> = l.iter().collect();
            let mut air = AirReadSide { grid: g, layers: &read, ground_ash: &mut ground, books: &mut books };
            let a = air_to_plume(&mut air, true, &ask, |_, _, _| true);
            (r, a)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
