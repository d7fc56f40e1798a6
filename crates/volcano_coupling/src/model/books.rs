//! The books of one atmosphere's coupling, as plain data (the plugin keeps them as a
//! component on the atmosphere entity; the coupling's steps, [`super::step`], write them).

use bevy::prelude::{Component, ReflectComponent};
use bevy::reflect::Reflect;

use super::column::TransferReport;

/// Books of one atmosphere's coupling (kg for ash, g for water): ash received from columns =
/// airborne in the layers + deposited + outflow.
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct CouplingBudget {
    /// Ash handed to this atmosphere by slices and umbrella spheres (kg).
    pub ash_received_kg: f64,
    /// Ash that settled onto the ground (kg), whether or not a terrain was there to show it.
    pub ash_deposited_kg: f64,
    /// Ash that left through the rim, or was handed over outside the grid (kg).
    pub ash_outflow_kg: f64,
    /// Of the deposited ash, what fell off every terrain's map (kg).
    pub ash_off_terrain_kg: f64,
    /// Net water the plume → air transfer wrote into the layers (g).
    pub water_written_g: f64,
    /// Heat the ground's sources (fountains, sea entries) gave the layers (J).
    pub heat_received_j: f64,
    /// Water vapour they gave the layers (kg).
    pub vapour_received_kg: f64,
    /// Heat of sources over this atmosphere that found no free air (J).
    pub heat_outflow_j: f64,
    /// Their vapour that found no free air (kg).
    pub vapour_outflow_kg: f64,
    /// The last plume → air transfer.
    #[reflect(ignore)]
    pub last_transfer: TransferReport,
}
