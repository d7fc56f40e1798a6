//! Model layer: plain structs and functions, each physical law beside the thesis equation it
//! implements.

pub mod ambient;
pub mod column;
pub mod deposit;
pub mod domain;
pub mod flows;
pub mod ground;
pub mod humid;
pub mod inverse;
pub mod params;
pub mod pyroclastic;
pub mod run;
pub mod slice;
pub mod spheres;
pub mod timeline;
pub mod umbrella;
pub mod wind;

use bevy::math::{DVec3, Vec3};
use params::{Dynamics, PlumeParams};
use slice::{Phase, Slice, SliceEnv, SliceStepReport};

impl Slice {
    /// Advances the slice by `dt` seconds (`p.dt` in stand-alone runs, the plume domain's step
    /// in the plugin) while it rises (jet or buoyant), by the thesis' slice law
    /// ([`Dynamics::Thesis`]) or the physical column ([`Dynamics::Column`], [`column`](mod@column)).
    /// Umbrella and collapsed slices are left to the umbrella and pyroclastic models and are
    /// not changed here. A non-finite or non-positive `dt` does nothing.
    pub fn step(&mut self, p: &PlumeParams, env: &SliceEnv, dt: f64) -> SliceStepReport {
        if matches!(self.phase, Phase::Umbrella | Phase::Collapsed) || !(dt.is_finite() && dt > 0.0) {
            return SliceStepReport::default();
        }
        match p.dynamics {
            Dynamics::Column => column::step(self, p, env, dt),
            Dynamics::Thesis => self.step_thesis(p, env, dt),
        }
    }
}

/// Plume frame (z up, metres above the vent) to a world offset (y up). Model x → world x,
/// model y → world −z, so counter-clockwise angles from +x seen from above are preserved.
pub fn plume_to_world(p: DVec3) -> Vec3 {
    Vec3::new(p.x as f32, p.z as f32, -p.y as f32)
}
