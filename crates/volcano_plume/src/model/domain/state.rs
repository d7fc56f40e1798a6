//! The plume domain's state: one volcano's live slices, their rings, its umbrella, its
//! emission clock and ash books (plain data, see [`super`]).

use bevy::math::{DVec3, Vec3};
use volcano_core::VolcanoRng;

use crate::model::params::PlumeParams;
use crate::model::slice::Slice;
use crate::model::spheres::{S1Sphere, SphereParams, s1_ring};
use crate::model::umbrella::UmbrellaSphere;

/// Most slices an eruption emits per plume step.
pub const MAX_EMISSIONS_PER_STEP: u32 = 4;

/// A live slice of the column: the model's side of a `PlumeSlice` (without its volcano).
#[derive(Debug, Clone, PartialEq)]
pub struct LiveSlice {
    /// Emission index, also the id of its random stream ("slice", index).
    pub index: u64,
    /// Vent position in world space when emitted (its `y` is the vent's altitude).
    pub vent: Vec3,
    /// Model state, plume frame (z above the vent).
    pub state: Slice,
    /// Spin angle of a ring sphere of mean size, `∫ v / (r/2) dt` (rad, unbounded).
    pub ring_phase: f64,
    /// Ash shed (σ_col, eq 3.9) and not yet handed to an atmosphere (kg).
    pub ash_pending: f64,
    /// A secondary column lifted off a pyroclastic flow (not emitted at the vent).
    pub secondary: bool,
}

impl LiveSlice {
    /// A new slice at the vent (§3.4.1).
    pub fn at_vent(p: &PlumeParams, index: u64, vent: Vec3) -> Self {
        Self { index, vent, state: Slice::at_vent(p), ring_phase: 0.0, ash_pending: 0.0, secondary: false }
    }
}

/// An s1 sphere on a live slice's vortex ring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingSphere {
    /// Index of the slice it rides on.
    pub slice: u64,
    /// Stable id `(slice index << 8) | k`.
    pub id: u64,
    /// Position on the ring and size factor.
    pub sphere: S1Sphere,
}

/// The ring of s1 spheres of slice `index` (§3.5.1), from its own random stream
/// `("slice", index)`: the same spheres whoever asks.
pub fn ring(spheres: &SphereParams, rng: &VolcanoRng, index: u64) -> Vec<RingSphere> {
    s1_ring(spheres, &mut rng.stream("slice", index))
        .into_iter()
        .enumerate()
        .map(|(k, sphere)| RingSphere { slice: index, id: (index << 8) | k as u64, sphere })
        .collect()
}

/// A sphere of the spreading umbrella: the model's side of an `Umbrella` (without its volcano).
#[derive(Debug, Clone, PartialEq)]
pub struct CloudSphere {
    /// Stable id (that of the s1 sphere it was).
    pub id: u64,
    /// Kinematics.
    pub sphere: UmbrellaSphere,
    /// Radius (m).
    pub radius: f64,
    /// Density of the slice it left (kg/m³).
    pub density: f64,
    /// Seconds since it detached.
    pub age: f64,
    /// Vent position in world space.
    pub vent: Vec3,
    /// Ash still carried (kg).
    pub ash: f64,
    /// Ash fallen out of it and not yet handed to an atmosphere (kg).
    pub ash_pending: f64,
}

impl CloudSphere {
    /// Whether every number of its state is finite (its ash may be NaN only through an edit;
    /// the guard removes such a sphere).
    pub fn is_finite(&self) -> bool {
        self.sphere.is_finite()
            && self.radius.is_finite()
            && self.density.is_finite()
            && self.age.is_finite()
            && self.ash.is_finite()
            && self.ash_pending.is_finite()
            && self.vent.is_finite()
    }

    /// Position in the plume frame of its vent (m, z above the vent).
    pub fn position(&self) -> DVec3 {
        let h = self.sphere.horizontal();
        DVec3::new(h.x, h.y, self.sphere.altitude())
    }
}

/// Emission bookkeeping (the fields of `EmissionState`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Emission {
    /// Seconds since the last slice.
    pub since_last: f64,
    /// Slices numbered so far (vent slices and secondary columns).
    pub emitted: u64,
    /// Slices due at the end of the last step but not emitted; carried to the next steps.
    pub backlog: u64,
    /// Steps that ended with a backlog.
    pub capped_steps: u64,
}

/// Where the emitted ash went (kg; the fields of `PlumeAshBudget`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AshBooks {
    /// Solid mass of every slice emitted at the vent.
    pub emitted_kg: f64,
    /// Solid mass of slices that collapsed into pyroclastic flows.
    pub to_flows_kg: f64,
    /// Ash removed without a place to put it (non-finite state, a slice with no ring spheres).
    pub lost_kg: f64,
    /// Ash released by expiring umbrella spheres and by what the caps retired.
    pub released_kg: f64,
    /// Of `released_kg`, the ash of slices and spheres the caps retired.
    pub capped_kg: f64,
}

/// One volcano's plume: live slices, their rings, the umbrella, emission and ash books.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlumeState {
    /// Live slices (rising, or frozen by an invalid edit).
    pub slices: Vec<LiveSlice>,
    /// The s1 spheres of the live slices, each naming its slice (with a [`RingSource`](super::RingSource), only
    /// those the step needs, see there).
    pub rings: Vec<RingSphere>,
    /// Spheres of the spreading umbrella.
    pub umbrella: Vec<CloudSphere>,
    /// Emission clock and counters.
    pub emission: Emission,
    /// Ash books.
    pub ash: AshBooks,
}
