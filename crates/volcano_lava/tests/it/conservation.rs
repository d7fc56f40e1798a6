//! Volume conservation and budget closure of the flow layer.

use bevy::math::Vec2;
use volcano_core::Grid2;
use volcano_lava::model::step;
use volcano_lava::{Edge, Edges, FlowField, LavaParams, ViscosityModel};

/// A bumpy 3° slope (descending toward +y) so fluxes go every way.
fn bumpy_ground(n: usize, cell: f64) -> Grid2<f64> {
    let mut g = Grid2::new(n, n, cell, Vec2::ZERO, 0.0).unwrap();
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f64 * cell, j as f64 * cell);
            let z = -0.05 * y + 0.4 * (0.7 * x).sin() * (0.5 * y).cos() + 0.2 * (1.3 * x + 0.4 * y).sin();
            g.set(i, j, z);
        }
    }
    g
}

fn run_closed(edges: Edges, params: &LavaParams) -> (f64, f64, u32) {
    let mut f = FlowField::new(bumpy_ground(48, 0.5), edges, 300.0).unwrap();
    f.place_volume(Vec2::new(12.0, 5.0), 3.0, 20.0, 1330.0).unwrap();
    f.place_volume(Vec2::new(6.0, 15.0), 2.0, 5.0, 1300.0).unwrap();
    let v0 = f.lava_volume();
    let mut max_sub = 0;
    for _ in 0..10_000 {
        let r = step(&mut f, params, &[], 0.02);
        max_sub = max_sub.max(r.substeps);
    }
    assert!(f.is_valid());
    let moved = f.thickness().data().iter().filter(|&&h| h > 1e-3).count();
    assert!(moved > 200, "the lava must actually spread ({moved} wet cells)");
    ((f.lava_volume() - v0).abs() / v0, f.budget().error_rel(f.lava_volume()), max_sub)
}

#[test]
fn volume_conserved_10000_steps_walls_isothermal() {
    let p = LavaParams::isothermal(1000.0).unwrap();
    let (err, budget_err, max_sub) = run_closed(Edges::default(), &p);
    println!("walls, η=1000: relative volume error {err:e}, budget {budget_err:e}, max substeps {max_sub}");
    assert!(err <= 1e-9, "{err}");
    assert!(budget_err <= 1e-9, "{budget_err}");
    assert!(max_sub > 1, "the test must exercise CFL substeps");
}

#[test]
fn volume_conserved_10000_steps_periodic_vft_no_cooling() {
    let p = LavaParams { cooling: false, viscosity: ViscosityModel::FLOWGO_BASALT, ..Default::default() };
    let edges = Edges { west: Edge::Periodic, east: Edge::Periodic, south: Edge::Wall, north: Edge::Wall };
    let (err, budget_err, max_sub) = run_closed(edges, &p);
    println!("periodic x, VFT: relative volume error {err:e}, budget {budget_err:e}, max substeps {max_sub}");
    assert!(err <= 1e-9, "{err}");
    assert!(budget_err <= 1e-9, "{budget_err}");
}

#[test]
fn budget_closes_with_sources_solidification_and_outflow() {
    let edges = Edges { west: Edge::Open, east: Edge::Open, south: Edge::Wall, north: Edge::Open };
    let mut f = FlowField::new(bumpy_ground(48, 0.5), edges, 300.0).unwrap();
    let p = LavaParams { yield_strength: 50.0, ..Default::default() };
    let src = f.point_source(Vec2::new(12.0, 3.0), 1.0, 0.4, 1473.0).unwrap();
    let mut frozen = 0.0;
    let mut emitted = 0.0;
    for _ in 0..6_000 {
        let r = step(&mut f, &p, std::slice::from_ref(&src), 0.02);
        frozen += r.frozen;
        emitted += r.emitted;
    }
    let b = *f.budget();
    println!("{b:?}; lava {}", f.lava_volume());
    assert!((emitted - 0.4 * 120.0).abs() < 1e-9);
    assert!((b.sources - emitted).abs() < 1e-12);
    assert!((b.solidified - frozen).abs() < 1e-12);
    assert!(b.solidified > 0.0, "front lava must freeze");
    assert!(b.outflow > 0.0, "lava must reach the open lower edge");
    assert!(b.error_rel(f.lava_volume()) < 1e-12, "{}", b.error_rel(f.lava_volume()));
    // Frozen lava is part of the ground now.
    let solid: f64 = f.solid().data().iter().sum::<f64>() * 0.25;
    assert!((solid - b.solidified).abs() < 1e-9 * b.solidified.max(1.0));
    assert!(b.rounding < 1e-12, "rounding clamps stay negligible: {}", b.rounding);
}

#[test]
fn frozen_lava_raises_ground_and_later_lava_flows_over_it() {
    let mut f = FlowField::flat(32, 32, 0.5).unwrap();
    let p = LavaParams::default();
    // A thin hot film 7 K above the solidus freezes within seconds: bare 1.8 cm loses
    // ~200 kW/m², ≈ 1.4 K/s with the latent heat released between liquidus and solidus.
    f.place_volume(Vec2::new(8.0, 8.0), 3.0, 0.5, 1280.0).unwrap();
    for _ in 0..400 {
        step(&mut f, &p, &[], 0.02);
    }
    let g = f.ground().get(16, 16);
    assert!(g > 0.0, "ground rose under the frozen lava: {g}");
    assert!(f.lava_volume() < 1e-12);
    // New lava on top sits on the raised ground.
    f.place_volume(Vec2::new(8.0, 8.0), 0.3, 0.05, 1473.0).unwrap();
    let probe = f.probe(Vec2::new(8.0, 8.0)).unwrap();
    assert!(probe.ground > 0.0 && probe.thickness > 0.0);
}

#[test]
fn volume_conserved_10000_steps_periodic_both_ways() {
    // Periodic south/north faces join the first and last row bands (48 rows: bands of 32 and
    // 16), the one place where a band needs a row that is not next to it.
    let p = LavaParams::isothermal(1000.0).unwrap();
    let all =
        Edges { west: Edge::Periodic, east: Edge::Periodic, south: Edge::Periodic, north: Edge::Periodic };
    let (err, budget_err, _) = run_closed(all, &p);
    println!("periodic both ways: relative volume error {err:e}, budget {budget_err:e}");
    assert!(err <= 1e-9, "{err}");
    assert!(budget_err <= 1e-9, "{budget_err}");
}
