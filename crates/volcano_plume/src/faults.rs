//! The plume crate's side of the guard ([`volcano_core::fault`]): the model steps remove
//! slices, umbrella spheres and pyroclastic particles whose state is no longer finite and book
//! their ash as lost; the systems report each volcano's removals as one [`SimFault`] a domain.

use bevy::prelude::*;
use volcano_core::{SimDomain, SimFault};

/// Writes (and logs) one [`SimFault`] for `volcano` when `lost_kg` (the ash of each thing the
/// guard removed) is not empty.
pub(crate) fn report(
    writer: &mut MessageWriter<SimFault>,
    volcano: Entity,
    domain: SimDomain,
    lost_kg: &[f64],
) {
    if lost_kg.is_empty() {
        return;
    }
    let fault = SimFault {
        lost_ash_kg: lost_kg.iter().sum(),
        ..SimFault::new(volcano, domain, lost_kg.len() as u64)
    };
    fault.warn();
    writer.write(fault);
}
