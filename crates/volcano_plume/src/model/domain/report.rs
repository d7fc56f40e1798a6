//! What one plume domain step did (see [`super`]).

use std::ops::Range;

use super::state::{CloudSphere, LiveSlice, RingSphere};

/// A slice that left the column in this step.
#[derive(Debug, Clone, PartialEq)]
pub struct RemovedSlice {
    /// Its position (numbered after emission).
    pub at: usize,
    /// Its last state.
    pub slice: LiveSlice,
    /// Its ash (kg): released (cap), lost (non-finite), handed to the flows (collapse), shared
    /// among its umbrella spheres (apex) or lost (apex without ring spheres).
    pub ash_kg: f64,
    /// Positions of its ring spheres in [`PlumeState::rings`](super::PlumeState::rings) after emission, in order.
    pub ring: Vec<usize>,
}

/// How a finished slice ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Reached its apex: its ring spheres spread as the umbrella.
    Umbrella,
    /// Collapsed: handed to the pyroclastic flows.
    Collapsed,
}

/// A slice that reached its apex or collapsed in this step.
#[derive(Debug, Clone, PartialEq)]
pub struct Finished {
    /// The slice, its ash and its ring.
    pub removed: RemovedSlice,
    /// How it ended.
    pub outcome: Outcome,
    /// Umbrella spheres made of its ring (positions before the umbrella phase; in ring order).
    pub spheres: Range<usize>,
    /// The buoyancy frequency of a gravity-current umbrella was raised to its floor
    /// (`model::umbrella::MIN_BUOYANCY_FREQUENCY`).
    pub buoyancy_floored: bool,
}

/// A slice crossed its neutral-buoyancy altitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeutralEvent {
    /// Its position (numbered after emission).
    pub at: usize,
    /// Altitude above the vent (m).
    pub altitude: f64,
    /// Vertical speed at that moment (m/s).
    pub speed: f64,
}

/// A new slice.
#[derive(Debug, Clone, PartialEq)]
pub struct Emitted {
    /// Its position.
    pub at: usize,
    /// The slice as it left the vent.
    pub slice: LiveSlice,
    /// Its ring, appended to [`PlumeState::rings`](super::PlumeState::rings) from position `first_ring` on.
    pub ring: Vec<RingSphere>,
    /// Position of its first ring sphere.
    pub first_ring: usize,
}

/// An umbrella sphere that expired, or that the cap retired, in this step.
#[derive(Debug, Clone, PartialEq)]
pub struct RemovedSphere {
    /// Its position (numbered before the umbrella phase).
    pub at: usize,
    /// Its last state.
    pub sphere: CloudSphere,
    /// Ash it released (kg, `ash + ash_pending`; nothing is booked when ≤ 0).
    pub ash_kg: f64,
}

/// What became of a slice in this step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SliceFate {
    /// Still live, at this position of [`PlumeState::slices`](super::PlumeState::slices).
    Kept(usize),
    /// Retired by the cap: entry of [`PlumeReport::retired`].
    Retired(usize),
    /// Non-finite: entry of [`PlumeReport::non_finite`].
    NonFinite(usize),
    /// Apex or collapse: entry of [`PlumeReport::finished`].
    Finished(usize),
}

/// What became of an umbrella sphere in this step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SphereFate {
    /// Still spreading, at this position of [`PlumeState::umbrella`](super::PlumeState::umbrella).
    Kept(usize),
    /// Expired: entry of [`PlumeReport::expired`].
    Expired(usize),
    /// Retired by the cap: entry of [`PlumeReport::umbrella_retired`].
    Retired(usize),
    /// Non-finite: entry of [`PlumeReport::umbrella_non_finite`].
    NonFinite(usize),
}

/// What one step did. Lists are in the order things happened.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlumeReport {
    /// The slices were stepped (false while the eruption is frozen).
    pub stepped: bool,
    /// Slices emitted at the vent.
    pub emitted: Vec<Emitted>,
    /// The step ended with a backlog after one without ([`Emission::backlog`](super::Emission::backlog)).
    pub backlog_began: bool,
    /// Slices the live-slice cap retired (in the cap's order), ash released.
    pub retired: Vec<RemovedSlice>,
    /// Neutral-buoyancy crossings.
    pub neutral: Vec<NeutralEvent>,
    /// Slices removed because their state was no longer finite, ash lost.
    pub non_finite: Vec<RemovedSlice>,
    /// Slices that reached their apex or collapsed.
    pub finished: Vec<Finished>,
    /// Umbrella spheres that expired.
    pub expired: Vec<RemovedSphere>,
    /// Umbrella spheres the cap retired (in the cap's order), ash released.
    pub umbrella_retired: Vec<RemovedSphere>,
    /// Umbrella spheres removed because their state was no longer finite, ash lost.
    pub umbrella_non_finite: Vec<RemovedSphere>,
    /// One per slice position (numbered after emission).
    pub slice_fates: Vec<SliceFate>,
    /// One per umbrella position (numbered before the umbrella phase).
    pub sphere_fates: Vec<SphereFate>,
}

impl PlumeReport {
    /// Slices that collapsed.
    pub fn collapsed(&self) -> impl Iterator<Item = &Finished> {
        self.finished.iter().filter(|f| f.outcome == Outcome::Collapsed)
    }
    /// Slices that reached their apex and spread as the umbrella.
    pub fn spreading(&self) -> impl Iterator<Item = &Finished> {
        self.finished.iter().filter(|f| f.outcome == Outcome::Umbrella)
    }
}
