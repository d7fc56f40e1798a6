//! What one pyroclastic step did (see [`super`]): for each volcano, where each of its
//! particles came from, the flows that started, the secondary columns that formed; what the
//! caps removed.

use bevy::math::Vec3;

use crate::model::slice::Slice;

/// A collapse turned into particles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowStarted {
    /// World position of the collapsing slice.
    pub position: Vec3,
    /// Particles spawned.
    pub particles: usize,
    /// Their total mass (kg).
    pub mass: f64,
}

/// Buoyant particles lifted off as a new rising slice (§3.6).
#[derive(Debug, Clone, PartialEq)]
pub struct SecondaryColumn {
    /// Its emission index (the volcano's next slice number).
    pub index: u64,
    /// Vent (world) of the particles it formed from: the frame of `state`.
    pub vent: Vec3,
    /// The new slice (plume frame of `vent`).
    pub state: Slice,
    /// World position of the new slice.
    pub position: Vec3,
    /// Particles it replaced.
    pub particles: usize,
}

/// One volcano's part of the step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VolcanoFlowsReport {
    /// Particles the volcano held at the start of the step; those a collapse added are
    /// numbered after them, in the order of the collapses.
    pub held: usize,
    /// `kept[i]` is the number (as above) of the particle now at position `i` of
    /// [`VolcanoFlows::particles`](super::VolcanoFlows::particles); every number not listed
    /// was removed (settled, left the terrain, lifted off, capped or no longer finite).
    pub kept: Vec<usize>,
    /// Collapses handed over, in order.
    pub started: Vec<FlowStarted>,
    /// Secondary columns formed, in order of their index.
    pub columns: Vec<SecondaryColumn>,
    /// Clusters that lifted off without a column ([`FlowInputs::max_secondary_per_step`](super::FlowInputs::max_secondary_per_step)).
    pub secondary_retired: u64,
    /// Their mass (kg), booked as lifted.
    pub secondary_retired_kg: f64,
    /// Per particle removed because its state was no longer finite, the mass it still held
    /// (kg, 0 where that was not finite), booked as lost.
    pub non_finite: Vec<f64>,
}

/// What one step of the pyroclastic domain did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FlowsReport {
    /// Per volcano, in the state's order.
    pub volcanoes: Vec<VolcanoFlowsReport>,
    /// The particles removed, as (volcano, number as in [`VolcanoFlowsReport::kept`]), in the
    /// order the step removed them: in the particle step in each volcano's order, by the cap in
    /// id order, at lift-off cluster by cluster. (The plugin despawns in this order, which
    /// fixes Bevy's table order, and with it the next step's gathering order.)
    pub removed: Vec<(usize, usize)>,
    /// Per terrain: its deposit changed (created, added to, relaxed).
    pub grounds_changed: Vec<bool>,
    /// Particles settled by the particle cap ([`FlowInputs::max_particles`](super::FlowInputs::max_particles)).
    pub particles_settled: u64,
    /// Their mass (kg), deposited or lost off the map.
    pub particle_kg: f64,
    /// Caps that acted in this step (the particle cap, and each volcano's secondary-column
    /// cap, count one each).
    pub capped: u64,
}
