//! Spawning atmospheres: one [`Atmosphere`] entity and one [`AirLayer`] entity per layer.

use bevy::prelude::*;
use volcano_core::prelude::*;

use super::components::{AirLayer, Atmosphere, AtmosphereGround, AtmosphereTimeline};
use super::pipeline::{AtmosphereWork, WeatherPipelineStatus};
use crate::model::fields::AtmosphereState;
use crate::model::params::AtmosphereParams;
use crate::model::run::apply_event;
use crate::model::scenario::WeatherScenario;
use crate::model::step::{Workspace, step};

/// Spawns an atmosphere from a model state (e.g. `WeatherScenario::build`): one [`Atmosphere`]
/// entity and one [`AirLayer`] entity per layer (children of it). Returns the atmosphere.
pub fn spawn_atmosphere(
    commands: &mut Commands,
    state: AtmosphereState,
    params: AtmosphereParams,
) -> Result<Entity, ConfigError> {
    params.validate()?;
    let work = Workspace::new(&state)?;
    let AtmosphereState { grid, layers, ground, time_s, start_hour, day_of_year, latitude_deg, precipitated } =
        state;
    let atmosphere = commands
        .spawn((
            Name::new("Atmosphere"),
            Atmosphere {
                n: grid.n,
                dx: grid.dx,
                params,
                time_s,
                start_hour,
                day_of_year,
                latitude_deg,
                precipitated,
            },
            AtmosphereGround(ground),
            AtmosphereWork::new(work),
            WeatherPipelineStatus::default(),
        ))
        .id();
    for (index, fields) in layers.into_iter().enumerate() {
        commands.spawn((
            Name::new(format!("Air layer {index} ({} m)", fields.altitude)),
            AirLayer { atmosphere, index, fields: fields.into() },
            ChildOf(atmosphere),
        ));
    }
    Ok(atmosphere)
}

/// Spawns a scenario (its state on an `n × n` grid, or its own, its coefficients and its
/// timeline) as in [`spawn_atmosphere`]. Returns the atmosphere entity.
pub fn spawn_scenario(
    commands: &mut Commands,
    scenario: &WeatherScenario,
    grid: Option<usize>,
) -> Result<Entity, ConfigError> {
    let state = scenario.build(grid)?;
    let entity = spawn_atmosphere(commands, state, scenario.params.clone())?;
    let mut events = scenario.events.clone();
    events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    commands.entity(entity).insert(AtmosphereTimeline(events));
    Ok(entity)
}

/// Spawns a scenario as in [`spawn_scenario`], over a game's own `terrain` if given (sampled
/// at the cell centres, `WeatherScenario::build_with_terrain`), after running `prespin_steps` model
/// steps of the scenario's Δt (timeline events included) so a scene starts with developed
/// weather. Returns the atmosphere entity.
pub fn spawn_scenario_with(
    commands: &mut Commands,
    scenario: &WeatherScenario,
    grid: Option<usize>,
    terrain: Option<&Terrain>,
    prespin_steps: u32,
) -> Result<Entity, ConfigError> {
    let mut state = match terrain {
        Some(t) => scenario.build_with_terrain(grid, t)?,
        None => scenario.build(grid)?,
    };
    let mut events = scenario.events.clone();
    events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    if prespin_steps > 0 {
        let mut work = Workspace::new(&state)?;
        let mut next = 0;
        for _ in 0..prespin_steps {
            while next < events.len() && events[next].at_s <= state.time_s {
                apply_event(&mut state, &events[next]);
                next += 1;
            }
            step(&mut state, &scenario.params, &mut work, scenario.dt)?;
        }
        events.drain(..next);
    }
    let entity = spawn_atmosphere(commands, state, scenario.params.clone())?;
    commands.entity(entity).insert(AtmosphereTimeline(events));
    Ok(entity)
}

/// Spawns a scenario's atmosphere with named options instead of positional ones:
///
/// ```text
/// let air = AtmosphereSpawner::new(&WeatherScenario::builtin("eruption")?)
///     .over(&terrain)      // the game's terrain under the grid (else the scenario's own)
///     .grid(128)           // cells per side (else the scenario's)
///     .prespin(60)         // model steps run before it appears (developed weather)
///     .spawn(&mut commands)?;
/// ```
///
/// The same as [`spawn_scenario_with`]; the atmosphere entity is returned.
#[derive(Debug, Clone, Copy)]
pub struct AtmosphereSpawner<'a> {
    scenario: &'a WeatherScenario,
    grid: Option<usize>,
    terrain: Option<&'a Terrain>,
    prespin_steps: u32,
}

impl<'a> AtmosphereSpawner<'a> {
    /// The scenario's atmosphere on its own grid and terrain, from its start.
    pub fn new(scenario: &'a WeatherScenario) -> Self {
        Self { scenario, grid: None, terrain: None, prespin_steps: 0 }
    }

    /// `n × n` cells instead of the scenario's grid (validated when spawning).
    pub fn grid(self, n: usize) -> Self {
        Self { grid: Some(n), ..self }
    }

    /// Over the game's `terrain` (sampled at the cell centres) instead of the scenario's own.
    pub fn over(self, terrain: &'a Terrain) -> Self {
        Self { terrain: Some(terrain), ..self }
    }

    /// Runs `steps` model steps of the scenario's Δt (its timeline events included) before the
    /// atmosphere appears, so a scene starts with developed weather.
    pub fn prespin(self, steps: u32) -> Self {
        Self { prespin_steps: steps, ..self }
    }

    /// Spawns the atmosphere and its layers; errors (spawning nothing) on an invalid grid or a
    /// terrain the scenario cannot be built over.
    pub fn spawn(self, commands: &mut Commands) -> Result<Entity, ConfigError> {
        spawn_scenario_with(commands, self.scenario, self.grid, self.terrain, self.prespin_steps)
    }
}
