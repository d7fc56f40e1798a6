//! Folds form in front of the obstacle of thesis Fig 5.10 (left) and not on the same free
//! slope.

use volcano_lava::scenario::{Scenario, ScenarioConfig, ScenarioKind};

fn run(kind: ScenarioKind) -> Scenario {
    let mut c = ScenarioConfig::new(kind);
    c.seconds = 200.0;
    let mut s = Scenario::build(&c).unwrap();
    s.run_until(c.seconds);
    s
}

#[test]
fn folds_pile_up_in_front_of_the_obstacle_not_on_a_free_slope() {
    let s = run(ScenarioKind::Obstacle);
    let sum = s.summary();
    let n = s.folds.particle_count();
    println!("obstacle: {} folds, {n} particles, max crust {:.4} m", sum.folds.unwrap(), sum.max_crust_m);
    assert!(sum.folds.unwrap() >= 3, "{sum:?}");
    // The obstacle occupies 60–66 % of the length (y from 38.1 m): particles sit upstream of
    // it, most of them within 12 m of its face.
    let origin = s.field.ground().origin().y as f64;
    let face = origin + 0.6 * 127.0 * 0.5;
    let ys: Vec<f64> = s.folds.particles.iter().map(|q| q.pos.y).collect();
    let upstream = ys.iter().filter(|&&y| y < face).count();
    let near = ys.iter().filter(|&&y| y > face - 12.0 && y < face).count();
    println!("{upstream} of {n} particles upstream of the face, {near} within 12 m of it");
    assert!(upstream * 10 >= n * 9, "{upstream} of {n} upstream of the obstacle");
    assert!(near * 10 >= n * 8, "{near} of {n} particles within 12 m of the obstacle");
    // Crust is thicker upstream of the obstacle than on the free slope.
    let free = run(ScenarioKind::Slope);
    let fsum = free.summary();
    println!("slope: {:?} folds, max crust {:.4} m", fsum.folds, fsum.max_crust_m);
    assert_eq!(fsum.folds, Some(0));
    assert!(sum.max_crust_m > fsum.max_crust_m);
}

/// Past 240 s the ponded lava in front of the obstacle keeps converging: particles of many
/// folds used to pile into single cells (117 per 0.5 m cell at 240 s, 648 at 270 s) and the
/// neighbour searches went quadratic. Chains now stop at occupied crust and overridden
/// particles are buried, so the density stays bounded.
#[test]
fn folds_do_not_pile_up_as_the_pond_keeps_converging() {
    let mut c = ScenarioConfig::new(ScenarioKind::Obstacle);
    c.seconds = 320.0;
    let mut s = Scenario::build(&c).unwrap();
    s.run_until(c.seconds);
    let sum = s.summary();
    println!(
        "320 s: {:?} folds, {:?} particles, {:?} buried, at most {:?} per cell",
        sum.folds, sum.fold_particles, sum.buried_fold_particles, sum.max_fold_particles_per_cell
    );
    assert!(volcano_lava::model::folds::consistent(&s.folds));
    assert!(sum.fold_particles.unwrap() > 1000, "the pond is covered with folds");
    assert!(sum.buried_fold_particles.unwrap() > 0, "converging folds override each other");
    assert!(sum.max_fold_particles_per_cell.unwrap() <= 10, "{sum:?}");
    // No two particles of different folds closer than half their contact distance after a
    // burial pass (the last step of 320 s = 16,000 steps ran one: 16,000 is a multiple of 25).
    let p = &s.folds.particles;
    let mut worst = f64::INFINITY;
    for a in p {
        for b in p {
            if a.fold != b.fold {
                worst = worst.min(a.pos.distance(b.pos) / (0.5 * (a.thickness + b.thickness)));
            }
        }
    }
    assert!(worst >= 0.5 - 1e-9, "closest pair at {worst} × contact distance");
}

#[test]
fn breakouts_tear_the_crust_where_lava_inflates_in_front_of_the_obstacle() {
    let mut c = ScenarioConfig::new(ScenarioKind::Obstacle);
    c.seconds = 240.0;
    let mut s = Scenario::build(&c).unwrap();
    s.fold_params.enabled = false;
    s.run_until(c.seconds);
    let with_drag = s.summary();
    let mut s2 = Scenario::build(&c).unwrap();
    s2.fold_params.enabled = false;
    s2.params.crust_drag = false;
    s2.run_until(c.seconds);
    let without = s2.summary();
    println!(
        "breakouts with crust drag: {:?} (front {:.1} m), without: {:?} (front {:.1} m)",
        with_drag.breakouts, with_drag.front_distance_m, without.breakouts, without.front_distance_m
    );
    assert!(with_drag.breakouts.unwrap() > 0);
    assert_eq!(without.breakouts, Some(0));
    assert!(with_drag.volume_error_rel < 1e-12 && without.volume_error_rel < 1e-12);
}
