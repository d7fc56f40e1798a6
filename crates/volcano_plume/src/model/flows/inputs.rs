//! What the pyroclastic domain's step reads (plain data, see [`super`]).

use bevy::math::Vec3;
use volcano_core::{Terrain, VolcanoRng};

use crate::model::params::PlumeParams;
use crate::model::pyroclastic::PyroclasticParams;
use crate::model::slice::Slice;

/// A slice the plume handed over in a collapse (§3.6): the model's side of `SliceCollapsed`.
#[derive(Debug, Clone, PartialEq)]
pub struct Collapsed {
    /// The slice's emission index (its particles' ids are `(index << 16) | k`, their random
    /// stream `("collapse", index)`).
    pub index: u64,
    /// Vent position (world) the slice was emitted from.
    pub vent: Vec3,
    /// The slice's state at its collapse (plume frame).
    pub state: Slice,
}

/// One erupting volcano's inputs, matched by position with
/// [`FlowsState::volcanoes`](super::FlowsState::volcanoes).
#[derive(Debug, Clone, Copy)]
pub struct VolcanoInputs<'a> {
    /// Its eruption's parameters: the atmosphere and wind particles feel.
    pub plume: &'a PlumeParams,
    /// Its pyroclastic parameters.
    pub pyroclastic: &'a PyroclasticParams,
    /// Its random streams (the scatter of a collapse's particles).
    pub rng: &'a VolcanoRng,
    /// The terrain it stands on (an index into [`FlowInputs::terrains`]); `None`: its
    /// particles have no ground and are lost.
    pub ground: Option<usize>,
    /// Slices that collapsed since the last step, in the order they did.
    pub collapsed: &'a [Collapsed],
}

/// Everything one pyroclastic step reads besides its state.
#[derive(Debug, Clone, Copy)]
pub struct FlowInputs<'a> {
    /// Step length (s): the pyroclastic domain's step (one base tick).
    pub dt: f64,
    /// Jacobi passes of every deposit's relaxation to its angle of repose in this step
    /// ([`DepositMap::relax`](crate::model::ground::DepositMap::relax)): the plugin gives one
    /// per quarter second of domain time, on the steps crossing 1/8, 3/8, 5/8 and 7/8 of a
    /// second ([`RELAX_PERIOD`](super::RELAX_PERIOD), `volcano_core::clock::crossings`), so
    /// four a second at any tick rate, spread out, and never on the tick of the
    /// once-per-second weather step.
    pub relax_passes: u32,
    /// Most live particles, all volcanoes together (`PlumeCaps::max_particles`, validated).
    pub max_particles: usize,
    /// Most secondary columns one volcano forms per step (`PlumeCaps::max_secondary_per_step`).
    pub max_secondary_per_step: usize,
    /// Per volcano, in the order of [`FlowsState::volcanoes`](super::FlowsState::volcanoes).
    pub volcanoes: &'a [VolcanoInputs<'a>],
    /// The terrains, in the order of [`FlowsState::grounds`](super::FlowsState::grounds).
    pub terrains: &'a [&'a Terrain],
}
