//! Fold detection and formation (thesis §5.4.3, §5.5.1): first folds where the crust is
//! compressed, following folds ℓ behind, two-step chaining, extension.

use bevy::math::DVec2;

use super::sample::{cell, cylinder_on_flow, surface_velocity};
use super::{Fold, FoldParams, FoldParticle, FoldSystem, fold_thickness};
use crate::model::field::FlowField;
use crate::model::params::LavaParams;
use crate::model::surface::SurfaceState;

/// New first folds per detection pass, at most.
const MAX_FIRST_PER_PASS: usize = 8;

/// A new particle may start this close to another fold, as a fraction of the contact distance
/// `(ℓ + ℓ')/2`: a following fold is placed one wavelength ℓ behind its leader, in contact,
/// and round-off must not reject it. Collisions then keep the two apart.
const CREATE_CLEARANCE: f64 = 0.8;

struct Ctx<'a> {
    field: &'a FlowField,
    surface: &'a SurfaceState,
    p: &'a FoldParams,
    /// Largest particle diameter at the start of the pass (capped at 2 m).
    lmax: f64,
}

impl Ctx<'_> {
    fn lava(&self, q: DVec2) -> f64 {
        cell(self.field, q).map_or(0.0, |k| self.field.thickness().data()[k])
    }
    fn crust(&self, q: DVec2) -> f64 {
        cell(self.field, q).map_or(0.0, |k| self.surface.crust[k])
    }
    /// Unit horizontal vector orthogonal to the surface velocity at `q`.
    fn across_flow(&self, q: DVec2) -> Option<DVec2> {
        surface_velocity(self.field, self.surface, q).try_normalize().map(|v| v.perp())
    }
}

/// Closest particle not in `own` fold within `radius` of `q` (the hash holds every
/// particle, new ones included; `radius` is capped at the hash's bucket size).
fn closest_other(sys: &FoldSystem, q: DVec2, own: u32, radius: f64) -> Option<usize> {
    let radius = radius.min(sys.hash.size());
    let mut near = Vec::new();
    sys.hash.near(q, &mut near);
    near.iter()
        .map(|&o| o as usize)
        .filter(|&o| sys.particles[o].fold != own)
        .map(|o| (sys.particles[o].pos.distance(q), o))
        .filter(|(d, _)| *d < radius)
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, o)| o)
}

/// Whether a new particle of fold `own` (diameter `ell`) at `q` would overlap a particle of
/// another fold (closer than [`CREATE_CLEARANCE`] × `(ℓ + ℓ')/2`) or a particle of its own
/// fold other than the chain end it grows from (closer than L/2: the chain would fold back
/// on itself).
fn occupied(sys: &FoldSystem, q: DVec2, own: u32, ell: f64, end: u32, half_length: f64) -> bool {
    let mut near = Vec::new();
    sys.hash.near(q, &mut near);
    near.iter().any(|&o| {
        let po = &sys.particles[o as usize];
        let d = po.pos.distance(q);
        if po.fold == own {
            o != end && d < half_length
        } else {
            d < CREATE_CLEARANCE * 0.5 * (ell + po.thickness)
        }
    })
}

/// Next particle of a chain in two steps (Fig 5.7 left): `p' = p + L/2·d`, tangent `d'` at
/// `p'` (orthogonal to the surface velocity, or the closest neighbouring fold's tangent if
/// `p'` is within a wavelength of it, Fig 5.7 right), `p_next = p' + L/2·d'`.
fn next_position(c: &Ctx, sys: &FoldSystem, pos: DVec2, d: DVec2, ell: f64, fold: u32) -> (DVec2, DVec2) {
    let half = 0.5 * c.p.particle_length;
    let mid = pos + d * half;
    let mut d2 = c.across_flow(mid).unwrap_or(d);
    if let Some(o) = closest_other(sys, mid, fold, ell + c.lmax) {
        d2 = sys.particles[o].tangent;
    }
    if d2.dot(d) < 0.0 {
        d2 = -d2;
    }
    (mid + d2 * half, d2)
}

pub(super) fn particle(pos: DVec2, tangent: DVec2, ell: f64, fold: u32, vel: DVec2) -> FoldParticle {
    FoldParticle {
        pos,
        spring_vel: DVec2::ZERO,
        vel,
        tangent,
        thickness: ell,
        age: 0.0,
        offset: -0.5 * ell,
        roll_height: 0.0,
        roll_angle: 0.0,
        fold,
        blocked_by: None,
    }
}

/// Extends fold `f` from its end (`front = false`) or start (`front = true`) until a new
/// particle would not be on crust > `chain_min_crust`, its cylinder would leave the flow, or
/// it would overlap another fold or its own (a fold does not grow into occupied crust).
fn grow(c: &Ctx, sys: &mut FoldSystem, f: usize, front: bool) -> u32 {
    let mut added = 0;
    while sys.folds[f].chain.len() < c.p.max_chain && sys.particles.len() < c.p.max_particles {
        let chain = &sys.folds[f].chain;
        let (end, inner) = if front {
            (chain[0], chain.get(1).copied())
        } else {
            (chain[chain.len() - 1], chain.len().checked_sub(2).map(|i| chain[i]))
        };
        let e = sys.particles[end as usize];
        let out = match inner {
            Some(i) => (e.pos - sys.particles[i as usize].pos).try_normalize().unwrap_or(e.tangent),
            None => {
                if front {
                    -e.tangent
                } else {
                    e.tangent
                }
            }
        };
        let (pos, d) = next_position(c, sys, e.pos, out, e.thickness, f as u32);
        if c.crust(pos) <= c.p.chain_min_crust
            || !cylinder_on_flow(c.field, pos, d, c.p.particle_length, e.thickness)
            || occupied(sys, pos, f as u32, e.thickness, end, 0.5 * c.p.particle_length)
        {
            break;
        }
        let vel = surface_velocity(c.field, c.surface, pos);
        let tangent = if front { -d } else { d };
        sys.particles.push(particle(pos, tangent, e.thickness, f as u32, vel));
        let idx = (sys.particles.len() - 1) as u32;
        sys.hash.insert(idx, pos);
        if front {
            sys.folds[f].chain.insert(0, idx);
        } else {
            sys.folds[f].chain.push(idx);
        }
        added += 1;
    }
    added
}

/// Starts a fold with one particle at `pos` (tangent across the flow, ℓ from eq 5.4) and
/// chains it both ways. Returns the particles added, or `None` if the seed is not valid.
fn start_fold(c: &Ctx, sys: &mut FoldSystem, lava: &LavaParams, pos: DVec2, first: bool) -> Option<u32> {
    let tangent = c.across_flow(pos)?;
    let ell = fold_thickness(c.crust(pos), c.lava(pos), lava.crust_viscosity_ratio);
    if ell.is_nan() || ell <= 0.0 || !cylinder_on_flow(c.field, pos, tangent, c.p.particle_length, ell) {
        return None;
    }
    let f = sys.folds.len();
    if sys.particles.len() >= c.p.max_particles
        || occupied(sys, pos, f as u32, ell, u32::MAX, 0.5 * c.p.particle_length)
    {
        return None;
    }
    let vel = surface_velocity(c.field, c.surface, pos);
    sys.particles.push(particle(pos, tangent, ell, f as u32, vel));
    let idx = (sys.particles.len() - 1) as u32;
    sys.hash.insert(idx, pos);
    sys.folds.push(Fold { chain: vec![idx], follower: None, first });
    Some(1 + grow(c, sys, f, false) + grow(c, sys, f, true))
}

/// One detection pass: extend existing folds, create following folds behind folds that have
/// none, then first folds where crust > 1 cm, lava > 50 cm and the lava-thickness difference
/// to a neighbour cell > 20 cm (thesis §5.4.3), away from existing particles. Returns
/// `(new folds, new particles)`.
pub(crate) fn detect_and_extend(
    sys: &mut FoldSystem,
    field: &FlowField,
    surface: &SurfaceState,
    lava: &LavaParams,
    p: &FoldParams,
) -> (u32, u32) {
    let lmax = sys.max_thickness().min(2.0);
    let c = Ctx { field, surface, p, lmax };
    sys.hash.rebuild((2.0 * lmax).max(p.particle_length).max(1.0), sys.particles.iter().map(|q| q.pos));
    let (mut folds, mut parts) = (0u32, 0u32);
    for f in 0..sys.folds.len() {
        parts += grow(&c, sys, f, false) + grow(&c, sys, f, true);
    }
    // Following folds: ℓ behind the centre particle, opposite to the velocity.
    for f in 0..sys.folds.len() {
        if sys.folds[f].follower.is_some() {
            continue;
        }
        let centre = sys.particles[sys.folds[f].chain[sys.folds[f].chain.len() / 2] as usize];
        let v = surface_velocity(field, surface, centre.pos);
        let mut back = centre.tangent.perp();
        if back.dot(v) > 0.0 {
            back = -back;
        }
        let pos = centre.pos + back * centre.thickness;
        if c.crust(pos) <= p.next_min_crust || c.lava(pos) <= p.next_min_lava {
            continue;
        }
        if closest_other(sys, pos, f as u32, 0.5 * centre.thickness).is_some() {
            continue; // another fold is already there
        }
        if let Some(n) = start_fold(&c, sys, lava, pos, false) {
            sys.folds[f].follower = Some((sys.folds.len() - 1) as u32);
            folds += 1;
            parts += n;
        }
    }
    // First folds.
    let (nx, ny) = (field.nx(), field.ny());
    let h = field.thickness().data();
    let mut seeds = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            if surface.crust[k] <= p.first_min_crust || h[k] <= p.first_min_lava {
                continue;
            }
            let mut diff = 0.0f64;
            for (di, dj) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (a, b) = (i as i64 + di, j as i64 + dj);
                if a >= 0 && b >= 0 && (a as usize) < nx && (b as usize) < ny {
                    diff = diff.max((h[k] - h[b as usize * nx + a as usize]).abs());
                }
            }
            if diff > p.first_min_height_diff {
                seeds.push(k);
            }
        }
    }
    let origin = field.ground().origin();
    let mut made = 0;
    for k in seeds {
        if made >= MAX_FIRST_PER_PASS {
            break;
        }
        let (i, j) = (k % nx, k / nx);
        let pos =
            DVec2::new(origin.x as f64 + i as f64 * field.cell(), origin.y as f64 + j as f64 * field.cell());
        let ell = fold_thickness(surface.crust[k], h[k], lava.crust_viscosity_ratio);
        let clear = p.particle_length.max(2.0 * ell);
        if closest_other(sys, pos, u32::MAX, clear).is_some() {
            continue;
        }
        if let Some(n) = start_fold(&c, sys, lava, pos, true) {
            folds += 1;
            parts += n;
            made += 1;
        }
    }
    (folds, parts)
}
