//! The pyroclastic domain's state: every erupting volcano's particles and books, and the
//! deposit of every terrain (plain data, see [`super`]).

use bevy::math::Vec3;

use crate::model::ground::{DepositMap, PyroclasticBudget};
use crate::model::pyroclastic::Particle;

/// One pyroclastic particle: the model's side of a `PyroParticle` (without its volcano).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowParticle {
    /// Stable id `(slice index << 16) | k`: unique within its volcano, increasing with the
    /// collapse it came from (the particle cap settles the lowest first).
    pub id: u64,
    /// Vent position (world) of its volcano when its slice collapsed.
    pub vent: Vec3,
    /// Model state in the vent's plume frame.
    pub particle: Particle,
    /// Lighter than the air after its last step (a secondary-column candidate).
    pub buoyant: bool,
}

/// One erupting volcano's flows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VolcanoFlows {
    /// Live particles, in a stable order (the step keeps it: removals leave the others in
    /// place, new particles are appended).
    pub particles: Vec<FlowParticle>,
    /// Mass books.
    pub budget: PyroclasticBudget,
    /// Slices the volcano has numbered so far (vent slices and secondary columns share the
    /// counter, `EmissionState::emitted`): a secondary column takes the next number.
    pub emitted: u64,
}

/// The whole pyroclastic domain: the volcanoes' flows and the deposit maps of the terrains
/// (every terrain, also those only ash falls on: their deposits relax too).
#[derive(Debug, Clone, Default)]
pub struct FlowsState {
    /// One entry per erupting volcano, matched by position with
    /// [`FlowInputs::volcanoes`](super::FlowInputs::volcanoes).
    pub volcanoes: Vec<VolcanoFlows>,
    /// One deposit per terrain, matched by position with
    /// [`FlowInputs::terrains`](super::FlowInputs::terrains).
    pub grounds: Vec<DepositMap>,
}

impl FlowsState {
    /// Mass of the live particles of every volcano (kg).
    pub fn airborne_kg(&self) -> f64 {
        self.volcanoes.iter().flat_map(|v| &v.particles).map(|p| p.particle.mass).sum()
    }
    /// Live particles of every volcano.
    pub fn particle_count(&self) -> usize {
        self.volcanoes.iter().map(|v| v.particles.len()).sum()
    }
}
