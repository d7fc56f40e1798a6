//! Caps on what an eruption keeps alive, so a runaway eruption (a huge live edit, a collapse
//! shedding thousands of light stragglers) cannot eat the frame: live slices per eruption,
//! pyroclastic particles, secondary columns formed per step. These are bookkeeping limits, not
//! physics: when one acts, what it removes is booked in the existing budgets and counted in
//! [`PlumeCapReport`] (with a warning the first time), never dropped silently, and the choice
//! is deterministic (a stable order, the same at any frame rate).
//!
//! The live-slice and umbrella caps act inside the plume domain's step
//! ([`crate::model::domain::step`], given the numbers as `StepCaps`; the first acts between the
//! emission and the slices' step, the second after the umbrella's), so a model-only run applies
//! them too; the plugin turns what they retired into messages and [`PlumeCapReport`] entries.
//! The particle and secondary-column caps act inside the pyroclastic domain's step
//! ([`crate::model::flows::step`], given the numbers in `FlowInputs`), likewise.
//!
//! - Live slices ([`PlumeCaps::max_live_slices`]): beyond the cap, secondary columns are
//!   retired first (lightest first, then by index), then the column's oldest slices (lowest
//!   emission index, the top of the column). A retired slice's ash (solid mass and what it shed
//!   and has not handed over) is released into the air where it is, as an [`crate::AshReleased`]
//!   message, and booked in [`crate::PlumeAshBudget::released_kg`] and [`crate::PlumeAshBudget::capped_kg`].
//! - Umbrella spheres ([`PlumeCaps::max_umbrella_spheres`], per eruption): beyond it the
//!   oldest (largest age, then id) expire early: their ash is released as when they expire
//!   (an [`crate::AshReleased`] message, [`crate::PlumeAshBudget::released_kg`] and `capped_kg`).
//! - Pyroclastic particles ([`PlumeCaps::max_particles`], all flows): beyond it the oldest
//!   (lowest id, i.e. from the earliest collapse) settle where they are: their mass is
//!   deposited on the ground below them ([`crate::PyroclasticBudget::deposited`], or `lost` off the
//!   map) and counted in [`crate::PyroclasticBudget::capped`].
//! - Secondary columns ([`PlumeCaps::max_secondary_per_step`], per eruption and pyroclastic
//!   step): the heaviest clusters become columns; the lighter ones lift off all the same (their
//!   particles are removed and their mass booked in [`crate::PyroclasticBudget::lifted`] and
//!   [`crate::PyroclasticBudget::capped`]) but no column is simulated for them. A secondary column
//!   carries no ash account (`model::pyroclastic::secondary_column`), so only the light
//!   column's own rise and its heat and moisture for a coupled atmosphere are not simulated.
//!   (They are not held back as particles for a later step: after the eruption scene's
//!   collapse that would re-cluster thousands of stragglers every step.)

use bevy::prelude::*;
use volcano_core::ConfigError;
use volcano_core::error::in_range;

/// The caps (a resource, editable live; `volcano::VolcanoQuality` sets it). The defaults are
/// far above what the built-in scenes reach, so they only act on runaway eruptions.
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct PlumeCaps {
    /// Most live slices per eruption (rising column slices and secondary columns; collapsed
    /// slices waiting for the pyroclastic hand-over are not counted), 16–1,000,000.
    pub max_live_slices: u32,
    /// Most pyroclastic particles alive, all flows together, 100–10,000,000.
    pub max_particles: u32,
    /// Most secondary columns an eruption forms per pyroclastic step, 1–100,000.
    pub max_secondary_per_step: u32,
    /// Most umbrella spheres per eruption, 100–10,000,000.
    pub max_umbrella_spheres: u32,
}

impl Default for PlumeCaps {
    fn default() -> Self {
        Self {
            max_live_slices: 20_000,
            max_particles: 500_000,
            max_secondary_per_step: 1_000,
            max_umbrella_spheres: 100_000,
        }
    }
}

impl PlumeCaps {
    /// Checks every field; the error names it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("max_live_slices", self.max_live_slices as f64, 16.0, 1.0e6)?;
        in_range("max_particles", self.max_particles as f64, 100.0, 1.0e7)?;
        in_range("max_secondary_per_step", self.max_secondary_per_step as f64, 1.0, 1.0e5)?;
        in_range("max_umbrella_spheres", self.max_umbrella_spheres as f64, 100.0, 1.0e7)?;
        Ok(())
    }
}

/// What the caps removed so far (a resource).
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct PlumeCapReport {
    /// Slices retired by [`PlumeCaps::max_live_slices`].
    pub slices_retired: u64,
    /// Their ash released into the air (kg).
    pub slice_ash_released_kg: f64,
    /// Umbrella spheres retired by [`PlumeCaps::max_umbrella_spheres`].
    pub umbrella_retired: u64,
    /// Their ash released into the air (kg).
    pub umbrella_ash_released_kg: f64,
    /// Particles settled by [`PlumeCaps::max_particles`].
    pub particles_settled: u64,
    /// Their mass (kg), deposited (or lost off the map).
    pub particle_kg: f64,
    /// Clusters that lifted off without becoming a column ([`PlumeCaps::max_secondary_per_step`]).
    pub secondary_retired: u64,
    /// Their mass (kg), booked as lifted.
    pub secondary_retired_kg: f64,
    /// Domain steps (plume substeps, pyroclastic steps) on which a cap acted, one per cap.
    pub capped_steps: u64,
}

/// The caps to use: invalid values fall back to the defaults (with a warning).
pub(crate) fn checked(caps: &PlumeCaps) -> PlumeCaps {
    match caps.validate() {
        Ok(()) => caps.clone(),
        Err(e) => {
            warn_once!("PlumeCaps: {e}; using the defaults");
            PlumeCaps::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_are_validated() {
        assert!(PlumeCaps::default().validate().is_ok());
        let e = PlumeCaps { max_particles: 0, ..default() }.validate().unwrap_err();
        assert!(e.to_string().contains("max_particles"), "{e}");
    }
}
