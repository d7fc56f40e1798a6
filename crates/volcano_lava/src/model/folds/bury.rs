//! Burial of overridden fold particles: under sustained compression (lava ponding against an
//! obstacle) ropes are overridden by the folds pushed into them, as pahoehoe ropes are in
//! the field. Beyond the thesis, which keeps every particle: without this, converging surface
//! velocity packs particles of dozens of folds into one cell and the neighbour searches
//! become quadratic (a 5 s slice of the obstacle scenario takes 92 s at 270 s).

use super::{Fold, FoldSystem};

/// Marks every particle whose centre lies within `depth` × `(ℓ + ℓ')/2` of a particle of an
/// older fold (lower index) as overridden (distance in 3D with the rolling heights of eq 5.5,
/// so a rope that rolled over or under another one is not buried), and removes them with
/// [`remove`]. Returns how many were removed. Among folds piled on one spot only the oldest
/// survives, so after this pass no two particles of different folds are closer than
/// `depth (ℓ + ℓ')/2`.
pub(crate) fn bury_overridden(sys: &mut FoldSystem, depth: f64) -> u32 {
    if sys.particles.is_empty() || depth <= 0.0 {
        return 0;
    }
    let lmax = sys.max_thickness();
    sys.hash.rebuild(lmax.max(0.25), sys.particles.iter().map(|q| q.pos));
    let mut near = Vec::new();
    let dead: Vec<bool> = sys
        .particles
        .iter()
        .map(|pk| {
            sys.hash.near(pk.pos, &mut near);
            near.iter().any(|&o| {
                let po = &sys.particles[o as usize];
                let dz = pk.roll_height - po.roll_height;
                let reach = depth * 0.5 * (pk.thickness + po.thickness);
                po.fold < pk.fold && po.pos.distance_squared(pk.pos) + dz * dz < reach * reach
            })
        })
        .collect();
    remove(sys, &dead)
}

/// Removes the particles flagged in `dead`. A chain loses its dead particles and closes up
/// (the springs then pull the survivors together: an overridden rope is drawn under rather
/// than torn into pieces, which in a test of the obstacle scenario leaves 3,154 folds of 2.8
/// particles on average at 400 s, against 335 of 14.5 this way); folds left empty disappear
/// and follower links to them are dropped. Particle and fold indices are compacted in order,
/// so the result is deterministic.
pub(crate) fn remove(sys: &mut FoldSystem, dead: &[bool]) -> u32 {
    let removed = dead.iter().filter(|&&d| d).count() as u32;
    if removed == 0 {
        return 0;
    }
    let mut remap = vec![u32::MAX; sys.particles.len()];
    let mut kept = Vec::with_capacity(sys.particles.len() - removed as usize);
    for (k, q) in sys.particles.iter().enumerate() {
        if !dead[k] {
            remap[k] = kept.len() as u32;
            kept.push(*q);
        }
    }
    let mut fold_map = vec![None; sys.folds.len()];
    let mut folds: Vec<Fold> = Vec::with_capacity(sys.folds.len());
    for (f, fold) in sys.folds.iter().enumerate() {
        let chain: Vec<u32> =
            fold.chain.iter().filter(|&&k| !dead[k as usize]).map(|&k| remap[k as usize]).collect();
        if chain.is_empty() {
            continue;
        }
        let idx = folds.len() as u32;
        fold_map[f] = Some(idx);
        for &k in &chain {
            kept[k as usize].fold = idx;
        }
        folds.push(Fold { chain, follower: fold.follower, first: fold.first });
    }
    for fold in &mut folds {
        fold.follower = fold.follower.and_then(|f| fold_map[f as usize]);
    }
    for q in &mut kept {
        q.blocked_by = q.blocked_by.and_then(|o| Some(remap[o as usize]).filter(|&r| r != u32::MAX));
    }
    sys.particles = kept;
    sys.folds = folds;
    removed
}

/// Whether the fold bookkeeping is consistent: every particle in exactly one chain, the
/// particle's `fold` naming that chain, links in range (used by tests).
pub fn consistent(sys: &FoldSystem) -> bool {
    let mut seen = vec![false; sys.particles.len()];
    for (f, fold) in sys.folds.iter().enumerate() {
        if fold.chain.is_empty() || fold.follower.is_some_and(|x| x as usize >= sys.folds.len()) {
            return false;
        }
        for &k in &fold.chain {
            let Some(q) = sys.particles.get(k as usize) else { return false };
            if seen[k as usize] || q.fold as usize != f {
                return false;
            }
            seen[k as usize] = true;
        }
    }
    seen.iter().all(|&s| s)
        && sys.particles.iter().all(|q| q.blocked_by.is_none_or(|o| (o as usize) < sys.particles.len()))
}

#[cfg(test)]
mod tests {
    use bevy::math::DVec2;

    use super::*;
    use crate::model::folds::{FoldParticle, create};

    /// A particle of diameter 0.4 m along x.
    fn particle(pos: DVec2, fold: u32) -> FoldParticle {
        create::particle(pos, DVec2::X, 0.4, fold, DVec2::ZERO)
    }

    /// Folds of 6 particles along x at the given y (and x shift), in order.
    fn folds(rows: &[(f64, f64)]) -> FoldSystem {
        let mut sys = FoldSystem::new(3);
        for (f, &(y, x0)) in rows.iter().enumerate() {
            let mut chain = Vec::new();
            for i in 0..6 {
                sys.particles.push(particle(DVec2::new(x0 + 0.5 * i as f64, y), f as u32));
                chain.push(sys.particles.len() as u32 - 1);
            }
            sys.folds.push(Fold { chain, follower: None, first: true });
        }
        sys.folds[0].follower = Some(1);
        if rows.len() > 2 {
            sys.folds[1].follower = Some(2);
        }
        sys
    }

    #[test]
    fn removing_particles_closes_the_chain_and_drops_empty_folds() {
        let mut sys = folds(&[(0.0, 0.0), (5.0, 0.0), (10.0, 0.0)]);
        sys.particles[7].blocked_by = Some(2);
        sys.particles[8].blocked_by = Some(3);
        let mut dead = vec![false; 18];
        dead[3] = true; // middle of fold 0
        dead[12..18].fill(true); // all of fold 2
        assert_eq!(remove(&mut sys, &dead), 7);
        assert!(consistent(&sys));
        assert_eq!(sys.particles.len(), 11);
        let lens: Vec<usize> = sys.folds.iter().map(|f| f.chain.len()).collect();
        assert_eq!(lens, vec![5, 6]);
        assert_eq!(sys.folds[0].chain, vec![0, 1, 2, 3, 4]);
        // Fold 0 keeps its follower (fold 1); fold 1's follower (fold 2) is gone.
        assert_eq!(sys.folds[0].follower, Some(1));
        assert_eq!(sys.folds[1].follower, None);
        // blocked_by links follow the compaction; one pointed at a removed particle.
        assert_eq!(sys.particles[5 + 2].blocked_by, None);
        assert_eq!(sys.particles[5 + 1].blocked_by, Some(2));
        // Positions kept their order: old particle 4 is now 3.
        assert_eq!(sys.particles[3].pos, DVec2::new(2.0, 0.0));
    }

    #[test]
    fn only_the_oldest_of_piled_folds_survives() {
        // Folds 0, 1, 2 on the same line (1 and 2 shifted 5 cm, well inside 0.5 × 0.4 m),
        // fold 3 at a safe 0.4 m (touching but not overridden).
        let mut sys = folds(&[(0.0, 0.0), (0.0, 0.05), (0.03, 0.0), (0.4, 0.0)]);
        let buried = bury_overridden(&mut sys, 0.5);
        assert_eq!(buried, 12);
        assert!(consistent(&sys));
        assert_eq!(sys.folds.len(), 2);
        // Nothing left closer than 0.5 × contact distance across folds.
        for a in &sys.particles {
            for b in &sys.particles {
                if a.fold != b.fold {
                    assert!(a.pos.distance(b.pos) >= 0.2 - 1e-12);
                }
            }
        }
        assert_eq!(bury_overridden(&mut sys, 0.5), 0, "a second pass has nothing left to do");
        // A fold that rolled over another (eq 5.5: 0.39 m up at 0.05 m apart) is not buried.
        let mut rolled = folds(&[(0.0, 0.0), (0.0, 0.05)]);
        for q in rolled.particles.iter_mut().filter(|q| q.fold == 1) {
            q.roll_height = (0.4f64 * 0.4 - 0.05 * 0.05).sqrt();
        }
        assert_eq!(bury_overridden(&mut rolled, 0.5), 0);
        assert_eq!(bury_overridden(&mut folds(&[(0.0, 0.0), (0.0, 0.05)]), 0.0), 0, "depth 0 keeps all");
    }

    /// Random fold systems and removal masks: the bookkeeping stays consistent, survivors
    /// keep their order and positions, and each chain keeps its survivors in chain order.
    #[test]
    fn removal_keeps_the_bookkeeping_consistent() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..300 {
            let mut sys = FoldSystem::new(0);
            for f in 0..rng.random_range(1..8u32) {
                let mut chain = Vec::new();
                for _ in 0..rng.random_range(1..12) {
                    let p = DVec2::new(rng.random_range(0.0..10.0), rng.random_range(0.0..10.0));
                    sys.particles.push(particle(p, f));
                    chain.push(sys.particles.len() as u32 - 1);
                }
                sys.folds.push(Fold { chain, follower: None, first: f == 0 });
            }
            let (nf, np) = (sys.folds.len() as u32, sys.particles.len() as u32);
            for fold in &mut sys.folds {
                fold.follower = rng.random_bool(0.5).then(|| rng.random_range(0..nf));
            }
            for q in &mut sys.particles {
                q.blocked_by = rng.random_bool(0.3).then(|| rng.random_range(0..np));
            }
            assert!(consistent(&sys));
            let dead: Vec<bool> = (0..np).map(|_| rng.random_bool(0.3)).collect();
            let survivors: Vec<DVec2> =
                sys.particles.iter().zip(&dead).filter(|(_, d)| !**d).map(|(q, _)| q.pos).collect();
            let chains: Vec<Vec<DVec2>> = sys
                .folds
                .iter()
                .map(|f| {
                    f.chain
                        .iter()
                        .filter(|&&k| !dead[k as usize])
                        .map(|&k| sys.particles[k as usize].pos)
                        .collect()
                })
                .filter(|c: &Vec<DVec2>| !c.is_empty())
                .collect();
            let removed = remove(&mut sys, &dead);
            assert_eq!(removed as usize, dead.iter().filter(|d| **d).count());
            assert!(consistent(&sys));
            assert_eq!(sys.particles.iter().map(|q| q.pos).collect::<Vec<_>>(), survivors);
            let after: Vec<Vec<DVec2>> = sys
                .folds
                .iter()
                .map(|f| f.chain.iter().map(|&k| sys.particles[k as usize].pos).collect())
                .collect();
            assert_eq!(after, chains);
        }
    }
}
