//! The substep cap (`LavaParams::max_substeps`): when a step would need more substeps, the
//! last one scales every face flux down so the explicit update stays stable, which slows the
//! flow. The shipped scenarios must never need it.

use volcano_lava::scenario::{LavaScenario, ScenarioConfig, ScenarioKind};

/// The hottest, thickest lava of each shipped scenario: `spread` releases its 20 m³ as a
/// 1.6 m cylinder at the liquidus (53 Pa·s), the most mobile lava any scenario holds; the
/// sloping scenarios and `incline` over their first seconds. (Their later, cooler ponds were
/// measured over 240 s with the CLI; see docs/physics/lava.md §6.6.)
#[test]
fn shipped_scenarios_never_hit_the_substep_cap() {
    for (kind, seconds, grid) in [
        (ScenarioKind::Spread, 4.0, 32),
        (ScenarioKind::Obstacle, 4.0, 128),
        (ScenarioKind::Incline, 4.0, 128),
    ] {
        let mut c = ScenarioConfig::new(kind);
        c.grid = grid;
        let mut s = LavaScenario::build(&c).unwrap();
        s.run_until(seconds);
        let sum = s.summary();
        println!(
            "{kind:?}: substeps mean {:.1}, max {} (cap {}), capped steps {}",
            sum.mean_substeps, sum.max_substeps, s.params.max_substeps, sum.mobility_capped_steps
        );
        assert_eq!(sum.mobility_capped_steps, 0, "{kind:?} hit the substep cap");
        assert!(sum.max_substeps < s.params.max_substeps);
    }
}
