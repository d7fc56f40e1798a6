//! Tests of the Lagrangian samples inside the surface update (a child of `surface`, so the
//! samples module does not import the surface that drives it).

use super::*;
/// A strip of lava moving at a uniform speed with old crust upstream and fresh lava
/// downstream: the samples carry the crust front with far less smearing than the grid's
/// upwind advection, and without samples the result is the grid's.
#[test]
fn samples_keep_the_crust_front_sharp() {
    let (nx, ny) = (120, 4);
    let run = |per_cell: u32| -> Vec<f64> {
        let mut p = LavaParams::isothermal(1000.0).unwrap();
        p.surface_samples = per_cell;
        p.rigid_crust = 1e9; // no smoothing: the surface moves at 1.5 ū everywhere
        let mut f = FlowField::flat(nx, ny, 0.5).unwrap();
        f.h.data_mut().fill(1.0);
        f.temp.data_mut().fill(1400.0);
        f.vel[0].data_mut().fill(0.1 / 1.5); // surface speed 0.1 m/s = 0.2 cells/s
        let mut s = SurfaceState::new(nx, ny);
        for j in 0..ny {
            for i in 0..30 {
                s.crust[j * nx + i] = 0.03;
                s.contact[j * nx + i] = contact_from_crust(p.kappa(), 0.03);
            }
        }
        for _ in 0..5_000 {
            update_surface(&mut s, &f, &p, 0.02);
        }
        (0..nx).map(|i| s.crust[nx + i]).collect()
    };
    // Front moved 0.2 cells/s × 100 s = 20 cells: from 30 to 50. Upstream crust
    // √(0.03² + 4κ·100 s) = 3.6 cm, downstream 2√(κ·100 s) = 2 cm.
    let width = |c: &[f64]| c.iter().filter(|v| **v > 0.0215 && **v < 0.0345).count();
    let (grid, lagrangian) = (run(0), run(2));
    assert!(lagrangian[47] > 0.035 && lagrangian[53] < 0.021, "{:?}", &lagrangian[40..60]);
    assert!(width(&lagrangian) <= 3, "samples: front {} cells wide", width(&lagrangian));
    eprintln!("front width: grid {} cells, samples {} cells", width(&grid), width(&lagrangian));
    assert!(width(&grid) >= 3 * width(&lagrangian).max(1), "grid front {} cells", width(&grid));
}

#[test]
fn turning_samples_off_drops_them() {
    let mut p = LavaParams::isothermal(1000.0).unwrap();
    p.surface_samples = 2;
    let mut f = FlowField::flat(8, 8, 0.5).unwrap();
    f.h.data_mut().fill(1.0);
    let mut s = SurfaceState::new(8, 8);
    for _ in 0..10 {
        update_surface(&mut s, &f, &p, 0.02);
    }
    assert_eq!(s.samples.samples.len(), 64);
    p.surface_samples = 0;
    update_surface(&mut s, &f, &p, 0.02);
    assert!(s.samples.samples.is_empty());
}

fn translate(samples: u32) -> (Vec<f64>, Vec<f64>) {
    let (nx, ny, dx) = (64, 4, 0.5);
    let mut p = LavaParams::isothermal(1000.0).unwrap();
    p.surface_samples = samples;
    let kappa = p.kappa();
    let u = 0.05; // surface speed (m/s)
    let t0 = |x: f64| 100.0 + 10.0 * x; // initial contact time (s) at x (m)
    let mut f = FlowField::flat(nx, ny, dx).unwrap();
    f.place_volume(bevy::math::Vec2::new(1.0, 1.0), 1e3, 1.0 * (nx * ny) as f64 * dx * dx, 1400.0).unwrap();
    f.vel[0].data_mut().fill(u / 1.5);
    let mut s = SurfaceState::new(nx, ny);
    for j in 0..ny {
        for i in 0..nx {
            let c = crust_from_contact(kappa, t0(i as f64 * dx));
            s.crust[j * nx + i] = c;
            s.contact[j * nx + i] = contact_from_crust(kappa, c);
        }
    }
    let (dt, tau) = (0.02, 100.0);
    for _ in 0..(tau / dt) as usize {
        update_surface(&mut s, &f, &p, dt);
    }
    let got: Vec<f64> = (0..nx).map(|i| s.crust[nx + i]).collect();
    let expect: Vec<f64> =
        (0..nx).map(|i| crust_from_contact(kappa, t0(i as f64 * dx - u * tau) + tau)).collect();
    (got, expect)
}

/// The crust rides with the lava: on a sheet translating at a uniform surface speed U (no
/// divergence), the crust at x after τ seconds is the crust that was at x − Uτ, grown by τ
/// more seconds of contact, `2√(κ (t₀(x − Uτ) + τ))` (eq 5.1 along characteristics), on
/// the grid alone and with samples, for which the code computes no closed form.
#[test]
fn crust_is_carried_with_the_lava_and_keeps_growing() {
    check_translation(0);
}

/// The same with Lagrangian samples. A cell holds up to `2 × max_per_cell` samples: with
/// only `max_per_cell`, cells 37–42 (x = 18.5–21 m) come out up to 4 % too thick (worst
/// 4.05e-2), as samples crossing cell edges a step apart drop one another and their cells
/// are re-seeded from stale grid values. The error is 5.1e-3: a cell re-seeded once keeps
/// two samples half a cell apart whose mean stands for the cell, and the crust varies 1 % per
/// cell here, so the bound is 1e-2 (the grid's 5e-3 would ask the mean of two positions to be
/// the value at one).
#[test]
fn samples_carry_the_crust_with_the_lava() {
    check_translation(1);
}

fn check_translation(samples: u32) {
    {
        let (got, expect) = translate(samples);
        let bound = if samples == 0 { 5e-3 } else { 1e-2 };
        // Cells 14..60: fed from inside the grid (the front moved 10 cells) and away from
        // the downstream wall.
        let worst = (14..60).map(|i| (got[i] / expect[i] - 1.0).abs()).fold(0.0, f64::max);
        println!(
            "samples {samples}: x = 15 m crust {:.5} m vs {:.5} m; worst relative error {worst:.2e}",
            got[30], expect[30]
        );
        assert!(worst < bound, "samples {samples}: worst error {worst}");
        // Without transport the crust at x = 15 m would be 2√(κ (t₀(15) + τ)), 1.6 % thicker.
        let still = crust_from_contact(1e-6, 100.0 + 150.0 + 100.0);
        assert!((got[30] / still - 1.0).abs() > 0.01, "the crust did not move: {}", got[30]);
    }
}
