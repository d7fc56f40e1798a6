//! Layer 3, the folds (thesis §5.4.3 and §5.5): chains of oriented particles (cylinders of
//! length L and diameter ℓ, eq 5.4) created where the crust is compressed, advected on the
//! surface velocity, held together by springs, kept inside the flow, colliding (§5.5.2.2)
//! or rolling over / under each other (§5.5.2.3, eq 5.5).
//!
//! Particles live in one `Vec` per field (not one entity each): the render side instances
//! them from [`FoldSystem::particles`].

pub(crate) mod bury;
mod collide;
mod create;
mod feedback;
mod hash;
#[cfg(test)]
mod rules_tests;
mod sample;

use bevy::math::DVec2;
use bevy::reflect::Reflect;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use volcano_core::ConfigError;
use volcano_core::error::{in_range, positive};

use super::field::FlowField;
use super::params::LavaParams;
use super::surface::SurfaceState;

pub use bury::consistent;
pub use feedback::{fold_crust, thicken_crust_under_folds};
pub use hash::SpatialHash;

/// Parameters of the fold layer (thesis §5.4.3, §5.5 and Table 5.2).
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FoldParams {
    /// Whether folds are simulated.
    pub enabled: bool,
    /// First fold: minimum crust (m), thesis 1 cm.
    pub first_min_crust: f64,
    /// First fold: minimum lava thickness (m), thesis 50 cm.
    pub first_min_lava: f64,
    /// First fold: minimum lava-thickness difference to a neighbour (m), thesis 20 cm.
    pub first_min_height_diff: f64,
    /// Following folds: minimum crust (m), thesis 1 cm.
    pub next_min_crust: f64,
    /// Following folds: minimum lava thickness (m), thesis 30 cm.
    pub next_min_lava: f64,
    /// Chaining stops where the crust is thinner than this (m), thesis 8 mm.
    pub chain_min_crust: f64,
    /// Particle length L (m), Table 5.2: 0.5.
    pub particle_length: f64,
    /// Spring constant between chained particles (N/m), Table 5.2: 1e3.
    pub spring: f64,
    /// Crust density for the particle mass ρ π (ℓ/2)² L (kg/m³).
    pub crust_density: f64,
    /// Seconds for a new fold to rise from offset −ℓ/2 to the surface.
    pub rise_time: f64,
    /// Rolling collisions (§5.5.2.3) instead of blocking ones (§5.5.2.2).
    pub rolling: bool,
    /// Detection and extension run every this many steps.
    pub detect_every: u32,
    /// At most this many particles per field.
    pub max_particles: usize,
    /// At most this many particles per fold.
    pub max_chain: usize,
    /// Burial (beyond the thesis): a particle whose centre comes within this fraction of the
    /// contact distance `(ℓ + ℓ')/2` of an older fold's particle is overridden and removed
    /// (checked every `detect_every` steps). 0 keeps every particle.
    pub bury_depth: f64,
}

impl Default for FoldParams {
    fn default() -> Self {
        Self {
            enabled: true,
            first_min_crust: 0.01,
            first_min_lava: 0.5,
            first_min_height_diff: 0.2,
            next_min_crust: 0.01,
            next_min_lava: 0.3,
            chain_min_crust: 0.008,
            particle_length: 0.5,
            spring: 1e3,
            crust_density: 2700.0,
            rise_time: 3.0,
            rolling: false,
            detect_every: 25,
            max_particles: 20_000,
            max_chain: 200,
            bury_depth: 0.5,
        }
    }
}

impl FoldParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for (name, v) in [
            ("first_min_crust", self.first_min_crust),
            ("first_min_lava", self.first_min_lava),
            ("first_min_height_diff", self.first_min_height_diff),
            ("next_min_crust", self.next_min_crust),
            ("next_min_lava", self.next_min_lava),
            ("chain_min_crust", self.chain_min_crust),
        ] {
            in_range(name, v, 0.0, 100.0)?;
        }
        in_range("particle_length", self.particle_length, 0.01, 100.0)?;
        positive("spring", self.spring)?;
        positive("crust_density", self.crust_density)?;
        in_range("rise_time", self.rise_time, 0.0, 1e4)?;
        in_range("detect_every", self.detect_every as f64, 1.0, 1e6)?;
        in_range("max_particles", self.max_particles as f64, 0.0, 1e7)?;
        in_range("max_chain", self.max_chain as f64, 1.0, 1e5)?;
        in_range("bury_depth", self.bury_depth, 0.0, 1.0)?;
        Ok(())
    }
}

/// Fold thickness (local wavelength), thesis eq (5.4):
/// `ℓ = √(h_crust h_lava) (ν_crust/ν_lava)^{1/6}`.
pub fn fold_thickness(crust: f64, lava: f64, viscosity_ratio: f64) -> f64 {
    (crust * lava).max(0.0).sqrt() * viscosity_ratio.powf(1.0 / 6.0)
}

/// One oriented particle: a cylinder of length L along `tangent`, diameter `thickness`.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize)]
pub struct FoldParticle {
    /// World (x, z) position (m).
    pub pos: DVec2,
    /// Velocity relative to the surface from the springs (m/s).
    pub spring_vel: DVec2,
    /// Velocity used last step (m/s).
    pub vel: DVec2,
    /// Unit fold tangent.
    pub tangent: DVec2,
    /// Diameter ℓ (m).
    pub thickness: f64,
    /// Seconds since creation.
    pub age: f64,
    /// Vertical offset from the flow surface (m): −ℓ/2 at creation, rising to 0.
    pub offset: f64,
    /// Height from rolling collisions, eq (5.5) (m; + above, − under its neighbour fold).
    pub roll_height: f64,
    /// Roll angle α about the tangent (rad).
    pub roll_angle: f64,
    /// Fold index.
    pub fold: u32,
    /// Index of the particle this one is blocked by (collision this step).
    pub blocked_by: Option<u32>,
}

/// A chain of particles.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize)]
pub struct Fold {
    /// Particle indices in chain order.
    pub chain: Vec<u32>,
    /// Fold created behind this one (following fold), if any.
    pub follower: Option<u32>,
    /// Whether it was a first fold (compression detected) or a following one.
    pub first: bool,
}

/// Counts of one fold update.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FoldReport {
    /// Folds created.
    pub new_folds: u32,
    /// Particles created (new folds and extensions).
    pub new_particles: u32,
    /// Particle collisions resolved.
    pub collisions: u32,
    /// Particles overridden and removed.
    pub buried: u32,
    /// The system holds [`FoldParams::max_particles`]: no fold is created or extended until
    /// particles are buried.
    pub at_cap: bool,
}

/// All folds of one field.
#[derive(Debug, Clone)]
pub struct FoldSystem {
    /// Particles (removed only when overridden, see [`FoldParams::bury_depth`]; frozen lava
    /// keeps its ropes).
    pub particles: Vec<FoldParticle>,
    /// Folds.
    pub folds: Vec<Fold>,
    pub(crate) hash: SpatialHash,
    pub(crate) rng: ChaCha8Rng,
    steps: u64,
    buried: u64,
}

impl FoldSystem {
    /// An empty system; `seed` drives the random over/under choice of rolling collisions.
    pub fn new(seed: u64) -> Self {
        Self {
            particles: Vec::new(),
            folds: Vec::new(),
            hash: SpatialHash::new(1.0),
            rng: volcano_core::derive_stream(seed, volcano_core::rng::stream_id("lava_folds", 0)),
            steps: 0,
            buried: 0,
        }
    }

    /// Number of folds.
    pub fn fold_count(&self) -> usize {
        self.folds.len()
    }

    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.particles.len()
    }

    /// Particles overridden and removed so far.
    pub fn buried_count(&self) -> u64 {
        self.buried
    }

    /// Largest particle diameter ℓ (m), 0 without particles: the neighbour grids' bucket
    /// sizes follow it.
    pub(crate) fn max_thickness(&self) -> f64 {
        self.particles.iter().map(|q| q.thickness).fold(0.0, f64::max)
    }
}

/// Advances the folds by `dt`: motion (surface velocity + springs, kept inside the flow),
/// collisions, rise of the offset, then every `detect_every` steps burial of overridden
/// particles, detection of first and following folds and extension of existing ones.
pub fn update_folds(
    sys: &mut FoldSystem,
    field: &FlowField,
    surface: &SurfaceState,
    lava: &LavaParams,
    params: &FoldParams,
    dt: f64,
) -> FoldReport {
    let mut report = FoldReport::default();
    if !(params.enabled && dt.is_finite() && dt > 0.0) {
        return report;
    }
    move_particles(sys, field, surface, params, dt);
    report.collisions = collide::collide(sys, field, params);
    sys.steps += 1;
    if sys.steps.is_multiple_of(params.detect_every as u64) {
        report.buried = bury::bury_overridden(sys, params.bury_depth);
        sys.buried += report.buried as u64;
        let (f, p) = create::detect_and_extend(sys, field, surface, lava, params);
        report.new_folds = f;
        report.new_particles = p;
    }
    report.at_cap = sys.particles.len() >= params.max_particles;
    report
}

/// Motion of a fold (§5.5.2.1): advection by the surface velocity (or the blocking particle's
/// velocity after a collision), spring forces `k (|d| − L)` between chain neighbours acting on
/// the mass `ρ π (ℓ/2)² L` (damped), tangent from the neighbours, and a particle whose
/// cylinder would leave the flow goes back to its previous position.
fn move_particles(sys: &mut FoldSystem, field: &FlowField, surface: &SurfaceState, p: &FoldParams, dt: f64) {
    let n = sys.particles.len();
    let mut force = vec![DVec2::ZERO; n];
    for fold in &sys.folds {
        for w in fold.chain.windows(2) {
            let (a, b) = (w[0] as usize, w[1] as usize);
            let d = sys.particles[b].pos - sys.particles[a].pos;
            let len = d.length();
            if len > 1e-9 {
                let f = p.spring * (len - p.particle_length) * d / len;
                force[a] += f;
                force[b] -= f;
            }
        }
    }
    let blocked: Vec<Option<DVec2>> =
        sys.particles.iter().map(|q| q.blocked_by.map(|o| sys.particles[o as usize].vel)).collect();
    for (k, q) in sys.particles.iter_mut().enumerate() {
        let mass =
            p.crust_density * std::f64::consts::PI * 0.25 * q.thickness * q.thickness * p.particle_length;
        q.spring_vel = (q.spring_vel + force[k] / mass.max(1e-6) * dt) * 0.8;
        let carried = match blocked[k] {
            Some(v) if p.rolling => q.vel + (v - q.vel) * 0.1,
            Some(v) => v,
            None => sample::surface_velocity(field, surface, q.pos),
        };
        let vel = carried + q.spring_vel;
        let next = q.pos + vel * dt;
        if sample::cylinder_on_flow(field, next, q.tangent, p.particle_length, q.thickness) {
            q.pos = next;
            q.vel = vel;
        } else {
            q.vel = DVec2::ZERO;
            q.spring_vel = DVec2::ZERO;
        }
        q.age += dt;
        let rise = if p.rise_time > 0.0 { (q.age / p.rise_time).min(1.0) } else { 1.0 };
        q.offset = -0.5 * q.thickness * (1.0 - rise);
        q.blocked_by = None;
    }
    for fold in &sys.folds {
        let c = &fold.chain;
        for (i, &k) in c.iter().enumerate() {
            let prev = c[i.saturating_sub(1)] as usize;
            let next = c[(i + 1).min(c.len() - 1)] as usize;
            let d = sys.particles[next].pos - sys.particles[prev].pos;
            if let Some(t) = d.try_normalize() {
                sys.particles[k as usize].tangent = t;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16 m × 16 m sheet of 1 m lava with 2 cm crust; the surface moves at +0.3 m/s in y
    /// below `y_split` and is still above it.
    fn setup(y_split: f64) -> (FlowField, SurfaceState) {
        let n = 32;
        let mut f = FlowField::flat(n, n, 0.5).unwrap();
        f.h.data_mut().fill(1.0);
        let mut s = SurfaceState::new(n, n);
        s.crust.fill(0.02);
        for j in 0..n {
            for i in 0..n {
                if (j as f64) * 0.5 < y_split {
                    s.vsurf[1][j * n + i] = 0.3;
                }
            }
        }
        (f, s)
    }

    /// Two straight folds along x at y = y0 and y1 (ℓ = 0.4 m, 10 particles each).
    fn two_folds(y0: f64, y1: f64, h0: f64) -> FoldSystem {
        let mut sys = FoldSystem::new(7);
        for (f, y) in [y0, y1].into_iter().enumerate() {
            let mut chain = Vec::new();
            for i in 0..10 {
                let pos = DVec2::new(5.5 + 0.5 * i as f64, y);
                let mut q = create_particle(pos, DVec2::X, 0.4, f as u32);
                q.roll_height = if f == 0 { h0 } else { 0.0 };
                sys.particles.push(q);
                chain.push((sys.particles.len() - 1) as u32);
            }
            sys.folds.push(Fold { chain, follower: None, first: f == 0 });
        }
        sys
    }

    fn create_particle(pos: DVec2, tangent: DVec2, ell: f64, fold: u32) -> FoldParticle {
        FoldParticle {
            pos,
            spring_vel: DVec2::ZERO,
            vel: DVec2::ZERO,
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

    fn min_gap(sys: &FoldSystem) -> f64 {
        let mut m = f64::INFINITY;
        for a in sys.particles.iter().filter(|q| q.fold == 0) {
            for b in sys.particles.iter().filter(|q| q.fold == 1) {
                m = m.min(a.pos.distance(b.pos));
            }
        }
        m
    }

    #[test]
    fn colliding_folds_keep_their_minimum_distance() {
        let (f, s) = setup(7.0);
        let lava = LavaParams::isothermal(1000.0).unwrap();
        let p = FoldParams { detect_every: 1_000_000, ..Default::default() };
        // Fold 0 at y = 4 moves toward the still fold 1 at y = 7.2 (ℓ/2 + ℓ'/2 = 0.4 m).
        let mut sys = two_folds(4.0, 7.2, 0.0);
        let mut collisions = 0;
        for _ in 0..1500 {
            collisions += update_folds(&mut sys, &f, &s, &lava, &p, 0.02).collisions;
        }
        let gap = min_gap(&sys);
        assert!(collisions > 0);
        assert!(gap >= 0.4 - 1e-9, "gap {gap}");
        // Fold 0 really travelled up to fold 1 (30 s at 0.3 m/s would be 9 m).
        let y0 = sys.particles.iter().filter(|q| q.fold == 0).map(|q| q.pos.y).sum::<f64>() / 10.0;
        assert!((y0 - 6.8).abs() < 0.05, "fold 0 stopped at y = {y0}");
        // Springs kept the chain together (rest length L = 0.5 m).
        for w in sys.folds[0].chain.windows(2) {
            let d = sys.particles[w[0] as usize].pos.distance(sys.particles[w[1] as usize].pos);
            assert!((d - 0.5).abs() < 0.05, "{d}");
        }
    }

    #[test]
    fn rolling_folds_go_over_or_under_per_the_rules() {
        let (f, s) = setup(7.0);
        let lava = LavaParams::isothermal(1000.0).unwrap();
        let p = FoldParams { detect_every: 1_000_000, rolling: true, ..Default::default() };
        for (start, expect) in [(0.05, 1.0), (-0.05, -1.0)] {
            let mut sys = two_folds(4.0, 7.2, start);
            for _ in 0..1000 {
                update_folds(&mut sys, &f, &s, &lava, &p, 0.02);
            }
            let rolled: Vec<f64> =
                sys.particles.iter().filter(|q| q.fold == 0).map(|q| q.roll_height).collect();
            assert!(rolled.iter().all(|&h| h * expect > 0.0), "start {start}: {rolled:?}");
            let max_dz = rolled.iter().fold(0.0f64, |m, h| m.max(h.abs()));
            assert!(max_dz <= 0.4 + 1e-9);
        }
    }

    #[test]
    fn fold_thickness_eq_5_4() {
        // √(0.02 · 0.6) · (1e3)^{1/6} = 0.1095 · 3.162 = 0.3464 m
        assert!((fold_thickness(0.02, 0.6, 1e3) - 0.34641).abs() < 1e-4);
        assert!(FoldParams::default().validate().is_ok());
        assert!(FoldParams { spring: -1.0, ..Default::default() }.validate().is_err());
    }
}
