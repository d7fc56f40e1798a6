//! No negative cells under random terrains and parameters; bad input rejected.

use bevy::math::Vec2;
use proptest::prelude::*;
use volcano_core::{Grid2, Terrain};
use volcano_lava::model::step;
use volcano_lava::scenario::{ScenarioConfig, ScenarioKind};
use volcano_lava::{Edge, Edges, FlowField, LavaParams, Placement, ViscosityModel};

fn random_ground(nx: usize, ny: usize, heights: &[f64]) -> Grid2<f64> {
    let mut g = Grid2::new(nx, ny, 0.5, Vec2::ZERO, 0.0).unwrap();
    for (k, v) in g.data_mut().iter_mut().enumerate() {
        *v = heights[k % heights.len()];
    }
    g
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn thickness_never_negative_and_budget_closes(
        heights in prop::collection::vec(-2.0f64..2.0, 1..40),
        eta in 1.0f64..1e5,
        yield_strength in prop_oneof![Just(0.0), 0.0f64..500.0],
        cooling in any::<bool>(),
        vft in any::<bool>(),
        dt in 0.001f64..0.2,
        spots in prop::collection::vec((0.0f32..10.0, 0.0f32..34.0, 0.1f64..20.0, 1280.0f64..1500.0), 1..4),
        edge in prop_oneof![Just(Edge::Wall), Just(Edge::Open), Just(Edge::Periodic)],
    ) {
        // 70 rows: three row bands (32 rows each), so fluxes cross the bands' seams.
        let (nx, ny) = (21, 70);
        let edges = Edges { west: edge, east: edge, south: Edge::Wall, north: Edge::Open };
        let mut f = FlowField::new(random_ground(nx, ny, &heights), edges, 300.0).unwrap();
        let viscosity = if vft { ViscosityModel::FLOWGO_BASALT } else { ViscosityModel::Constant(eta) };
        let p = LavaParams { viscosity, yield_strength, cooling, max_substeps: 64, ..Default::default() };
        p.validate().unwrap();
        let mut fed = 0.0;
        for &(x, y, v, t) in &spots {
            f.place_volume(Vec2::new(x, y), 1.0, v, t).unwrap();
            fed += v;
        }
        let src = f.point_source(Vec2::new(5.0, 5.0), 0.0, 0.5, 1473.0).unwrap();
        for _ in 0..40 {
            step(&mut f, &p, std::slice::from_ref(&src), dt);
            fed += 0.5 * dt;
            prop_assert!(f.thickness().data().iter().all(|&h| h >= 0.0 && h.is_finite()));
            // Lava cooled below its solidus freezes into the ground in the same step: what is
            // still liquid is above it (the floor at the air's temperature never shows).
            let (h, t) = (f.thickness().data(), f.temperature().data());
            prop_assert!((0..nx * ny).all(|k| h[k] == 0.0 || t[k] >= p.solidus), "liquid lava below the solidus");
        }
        prop_assert!(f.is_valid());
        let b = f.budget();
        let err = b.error_rel(f.lava_volume());
        prop_assert!(err < 1e-12, "budget error {}", err);
        // The clamps must not hide a real loss: what they added stays at round-off, and the
        // volume on the grid + frozen + drained equals what the test fed, counted here.
        prop_assert!(b.rounding.abs() < 1e-12 * fed, "clamped negatives {} m³ of {} fed", b.rounding, fed);
        let held = f.lava_volume() + b.solidified + b.outflow;
        prop_assert!((held - fed).abs() < 1e-12 * fed, "held {} m³ vs fed {} m³", held, fed);
    }
}

#[test]
fn bad_sources_rejected() {
    let f = FlowField::flat(16, 16, 0.5).unwrap();
    let c = Vec2::new(4.0, 4.0);
    assert!(f.point_source(c, 1.0, -1.0, 1400.0).is_err(), "negative rate");
    assert!(f.point_source(c, 1.0, f64::NAN, 1400.0).is_err(), "NaN rate");
    assert!(f.point_source(c, 1.0, 1.0, f64::NAN).is_err(), "NaN temperature");
    assert!(f.point_source(c, 1.0, 1.0, 5000.0).is_err(), "absurd temperature");
    assert!(f.point_source(Vec2::new(40.0, 4.0), 1.0, 1.0, 1400.0).is_err(), "off the grid");
    assert!(f.point_source(Vec2::new(-1.0, 4.0), 1.0, 1.0, 1400.0).is_err(), "off the grid");
    assert!(f.point_source(Vec2::new(f32::NAN, 4.0), 1.0, 1.0, 1400.0).is_err(), "NaN position");
    assert!(f.point_source(c, f64::INFINITY, 1.0, 1400.0).is_err(), "infinite radius");
    assert!(f.row_source(16, 1.0, 1400.0).is_err(), "row off the grid");
    assert!(f.point_source(c, 1.0, 1.0, 1400.0).is_ok());
}

#[test]
fn bad_fields_and_params_rejected() {
    let mut f = FlowField::flat(16, 16, 0.5).unwrap();
    assert!(f.place_volume(Vec2::new(4.0, 4.0), 1.0, -2.0, 1400.0).is_err());
    assert!(f.place_volume(Vec2::new(4.0, 4.0), 1.0, 2.0, f64::NAN).is_err());
    assert_eq!(f.budget().initial, 0.0, "rejected input leaves no trace");
    let mut g = Grid2::new(8, 8, 0.5, Vec2::ZERO, 0.0).unwrap();
    g.set(3, 3, f64::NAN);
    assert!(FlowField::new(g, Edges::default(), 300.0).is_err());
    let g = Grid2::new(8, 8, 0.5, Vec2::ZERO, 0.0).unwrap();
    let lopsided = Edges { west: Edge::Periodic, east: Edge::Wall, ..Default::default() };
    assert!(FlowField::new(g, lopsided, 300.0).is_err());
    // Placement must lie on the terrain.
    let terrain = Terrain::flat(64, 1.0, 0.0).unwrap();
    let inside = Placement { centre: Vec2::ZERO, nx: 32, ny: 32, cell: 0.5 };
    assert!(FlowField::on_terrain(&terrain, inside, Edges::default()).is_ok());
    let outside = Placement { centre: Vec2::new(60.0, 0.0), ..inside };
    assert!(FlowField::on_terrain(&terrain, outside, Edges::default()).is_err());
    let nan = Placement { cell: f64::NAN, ..inside };
    assert!(FlowField::on_terrain(&terrain, nan, Edges::default()).is_err());
    // Parameters.
    assert!(LavaParams { density: f64::NAN, ..Default::default() }.validate().is_err());
    assert!(LavaParams { yield_strength: -1.0, ..Default::default() }.validate().is_err());
    assert!(
        LavaParams { viscosity: ViscosityModel::Constant(0.0), ..Default::default() }.validate().is_err()
    );
    // Scenarios.
    let mut c = ScenarioConfig::new(ScenarioKind::Incline);
    c.slope_deg = 20.0;
    assert!(c.validate().is_err(), "incline is limited to 10°");
    c.slope_deg = 5.0;
    c.rate = -1.0;
    assert!(c.validate().is_err());
    assert!("volcano".parse::<ScenarioKind>().is_err());
    assert_eq!("split".parse::<ScenarioKind>().unwrap(), ScenarioKind::Split);
}

#[test]
fn nonpositive_dt_is_a_no_op() {
    let mut f = FlowField::flat(8, 8, 0.5).unwrap();
    f.place_volume(Vec2::new(2.0, 2.0), 1.0, 1.0, 1400.0).unwrap();
    let before = f.clone();
    let p = LavaParams::default();
    for dt in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        step(&mut f, &p, &[], dt);
    }
    assert_eq!(f, before);
}
