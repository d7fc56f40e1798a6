//! [`AtmospherePlugin`]: the weather domain (`WeatherStep`, `Period(1 s)` = one 1 s step per
//! simulated second at any fixed rate by default, docs/ARCHITECTURE.md §3.4). An [`Atmosphere`]
//! entity carries the grid, coefficients, clock and ground; each [`AirLayer`] entity holds one
//! layer's fields in one component; an [`AtmosphereScenario`] entity is built into an
//! atmosphere at the next tick. Each weather tick writes back the step started one weather step
//! earlier and starts the next one off the main thread on a snapshot ([`pipeline`], §3.3).

mod components;
pub mod pipeline;
mod shared;
mod snapshot;
mod spawn;

use bevy::prelude::*;
use volcano_core::prelude::*;

pub use components::{
    AirLayer, Atmosphere, AtmosphereGround, AtmosphereTimeline, WeatherStep, WeatherStepped, WeatherSystems,
    air_ash_at, atmosphere_fields,
};
pub use pipeline::{
    AtmosphereWork, WeatherPipelineSettings, WeatherPipelineStatus, flush_weather, join_weather,
};
pub use shared::SharedFields;
pub use spawn::{
    AtmosphereScenario, AtmosphereScenarioStatus, AtmosphereSpawner, spawn_atmosphere, spawn_scenario,
    spawn_scenario_with,
};

/// The layered atmosphere: systems in [`WeatherStep`] and [`WeatherSystems`], and the messages
/// they send.
#[derive(Debug, Clone)]
pub struct AtmospherePlugin {
    /// How often the weather steps (default once per simulated second).
    pub cadence: Cadence,
}

impl Default for AtmospherePlugin {
    fn default() -> Self {
        Self { cadence: Cadence::Period(std::time::Duration::from_secs(1)) }
    }
}

impl Plugin for AtmospherePlugin {
    fn build(&self, app: &mut App) {
        app.add_sim_domain::<WeatherStep>(SimSystems::Weather, self.cadence)
            .add_message::<WeatherStepped>()
            .init_resource::<WeatherPipelineSettings>()
            .register_type::<Atmosphere>()
            .register_type::<AirLayer>()
            .register_type::<AtmosphereGround>()
            .register_type::<AtmosphereTimeline>()
            .register_type::<AtmosphereScenario>()
            .register_type::<AtmosphereScenarioStatus>()
            .register_type::<WeatherPipelineSettings>()
            .register_type::<WeatherPipelineStatus>()
            // An atmosphere written from a saved world has neither (one is a task, the other a
            // report): start them empty.
            .register_required_components::<Atmosphere, AtmosphereWork>()
            .register_required_components::<Atmosphere, WeatherPipelineStatus>()
            .configure_sets(FixedUpdate, WeatherSystems::Apply.in_set(SimSystems::BeforeWeather))
            .add_systems(
                FixedUpdate,
                pipeline::apply_weather.run_if(pipeline::weather_due).in_set(WeatherSystems::Apply),
            )
            // After `SimSystems::Begin` placed the terrains; the new atmosphere steps this tick.
            .add_systems(
                FixedUpdate,
                spawn::build_scenario_atmospheres
                    .in_set(SimSystems::BeforeWeather)
                    .before(WeatherSystems::Apply),
            )
            .add_systems(WeatherStep, pipeline::start_weather)
            .add_systems(Last, pipeline::join_on_exit);
    }
}
