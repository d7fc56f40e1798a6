//! [`SimFault`]: what a domain's guard reports when it finds state that is no longer finite.
//!
//! Every domain checks its state once per step in every build (release included), because a
//! shipped game has no debug assertions: one NaN left in a grid spreads through every
//! neighbour within a few steps, and the bounds of a `clamp` computed from it panic. A guard
//! resets the bad cells (or removes the bad particles, slices or spheres), books what they
//! held as lost in the domain's own mass or volume accounts so the budgets still close, logs
//! a warning and writes one [`SimFault`] per entity and step.

use bevy::ecs::entity::Entity;
use bevy::ecs::message::Message;
use bevy::reflect::Reflect;

/// The simulation domain a [`SimFault`] comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Reflect)]
pub enum SimDomain {
    /// A lava field (`LavaState`): cells reset.
    Lava,
    /// An atmosphere's layers and ground: cells reset.
    Atmosphere,
    /// The plume → atmosphere coupling: ash parcels dropped.
    Coupling,
    /// A volcano's pyroclastic flows: particles removed.
    Pyroclastic,
    /// A volcano's rising column: slices removed.
    Plume,
    /// A volcano's umbrella cloud: spheres removed.
    Umbrella,
}

/// A domain found non-finite (or impossible, e.g. negative amounts) state in `entity` and
/// repaired it. The amounts are what the repaired cells or removed particles still held where
/// that was finite (an amount that was itself NaN is unknown and counts as zero); they are
/// booked as lost in the domain's accounts (e.g. `VolumeBudget::faulted` of a lava field,
/// `PlumeAshBudget::lost_kg`, `PyroclasticBudget::lost`).
#[derive(Message, Debug, Clone, PartialEq, Reflect)]
pub struct SimFault {
    /// The entity whose state was repaired (lava field, atmosphere, volcano).
    pub entity: Entity,
    /// Which of its domains.
    pub domain: SimDomain,
    /// Cells reset, or particles, slices, spheres or parcels removed.
    pub repaired: u64,
    /// Ash removed with them (kg).
    pub lost_ash_kg: f64,
    /// Water (vapour and condensed) removed with them (kg).
    pub lost_water_kg: f64,
    /// Liquid lava removed with them (m³).
    pub lost_lava_m3: f64,
}

impl SimFault {
    /// A fault of `domain` in `entity` with `repaired` things repaired and nothing booked yet.
    pub fn new(entity: Entity, domain: SimDomain, repaired: u64) -> Self {
        Self { entity, domain, repaired, lost_ash_kg: 0.0, lost_water_kg: 0.0, lost_lava_m3: 0.0 }
    }

    /// Logs the fault as a warning (every guard reports what it did).
    pub fn warn(&self) {
        bevy::log::warn!("{self}");
    }
}

impl std::fmt::Display for SimFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:?} state of {} was not finite: {} repaired, lost {:.3e} kg ash, {:.3e} kg water, \
             {:.3e} m³ lava",
            self.domain, self.entity, self.repaired, self.lost_ash_kg, self.lost_water_kg, self.lost_lava_m3
        )
    }
}

/// A finite, non-negative amount, else 0: what a guard can still book of a value it resets.
pub fn bookable(x: f64) -> f64 {
    if x.is_finite() && x > 0.0 { x } else { 0.0 }
}
