//! The row loops' AVX2 and AVX-512 copies give the baseline's bits: the obstacle scenario (a
//! 128² grid, four row bands, crust, breakouts and folds) run with the row loops limited to the
//! baseline, to AVX2, and unlimited, compared bit for bit (on a CPU without a feature, its run
//! is the next lower copy; the test prints which copies this CPU ran).

use volcano_lava::model::bands::{Simd, limit_simd, simd};
use volcano_lava::{LavaScenario, ScenarioConfig, ScenarioKind};

fn run(limit: Simd) -> (Simd, String) {
    limit_simd(limit);
    let used = simd();
    let mut s = LavaScenario::build(&ScenarioConfig::new(ScenarioKind::Obstacle)).unwrap();
    s.run_until(15.0);
    let state =
        format!("{:?} {:?} {:?} {:?}", s.field, s.surface.crust, s.folds.particles, s.breakouts.h_rigid);
    (used, state)
}

#[test]
fn every_simd_copy_gives_the_baseline_bits() {
    let (base_used, base) = run(Simd::Baseline);
    let (avx2_used, avx2) = run(Simd::Avx2);
    let (best_used, best) = run(Simd::Avx512);
    limit_simd(Simd::Avx512);
    eprintln!("copies run: {base_used:?}, {avx2_used:?}, {best_used:?}");
    assert_eq!(base_used, Simd::Baseline);
    assert!(base.contains("h:"), "the state is printed in full");
    assert!(avx2 == base, "the {avx2_used:?} copy differs from the baseline");
    assert!(best == base, "the {best_used:?} copy differs from the baseline");
}
