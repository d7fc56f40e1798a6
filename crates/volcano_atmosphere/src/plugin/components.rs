//! The weather domain's ECS vocabulary: its schedule label and system set, the atmosphere and
//! layer components, and the message sent when a step's result is applied.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;

use super::shared::SharedFields;
use crate::model::fields::{AtmosphereState, GridSpec, Ground, LayerFields};
use crate::model::params::AtmosphereParams;
use crate::model::scenario::Event;
use crate::model::step::WeatherStepReport;
use volcano_core::error::ConfigError;

/// Schedule of the weather domain: it *starts* a step (docs/ARCHITECTURE.md §3.3).
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, TypePath)]
pub struct WeatherStep;

/// Systems of the atmosphere outside its domain schedule, so other plugins can order against
/// them.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WeatherSystems {
    /// In `SimSystems::BeforeWeather`, on the ticks where the weather is about to step: joins
    /// the step started one weather step earlier and writes its result into the components.
    /// Transfers into the air (plume → air) belong after it.
    Apply,
}

/// The atmosphere over one terrain: grid, coefficients, clock and budgets.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(Component)]
pub struct Atmosphere {
    /// Cells per side.
    pub n: usize,
    /// Cell size (m).
    pub dx: f64,
    /// Model coefficients (live-editable; invalid edits freeze the weather until fixed).
    pub params: AtmosphereParams,
    /// Simulated weather time of the applied state (s): one weather step behind the weather
    /// clock while a step is in flight.
    pub time_s: f64,
    /// Local solar time at the start (h).
    pub start_hour: f64,
    /// Day of the year at the start.
    pub day_of_year: f64,
    /// Latitude (degrees).
    pub latitude_deg: f64,
    /// Water precipitated so far (g).
    pub precipitated: f64,
}

impl Atmosphere {
    /// A model state with this atmosphere's grid, clock and books, no layers and a default
    /// ground: the shell the weather snapshot and the cloud renderer fill with their layers.
    /// An error names a field out of range (an edit through reflection).
    pub fn state_shell(&self) -> Result<AtmosphereState, ConfigError> {
        let shell = AtmosphereState {
            grid: GridSpec::new(self.n, self.dx)?,
            layers: Vec::new(),
            ground: Ground::default(),
            time_s: self.time_s,
            start_hour: self.start_hour,
            day_of_year: self.day_of_year,
            latitude_deg: self.latitude_deg,
            precipitated: self.precipitated,
        };
        shell.check_clock()?;
        Ok(shell)
    }
}

/// One air layer's fields (thesis Table 4.2), on its own entity.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(opaque)]
#[reflect(Component)]
pub struct AirLayer {
    /// The [`Atmosphere`] entity it belongs to.
    #[entities]
    pub atmosphere: Entity,
    /// Position in the stack (0 = lowest).
    pub index: usize,
    /// The fields, shared copy-on-write with the weather step in flight ([`SharedFields`]:
    /// use them as [`LayerFields`]).
    pub fields: SharedFields,
}

/// Ash concentration (g/m³) in the air of `atmosphere` at world position `p` (gameplay: "is
/// ash falling on the player?"), from its `layers` (any order; other atmospheres' layers are
/// skipped): [`crate::model::ash::ash_at`]. 0 outside the layer stack or without layers.
pub fn air_ash_at<'a>(layers: impl IntoIterator<Item = &'a AirLayer>, atmosphere: Entity, p: Vec3) -> f64 {
    crate::model::ash::ash_at(&atmosphere_fields(layers, atmosphere), p.x, p.y as f64, p.z)
}

/// The fields of the layers of `atmosphere` among `layers` (any order; other atmospheres'
/// layers are skipped), bottom to top: the model's view of one atmosphere's stack, read in
/// place.
pub fn atmosphere_fields<'a>(
    layers: impl IntoIterator<Item = &'a AirLayer>,
    atmosphere: Entity,
) -> Vec<&'a LayerFields> {
    let mut mine: Vec<&AirLayer> = layers.into_iter().filter(|l| l.atmosphere == atmosphere).collect();
    mine.sort_by_key(|l| l.index);
    mine.into_iter().map(|l| &*l.fields).collect()
}

/// The ground under an atmosphere (terrain heights, cover, temperature, water).
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(opaque)]
#[reflect(Component)]
pub struct AtmosphereGround(pub Ground);

/// Timeline events still to fire (sorted by time), from a scenario.
#[derive(Component, Debug, Clone, Default, Reflect)]
#[reflect(opaque)]
#[reflect(Component)]
pub struct AtmosphereTimeline(pub Vec<Event>);

/// Sent when the result of a weather step is applied to an atmosphere's components.
#[derive(Message, Debug, Clone)]
pub struct WeatherStepped {
    /// The atmosphere entity.
    pub atmosphere: Entity,
    /// What the step did.
    pub report: WeatherStepReport,
    /// Base tick (`SimTick`) at which the step started from a snapshot of the components.
    pub started_tick: u64,
    /// Base tick at which its result was written back: the next weather tick, k ticks after
    /// `started_tick` for `EveryNthTick(k)`; earlier only after a flush, or while the weather
    /// domain is paused.
    pub applied_tick: u64,
}
