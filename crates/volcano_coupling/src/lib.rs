//! Plume ↔ atmosphere coupling (thesis §4.3.3): a `Volcano` with an `Eruption` inside the grid
//! of an [`Atmosphere`](volcano_atmosphere::Atmosphere) couples automatically.
//!
//! - **Air → plume**, just after each weather step: per layer, the mean temperature, moisture
//!   and wind over the annulus around the column at that layer's altitude become the ambient
//!   profile every slice reads ([`volcano_plume::PlumeAmbient`]).
//! - **Plume → air**, just before each weather step: per layer, the nearest slice within the
//!   layer's altitude range imposes its temperature and moisture on the cells under the column
//!   (a linear profile peaking at the centre whose mean is the slice's value), and the ash the
//!   slices and umbrella shed goes into the layer it is in. The atmosphere then carries, settles
//!   and deposits the ash; deposits land in the same
//!   [`DepositMap`](volcano_plume::DepositMap) as the pyroclastic flows.
//!
//! [`model`] holds the transfers as plain functions over plain data; [`plugin`] gathers the
//! slices and layers, calls them and writes back (docs/ARCHITECTURE.md §2).
#![forbid(unsafe_code)]

pub mod model;
pub mod plugin;

pub use model::books::CouplingBudget;
pub use model::column::{ColumnSlice, TransferReport};
pub use model::heat::{GroundSource, SourceReport};
pub use model::step::{
    AirReadSide, AirSide, AirToPlumeReport, AmbientRequest, AshParcel, CoupledColumn, GroundHeat,
    PlumeToAirReport,
};
pub use plugin::{AshLedger, CouplingPlugin, CouplingSettings, CouplingSystems, ash_ledger};
