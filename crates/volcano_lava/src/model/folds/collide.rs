//! Fold–fold collisions (thesis §5.5.2.2) and the ascending / rolling variant (§5.5.2.3,
//! eq 5.5), with a spatial hash for neighbours.

use std::collections::HashMap;

use bevy::math::DVec2;
use rand::RngExt;

use super::sample::cylinder_on_flow;
use super::{FoldParams, FoldSystem};
use crate::model::field::FlowField;

/// Uniform-grid spatial hash of particle indices.
#[derive(Debug, Clone, Default)]
pub struct SpatialHash {
    size: f64,
    buckets: HashMap<(i64, i64), Vec<u32>>,
}

impl SpatialHash {
    /// A hash with buckets of `size` m.
    pub fn new(size: f64) -> Self {
        Self { size: size.max(1e-3), buckets: HashMap::new() }
    }

    fn key(&self, p: DVec2) -> (i64, i64) {
        ((p.x / self.size).floor() as i64, (p.y / self.size).floor() as i64)
    }

    /// Clears and inserts `points` (index = position in the slice) with bucket size `size`.
    pub fn rebuild(&mut self, size: f64, points: impl Iterator<Item = DVec2>) {
        self.size = size.max(1e-3);
        self.buckets.values_mut().for_each(Vec::clear);
        for (k, p) in points.enumerate() {
            if p.is_finite() {
                let key = self.key(p);
                self.buckets.entry(key).or_default().push(k as u32);
            }
        }
    }

    /// Indices in the 3×3 buckets around `p` (everything within one bucket size), ascending.
    pub fn near(&self, p: DVec2, out: &mut Vec<u32>) {
        out.clear();
        let (ci, cj) = self.key(p);
        for dj in -1..=1 {
            for di in -1..=1 {
                if let Some(b) = self.buckets.get(&(ci + di, cj + dj)) {
                    out.extend_from_slice(b);
                }
            }
        }
        out.sort_unstable();
    }
}

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

/// Resolves collisions between particles of different folds; returns how many. A particle P
/// moving toward the closest particle P' of another fold closer than `(ℓ + ℓ')/2` is
/// blocked: it takes P' 's velocity next step and (blocking variant) is put back at exactly
/// that distance if that stays on the flow; (rolling variant) it rises or sinks to `d_z = ±√((ℓ/2 + ℓ'/2)² − d_xy²)`
/// relative to P' (eq 5.5) and rotates by α = atan2(d_z, d_xy).
pub(crate) fn collide(sys: &mut FoldSystem, field: &FlowField, p: &FoldParams) -> u32 {
    let n = sys.particles.len();
    if n == 0 {
        return 0;
    }
    let lmax = sys.particles.iter().map(|q| q.thickness).fold(0.0, f64::max);
    sys.hash.rebuild(lmax.max(0.25), sys.particles.iter().map(|q| q.pos));
    // Chain neighbours of every particle.
    let mut links = vec![[u32::MAX; 2]; n];
    for fold in &sys.folds {
        for w in fold.chain.windows(2) {
            links[w[0] as usize][1] = w[1];
            links[w[1] as usize][0] = w[0];
        }
    }
    let mut near = Vec::new();
    let mut count = 0;
    #[allow(clippy::needless_range_loop)] // particles are mutated inside the loop
    for k in 0..n {
        let pk = sys.particles[k];
        sys.hash.near(pk.pos, &mut near);
        let mut best: Option<(f64, usize)> = None;
        for &o in &near {
            let o = o as usize;
            if sys.particles[o].fold == pk.fold {
                continue;
            }
            let d = sys.particles[o].pos.distance(pk.pos);
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, o));
            }
        }
        let Some((d_xy, o)) = best else { continue };
        let po = sys.particles[o];
        let r = 0.5 * (pk.thickness + po.thickness);
        if d_xy >= r {
            continue;
        }
        let toward = (pk.vel - po.vel).dot(po.pos - pk.pos);
        if toward < 0.0 || (toward == 0.0 && k < o) {
            continue; // P' is the one moving; it is handled from its side
        }
        count += 1;
        let q = &mut sys.particles[k];
        q.blocked_by = Some(o as u32);
        if p.rolling {
            let neigh: Vec<f64> = links[k]
                .iter()
                .filter(|&&l| l != u32::MAX)
                .map(|&l| sys.particles[l as usize].roll_height)
                .collect();
            let random = sys.rng.random::<bool>();
            let own = sys.particles[k].roll_height;
            let sign = roll_sign(own, po.roll_height, &neigh, random);
            let dz = (r * r - d_xy * d_xy).max(0.0).sqrt();
            let q = &mut sys.particles[k];
            q.roll_height = po.roll_height + sign * dz;
            q.roll_angle = (sign * dz).atan2(d_xy);
        } else {
            let away = (pk.pos - po.pos).try_normalize().unwrap_or(-pk.tangent.perp());
            let pushed = po.pos + away * r;
            // The push never takes a particle off the flow (§5.5.2.1).
            if cylinder_on_flow(field, pushed, q.tangent, p.particle_length, q.thickness) {
                q.pos = pushed;
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
