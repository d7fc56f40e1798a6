//! Heat and water vapour that a domain puts into the air from the ground: the gas of a lava
//! fountain, the steam (laze) of lava entering the sea. A domain writes the current rates of its
//! sources on an entity ([`AirHeatSources`]); the coupling reads them at each weather step and
//! lifts them into the atmosphere as a buoyant plume (docs/physics/coupling.md). The rates are
//! per second of the source's own physics, so a source whose domain runs faster than the air
//! (an accelerated lava flow) still heats the air at its physical rate.

use bevy::prelude::*;

use crate::error::{ConfigError, in_range};

/// What makes a heat source.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Reflect)]
pub enum AirHeatKind {
    /// The gas and the cooling clots of a lava fountain.
    #[default]
    Fountain,
    /// Sea water boiled by lava entering the sea (laze).
    SeaEntry,
}

/// One source of heat and vapour at the ground.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct AirHeatSource {
    /// World position of the source (y: the ground's altitude, m).
    pub at: Vec3,
    /// Heat given to the air (W, in [0, 10¹⁴]).
    pub heat_w: f64,
    /// Water vapour given to the air (kg/s, in [0, 10⁸]).
    pub vapour_kg_s: f64,
    /// Radius of the source at the ground (m, in [0, 10⁴]).
    pub radius_m: f64,
    /// What it is.
    pub kind: AirHeatKind,
}

impl AirHeatSource {
    /// Checks every field: a finite position, rates and radius in range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !self.at.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "air heat source position",
                value: f64::NAN,
                reason: "must be finite".into(),
            });
        }
        in_range("air heat source heat_w", self.heat_w, 0.0, 1e14)?;
        in_range("air heat source vapour_kg_s", self.vapour_kg_s, 0.0, 1e8)?;
        in_range("air heat source radius_m", self.radius_m, 0.0, 1e4)?;
        Ok(())
    }
}

/// The air heat sources an entity's domain keeps (rates now; empty when it gives none).
/// Written by the domain plugins (the lava's fountains on the volcano, its sea entries on the
/// terrain); read by the coupling. A game may add its own (a wildfire, a geyser field).
#[derive(Component, Debug, Clone, Default, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct AirHeatSources(pub Vec<AirHeatSource>);

impl AirHeatSources {
    /// Replaces the `kind` entries with `new`, keeping the others (e.g. a game's own); touches
    /// nothing (no change detection) when the list stays the same.
    pub fn set_kind(this: &mut Mut<Self>, kind: AirHeatKind, new: impl IntoIterator<Item = AirHeatSource>) {
        let mut list: Vec<AirHeatSource> = this.0.iter().filter(|s| s.kind != kind).copied().collect();
        list.extend(new);
        if list != this.0 {
            this.0 = list;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_source_with_a_bad_value_is_an_error_naming_it() {
        let ok = AirHeatSource {
            at: Vec3::new(0.0, 10.0, 0.0),
            heat_w: 1e9,
            vapour_kg_s: 10.0,
            radius_m: 20.0,
            kind: AirHeatKind::SeaEntry,
        };
        assert!(ok.validate().is_ok());
        let e = AirHeatSource { heat_w: f64::NAN, ..ok }.validate().unwrap_err();
        assert!(e.to_string().contains("heat_w"), "{e}");
        let e = AirHeatSource { vapour_kg_s: -1.0, ..ok }.validate().unwrap_err();
        assert!(e.to_string().contains("vapour"), "{e}");
        assert!(AirHeatSource { at: Vec3::NAN, ..ok }.validate().is_err());
    }
}
