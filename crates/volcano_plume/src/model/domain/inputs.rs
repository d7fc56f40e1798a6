//! What one plume domain step reads (see [`super`]).

use bevy::math::Vec3;
use volcano_core::VolcanoRng;

use super::state::RingSphere;
use crate::model::ambient::LayeredAmbient;
use crate::model::params::PlumeParams;
use crate::model::spheres::SphereParams;

/// The air the column and its umbrella read.
#[derive(Debug, Clone, Copy)]
pub enum PlumeAir<'a> {
    /// The eruption's own: [`PlumeParams::air`] and [`PlumeParams::wind`].
    Own,
    /// A coupled atmosphere's layers around the column (§4.3.3).
    Coupled(&'a LayeredAmbient),
}

/// Where new slices leave from.
#[derive(Debug, Clone, Copy)]
pub struct Emitter<'a> {
    /// Vent position in world space.
    pub vent: Vec3,
    /// The volcano's random state (each slice's ring comes from its own stream).
    pub rng: &'a VolcanoRng,
}

/// Bookkeeping limits of one step (from `PlumeCaps`; `usize::MAX` for none).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepCaps {
    /// Most live slices.
    pub max_live_slices: usize,
    /// Most umbrella spheres.
    pub max_umbrella_spheres: usize,
}

impl Default for StepCaps {
    fn default() -> Self {
        Self { max_live_slices: usize::MAX, max_umbrella_spheres: usize::MAX }
    }
}

/// What one step reads.
#[derive(Debug, Clone, Copy)]
pub struct PlumeInputs<'a> {
    /// Slice parameters.
    pub params: &'a PlumeParams,
    /// Sphere counts of new rings.
    pub spheres: &'a SphereParams,
    /// Whether the eruption emits.
    pub active: bool,
    /// The eruption's parameters failed validation (a bad live edit): nothing is emitted and
    /// the slices hold still until they are fixed; the umbrella goes on.
    pub frozen: bool,
    /// Where slices leave from; `None` (no vent or random state yet): no emission, and the
    /// emission clock does not run.
    pub emitter: Option<Emitter<'a>>,
    /// Umbrella spheres older than this expire (s).
    pub umbrella_lifetime: f64,
    /// Time constant of the ash fallout from umbrella spheres (s).
    pub umbrella_fallout_s: f64,
    /// Ambient air and wind.
    pub air: PlumeAir<'a>,
    /// Caps.
    pub caps: StepCaps,
    /// Where the rings of the slices the state held at the start of the step are: `None` in
    /// [`PlumeState::rings`](super::PlumeState::rings) (a model-only run), or kept by the caller ([`RingSource`]).
    pub rings: Option<RingSource<'a>>,
    /// Step length (s).
    pub dt: f64,
    /// Time the umbrella phase advances in this step (s): the spheres' spreading, drift,
    /// fallout, ageing and expiry, then the umbrella cap. `dt` steps the umbrella with the
    /// column; 0 skips the phase (the spheres keep their state, spheres detached in this step
    /// included, and the cap waits). The plugin steps the umbrella once per base tick instead
    /// of in each of the column's ten substeps (docs/ARCHITECTURE.md §2.2): its laws are exact
    /// for any step, its motion slow. Negative or non-finite values count as 0.
    pub umbrella_dt: f64,
}

/// Rings kept by the caller (the plugin keeps them on the s1 entities, and looks them up only
/// for the few slices that leave the column in a step). With one, [`PlumeState::rings`](super::PlumeState::rings) starts
/// a step holding none of the live slices' rings; the step appends those of the slices it
/// emits and, once per step, asks the source for the rings of the slices that leave the
/// column (retired, non-finite, at their apex or collapsed) by index: the source returns their
/// spheres, each ring in its own order (rings may be interleaved), and the step appends them
/// to [`PlumeState::rings`](super::PlumeState::rings), so the positions in the report stay valid.
#[derive(Clone, Copy)]
pub struct RingSource<'a>(pub &'a dyn Fn(&[u64]) -> Vec<RingSphere>);

impl std::fmt::Debug for RingSource<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("RingSource(..)")
    }
}
