//! Crust on static lava follows eq (5.1), h = 2√(κt), with the flow and surface layers
//! stepped together.

use bevy::math::Vec2;
use volcano_lava::model::surface::{SurfaceState, crust_from_contact, update_surface};
use volcano_lava::{FlowField, LavaParams, step};

#[test]
fn crust_on_static_lava_follows_2_sqrt_kappa_t() {
    let p = LavaParams::isothermal(1000.0).unwrap();
    let n = 24;
    let mut f = FlowField::flat(n, n, 0.5).unwrap();
    // A uniform 50 cm sheet over the whole walled grid: nothing moves.
    f.place_volume(Vec2::new(5.75, 5.75), 100.0, 0.5 * 0.25 * (n * n) as f64, 1400.0).unwrap();
    let mut s = SurfaceState::new(n, n);
    let dt = 0.02;
    for step_i in 1..=15_000 {
        step(&mut f, &p, &[], dt);
        update_surface(&mut s, &f, &p, dt);
        if step_i % 5_000 == 0 {
            let t = step_i as f64 * dt;
            let k = 12 * n + 12;
            let expect = crust_from_contact(p.kappa(), t);
            println!("t = {t} s: crust {:.6} m, 2√(κt) = {expect:.6} m", s.crust[k]);
            assert!((s.crust[k] / expect - 1.0).abs() < 1e-6);
            assert!((s.contact[k] - t).abs() < 1e-6);
        }
    }
    // 300 s of contact: 2√(1e-6 · 300) = 3.46 cm, the thesis' "rigid at 2–5 cm" range.
    let (max, mean) = s.crust_stats(&f, 1e-3);
    assert!((max - 0.034641).abs() < 1e-5 && (mean - max).abs() < 1e-9);
}
