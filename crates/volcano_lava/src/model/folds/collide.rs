//! Fold–fold collisions (thesis §5.5.2.2) and the ascending / rolling variant (§5.5.2.3,
//! eq 5.5), with a uniform grid ([`super::hash::SpatialHash`]) for neighbours.

use bevy::math::DVec2;
use rand::RngExt;

use super::sample::cylinder_on_flow;
use super::{FoldParams, FoldSystem};
use crate::model::field::FlowField;

/// Over/under choice for a rolling collision of P with P' (§5.5.2.3): stay above (below) if
/// already above (below); at the same height follow the chain neighbours if they agree;
/// otherwise `random`.
pub fn roll_sign(own: f64, other: f64, neighbours: &[f64], random: bool) -> f64 {
    const EPS: f64 = 1e-6;
    if own > other + EPS {
        return 1.0;
    }
    if own < other - EPS {
        return -1.0;
    }
    let up = neighbours.iter().any(|&h| h > other + EPS);
    let down = neighbours.iter().any(|&h| h < other - EPS);
    match (up, down) {
        (true, false) => 1.0,
        (false, true) => -1.0,
        _ => {
            if random {
                1.0
            } else {
                -1.0
            }
        }
    }
}

/// Resolves collisions between particles of different folds; returns how many particles
/// were blocked. A particle P moving into particles P' of other folds closer than
/// `(ℓ + ℓ')/2` is blocked: it takes the closest P' 's velocity next step and (blocking
/// variant) is pushed out of every such overlap at once, if that stays on the flow; (rolling
/// variant) it rises or sinks to `d_z = ±√((ℓ/2 + ℓ'/2)² − d_xy²)` relative to the closest P'
/// (eq 5.5) and rotates by α = atan2(d_z, d_xy).
///
/// The pass is Jacobi-style: every particle sees the positions and heights of the step
/// before, so the result does not depend on the particle order, and a particle squeezed
/// between several folds gets the sum of their pushes (the thesis' closest-particle rule
/// alone lets converging flow stack particles of dozens of folds in one cell).
pub(crate) fn collide(sys: &mut FoldSystem, field: &FlowField, p: &FoldParams) -> u32 {
    let n = sys.particles.len();
    if n == 0 {
        return 0;
    }
    let lmax = sys.max_thickness();
    sys.hash.rebuild(lmax.max(0.25), sys.particles.iter().map(|q| q.pos));
    // Chain neighbours of every particle.
    let mut links = vec![[u32::MAX; 2]; n];
    for fold in &sys.folds {
        for w in fold.chain.windows(2) {
            links[w[0] as usize][1] = w[1];
            links[w[1] as usize][0] = w[0];
        }
    }
    let before = sys.particles.clone();
    let mut near = Vec::new();
    let mut count = 0;
    for (k, pk) in before.iter().enumerate() {
        sys.hash.near(pk.pos, &mut near);
        let mut best: Option<(f64, usize)> = None;
        let mut push = DVec2::ZERO;
        for &o in &near {
            let o = o as usize;
            let po = &before[o];
            if po.fold == pk.fold {
                continue;
            }
            let d = po.pos.distance(pk.pos);
            let r = 0.5 * (pk.thickness + po.thickness);
            if d >= r {
                continue;
            }
            // Each one's own speed toward the other: the pair approaches if the sum is
            // positive (or both are still), and the one moving in faster yields (ties: the
            // higher index), so exactly one particle of an overlapping pair is pushed.
            let (ak, ao) = (pk.vel.dot(po.pos - pk.pos), po.vel.dot(pk.pos - po.pos));
            if ak + ao < 0.0 || ao > ak || (ao == ak && k < o) {
                continue; // separating, or P' is the one moving in: handled from its side
            }
            if best.is_none_or(|(bd, bo)| d < bd || (d == bd && o < bo)) {
                best = Some((d, o));
            }
            let away = (pk.pos - po.pos).try_normalize().unwrap_or(-pk.tangent.perp());
            push += away * (r - d);
        }
        let Some((d_xy, o)) = best else { continue };
        let po = &before[o];
        count += 1;
        sys.particles[k].blocked_by = Some(o as u32);
        if p.rolling {
            let neigh: Vec<f64> = links[k]
                .iter()
                .filter(|&&l| l != u32::MAX)
                .map(|&l| before[l as usize].roll_height)
                .collect();
            let random = sys.rng.random::<bool>();
            let sign = roll_sign(pk.roll_height, po.roll_height, &neigh, random);
            let r = 0.5 * (pk.thickness + po.thickness);
            let dz = (r * r - d_xy * d_xy).max(0.0).sqrt();
            let q = &mut sys.particles[k];
            q.roll_height = po.roll_height + sign * dz;
            q.roll_angle = (sign * dz).atan2(d_xy);
        } else {
            let pushed = pk.pos + push;
            // The push never takes a particle off the flow (§5.5.2.1).
            if cylinder_on_flow(field, pushed, pk.tangent, p.particle_length, pk.thickness) {
                sys.particles[k].pos = pushed;
            }
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roll_sign_follows_the_thesis_rules() {
        assert_eq!(roll_sign(0.1, 0.0, &[], false), 1.0, "already above stays above");
        assert_eq!(roll_sign(-0.1, 0.0, &[], true), -1.0, "already under stays under");
        assert_eq!(roll_sign(0.0, 0.0, &[0.2, 0.0], false), 1.0, "neighbours going up");
        assert_eq!(roll_sign(0.0, 0.0, &[-0.2], true), -1.0, "neighbours going down");
        assert_eq!(roll_sign(0.0, 0.0, &[0.2, -0.2], true), 1.0, "disagreeing: random");
        assert_eq!(roll_sign(0.0, 0.0, &[0.2, -0.2], false), -1.0, "disagreeing: random");
        assert_eq!(roll_sign(0.0, 0.0, &[], true), 1.0);
    }
}
