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
            // Owned by volcano_core; registering twice is harmless.
            .add_message::<SimFault>()
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
            .add_systems(Update, warn_unplaced_atmospheres)
            .add_systems(Last, pipeline::join_on_exit);
    }
}

/// What of `transform` an atmosphere ignores: its grid is centred on the world origin, so any
/// translation, rotation or scale. Empty for the identity.
fn ignored_by_atmosphere(transform: &Transform) -> Vec<&'static str> {
    // What no heightfield-bound entity takes (rotation, scale), and any translation at all.
    let mut parts: Vec<_> = volcano_core::terrain::ignored_transform_parts(transform)
        .into_iter()
        .filter(|p| *p != "y translation")
        .collect();
    if transform.translation != Vec3::ZERO {
        parts.insert(0, "translation");
    }
    parts
}

/// Warns once per change about an atmosphere entity whose `Transform` would move it: the grid
/// stays centred on the world origin (spawn the terrain and volcano so that the air covers
/// them, e.g. with `AtmosphereSpawner::over`).
fn warn_unplaced_atmospheres(atmospheres: Query<(Entity, Ref<Transform>), With<Atmosphere>>) {
    for (entity, transform) in &atmospheres {
        if !transform.is_changed() {
            continue;
        }
        let ignored = ignored_by_atmosphere(&transform);
        if !ignored.is_empty() {
            warn!(
                "atmosphere {entity}: its grid is centred on the world origin, so its Transform's \
                 {} is ignored",
                ignored.join(", ")
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_atmosphere_names_what_of_its_transform_it_ignores() {
        assert!(ignored_by_atmosphere(&Transform::IDENTITY).is_empty());
        let moved = Transform::from_xyz(0.0, 0.0, -20_000.0).with_scale(Vec3::splat(2.0));
        assert_eq!(ignored_by_atmosphere(&moved), ["translation", "scale"]);
        let turned = Transform::from_rotation(Quat::from_rotation_y(0.3));
        assert_eq!(ignored_by_atmosphere(&turned), ["rotation"]);
        // A height alone is a translation too, named once.
        assert_eq!(ignored_by_atmosphere(&Transform::from_xyz(3.0, 5.0, 0.0)), ["translation"]);
        assert_eq!(ignored_by_atmosphere(&Transform::from_xyz(0.0, 5.0, 0.0)), ["translation"]);
    }
}
