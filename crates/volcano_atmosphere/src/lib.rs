//! Layered meso-scale atmosphere (thesis §4.2, "Interactive meso-scale simulation of
//! skyscapes"): air layers at irregular altitudes, each a 2D grid of temperature, humidity,
//! condensed water, wind, pressure and vertical exchange fields; stable fluids with a
//! multigrid pressure solve; phase changes with latent heat; convection and uplift between
//! layers; terrain damping, sun, radiation and ground exchange.
//!
//! [`model`] holds plain data and functions; [`plugin`] is the thin Bevy layer; [`view`] is
//! what renderers and panels read.

pub mod model;
pub mod plugin;
pub mod view;

pub use model::fields::{AtmosphereState, GridSpec, LayerFields};
pub use model::paint::{Brush, PaintField, PaintMode, paint};
pub use model::params::AtmosphereParams;
pub use model::run::AtmosphereSummary;
pub use model::scenario::{BUILTIN as BUILTIN_SCENARIOS, WeatherScenario};
pub use model::step::WeatherStepReport;
pub use plugin::{
    AirLayer, Atmosphere, AtmospherePlugin, AtmosphereScenario, AtmosphereScenarioStatus, AtmosphereSpawner,
    AtmosphereTimeline, SharedFields, WeatherPipelineSettings, WeatherPipelineStatus, WeatherStep,
    WeatherStepped, WeatherSystems, air_ash_at, atmosphere_fields, flush_weather, join_weather,
    spawn_atmosphere, spawn_scenario, spawn_scenario_with,
};
