//! Tests: fold detection thresholds (thesis §5.4.3), each at unit level, and the spacing ℓ of a
//! following fold (§5.5.1 with eq 5.4).
//!
//! The set-up: a 16 m × 16 m sheet with a step in the lava thickness across y = 8 m (1 m of
//! lava below it, `h_low` above it), uniform crust, the surface moving at 0.1 m/s in +y, so
//! the cells on either side of the step are candidate seeds of a first fold whose tangent is
//! along x.

use bevy::math::DVec2;

use super::{FoldParams, FoldSystem, fold_thickness, update_folds};
use crate::model::field::FlowField;
use crate::model::params::LavaParams;
use crate::model::surface::SurfaceState;

const N: usize = 32;

/// A threshold's name, its setter, and the value the set-up has.
type Threshold = (&'static str, fn(&mut FoldParams, f64), f64);

fn setup(h_low: f64, crust: f64) -> (FlowField, SurfaceState) {
    let mut f = FlowField::flat(N, N, 0.5).unwrap();
    for j in 0..N {
        for i in 0..N {
            f.h.set(i, j, if j < N / 2 { 1.0 } else { h_low });
        }
    }
    f.temp.data_mut().fill(1400.0);
    let mut s = SurfaceState::new(N, N);
    s.crust.fill(crust);
    s.vsurf[1].fill(0.1);
    (f, s)
}

/// Detection every step; `passes` updates of 1 ms (particles move 0.1 mm each).
fn run(f: &FlowField, s: &SurfaceState, p: &FoldParams, passes: usize) -> FoldSystem {
    let lava = LavaParams::default();
    let p = FoldParams { detect_every: 1, ..p.clone() };
    let mut sys = FoldSystem::new(7);
    for _ in 0..passes {
        update_folds(&mut sys, f, s, &lava, &p, 1e-3);
    }
    sys
}

fn first_folds(sys: &FoldSystem) -> usize {
    sys.folds.iter().filter(|f| f.first).count()
}

/// A first fold forms only where crust, lava thickness and the thickness difference to a
/// neighbour all exceed their thresholds: moving each threshold just above the value the
/// set-up has (crust 2 cm, lava 1 m, step 30 cm) suppresses it, just below allows it.
#[test]
fn first_fold_needs_crust_lava_and_height_difference() {
    let (f, s) = setup(0.7, 0.02);
    let base = FoldParams::default();
    assert!(first_folds(&run(&f, &s, &base, 1)) > 0, "thesis thresholds: a fold at the step");
    let cases: [Threshold; 3] = [
        ("first_min_crust", |p, v| p.first_min_crust = v, 0.02),
        ("first_min_lava", |p, v| p.first_min_lava = v, 1.0),
        ("first_min_height_diff", |p, v| p.first_min_height_diff = v, 0.3),
    ];
    for (name, set, at) in cases {
        let mut above = base.clone();
        set(&mut above, at * 1.02);
        let mut below = base.clone();
        set(&mut below, at * 0.98);
        assert_eq!(first_folds(&run(&f, &s, &above, 1)), 0, "{name} = {} must block", at * 1.02);
        assert!(first_folds(&run(&f, &s, &below, 1)) > 0, "{name} = {} must allow", at * 0.98);
    }
    // The thesis values themselves: a 15 cm step, 9 mm of crust, or 45 cm of lava is not enough.
    let (f2, s2) = setup(0.85, 0.02);
    assert_eq!(run(&f2, &s2, &base, 1).fold_count(), 0, "15 cm step");
    let (f3, s3) = setup(0.7, 0.009);
    assert_eq!(run(&f3, &s3, &base, 1).fold_count(), 0, "9 mm crust");
    let (mut f4, s4) = setup(0.2, 0.02);
    f4.h.data_mut().iter_mut().filter(|h| **h > 0.5).for_each(|h| *h = 0.45);
    assert_eq!(run(&f4, &s4, &base, 1).fold_count(), 0, "45 cm of lava");
}

/// A following fold needs crust > `next_min_crust` and lava > `next_min_lava` at its seed
/// (no compression test), and a chain grows only over crust > `chain_min_crust`.
#[test]
fn following_fold_and_chain_thresholds() {
    let (f, s) = setup(0.7, 0.02);
    let base = FoldParams::default();
    let followers = |p: &FoldParams| run(&f, &s, p, 2).folds.iter().filter(|f| !f.first).count();
    assert_eq!(followers(&base), 1, "a follower behind the first fold");
    let cases: [Threshold; 2] = [
        ("next_min_crust", |p, v| p.next_min_crust = v, 0.02),
        ("next_min_lava", |p, v| p.next_min_lava = v, 1.0),
    ];
    for (name, set, at) in cases {
        let mut above = base.clone();
        set(&mut above, at * 1.02);
        let mut below = base.clone();
        set(&mut below, at * 0.98);
        assert_eq!(followers(&above), 0, "{name} = {} must block", at * 1.02);
        assert_eq!(followers(&below), 1, "{name} = {} must allow", at * 0.98);
    }
    // Chaining: above the crust the fold is one particle; below it spans the sheet.
    let chain = |v: f64| {
        let p = FoldParams { chain_min_crust: v, ..base.clone() };
        run(&f, &s, &p, 1).folds.first().map_or(0, |f| f.chain.len())
    };
    assert_eq!(chain(0.0204), 1, "crust 2 cm ≤ chain_min_crust: no chaining");
    assert!(chain(0.0196) >= 20, "crust 2 cm > chain_min_crust: {} particles", chain(0.0196));
}

/// The following fold starts one fold thickness ℓ (eq 5.4, ℓ = √(h_crust h_lava)
/// (ν_crust/ν_lava)^{1/6} = √(0.02 · 1) · 1000^{1/6} = 0.447 m) behind the centre particle of
/// the first fold, against the surface velocity.
#[test]
fn following_fold_is_one_wavelength_behind() {
    let (f, s) = setup(0.7, 0.02);
    let sys = run(&f, &s, &FoldParams::default(), 2);
    let first = sys.folds.iter().position(|f| f.first).unwrap();
    let leader = &sys.folds[first];
    let follower = &sys.folds[leader.follower.expect("no follower") as usize];
    let centre = sys.particles[leader.chain[leader.chain.len() / 2] as usize];
    let ell = fold_thickness(0.02, 1.0, LavaParams::default().crust_viscosity_ratio);
    assert!((ell - 0.4472).abs() < 1e-4, "{ell}");
    assert!((centre.thickness - ell).abs() < 1e-12);
    // The follower's seed is its first-created particle (lowest index).
    let seed = sys.particles[*follower.chain.iter().min().unwrap() as usize];
    let d: DVec2 = seed.pos - centre.pos;
    println!(
        "follower seed {:?} from centre {:?}: distance {:.4} m, ℓ = {ell:.4} m",
        seed.pos,
        centre.pos,
        d.length()
    );
    // Particles moved 0.1 mm in the 1 ms since the leader formed.
    assert!((d.length() - ell).abs() < 1e-3, "spacing {} vs ℓ {ell}", d.length());
    assert!(d.y < -0.99 * ell, "behind = against the +y surface velocity: {d:?}");
}
