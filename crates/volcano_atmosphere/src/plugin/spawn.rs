//! Spawning atmospheres: one [`Atmosphere`] entity and one [`AirLayer`] entity per layer,
//! from code ([`spawn_atmosphere`], [`AtmosphereSpawner`]) or from an [`AtmosphereScenario`]
//! component the plugin builds on its own entity (what a scene, `bsn!`, writes).

use bevy::prelude::*;
use volcano_core::error::in_range;
use volcano_core::prelude::*;

use super::components::{AirLayer, Atmosphere, AtmosphereGround, AtmosphereTimeline};
use super::pipeline::{AtmosphereWork, WeatherPipelineStatus};
use crate::model::fields::{AtmosphereState, GridSpec};
use crate::model::params::AtmosphereParams;
use crate::model::run::apply_event;
use crate::model::scenario::{Event, WeatherScenario};
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
    let atmosphere = commands.spawn_empty().id();
    insert_atmosphere(commands, atmosphere, state, params, work);
    Ok(atmosphere)
}

/// Makes `atmosphere` an atmosphere of `state` (a name if it has none, the components, one
/// child [`AirLayer`] entity per layer). `params` must be valid and `work` sized for `state`.
fn insert_atmosphere(
    commands: &mut Commands,
    atmosphere: Entity,
    state: AtmosphereState,
    params: AtmosphereParams,
    work: Workspace,
) {
    let AtmosphereState { grid, layers, ground, time_s, start_hour, day_of_year, latitude_deg, precipitated } =
        state;
    commands.entity(atmosphere).insert_if_new(Name::new("Atmosphere")).insert((
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
    ));
    for (index, fields) in layers.into_iter().enumerate() {
        commands.spawn((
            Name::new(format!("Air layer {index} ({} m)", fields.altitude)),
            AirLayer { atmosphere, index, fields: fields.into() },
            ChildOf(atmosphere),
        ));
    }
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
    let (state, events) = prespun_state(scenario, grid, terrain, prespin_steps)?;
    let entity = spawn_atmosphere(commands, state, scenario.params.clone())?;
    commands.entity(entity).insert(AtmosphereTimeline(events));
    Ok(entity)
}

/// The state of `scenario` (over `terrain` if given) after `prespin_steps` model steps, and its
/// timeline events still to fire, sorted by time.
fn prespun_state(
    scenario: &WeatherScenario,
    grid: Option<usize>,
    terrain: Option<&Terrain>,
    prespin_steps: u32,
) -> Result<(AtmosphereState, Vec<Event>), ConfigError> {
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
    Ok((state, events))
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

/// An atmosphere to build on this entity from a built-in scenario: the plugin turns it into an
/// [`Atmosphere`] with its [`AirLayer`] children at the next simulated tick, as
/// [`AtmosphereSpawner`] does in code. This is how a scene (`bsn!`) writes an atmosphere:
///
/// ```text
/// bsn! { #Air AtmosphereScenario { scenario: "eruption", grid: {Some(64)} } }
/// ```
///
/// Like every atmosphere its grid is centred on the world origin. With `over_terrain` (the
/// default) it waits for a `Terrain` whose footprint holds the origin and is built over it
/// (sampled at the cell centres, where the terrain's `Transform` has placed it); without, it is
/// built at once over the scenario's own terrain. [`AtmosphereScenarioStatus`] says how it
/// went; an unknown scenario or an invalid value is an error naming it, found at the first
/// tick (before any wait), logged and kept there until the component is edited.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Default, Debug, PartialEq)]
pub struct AtmosphereScenario {
    /// Built-in scenario name (`convection`, `island`, `sea-breeze`, `orographic`, `mixed`,
    /// `eruption`).
    pub scenario: String,
    /// Cells per side (a power of two); the scenario's own grid if `None`.
    pub grid: Option<usize>,
    /// Model steps of the scenario's Δt run before the atmosphere appears (0–10,000), so it
    /// starts with developed weather.
    pub prespin: u32,
    /// Whether to build over the game's terrain under the world origin (waiting for one)
    /// rather than over the scenario's own terrain.
    pub over_terrain: bool,
}

impl Default for AtmosphereScenario {
    /// The five-layer `eruption` scenario on its own grid, not pre-spun, over the game's terrain.
    fn default() -> Self {
        Self { scenario: "eruption".into(), grid: None, prespin: 0, over_terrain: true }
    }
}

impl AtmosphereScenario {
    /// The named scenario with the other fields at their defaults.
    pub fn new(scenario: impl Into<String>) -> Self {
        Self { scenario: scenario.into(), ..Self::default() }
    }

    /// Checks the name and the numbers; returns the scenario.
    pub fn validate(&self) -> Result<WeatherScenario, ConfigError> {
        let scenario = WeatherScenario::builtin(&self.scenario)?;
        if let Some(n) = self.grid {
            GridSpec::new(n, scenario.extent_m / n.max(1) as f64)?;
        }
        in_range("prespin", self.prespin as f64, 0.0, 10_000.0)?;
        Ok(scenario)
    }
}

/// What became of an [`AtmosphereScenario`] (written by the plugin).
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
pub enum AtmosphereScenarioStatus {
    /// Waiting for a terrain under the world origin to build over.
    WaitingForTerrain,
    /// Built: the entity is an [`Atmosphere`] with its layers.
    Built,
    /// Not built; why. Tried again when the component is edited.
    Rejected(String),
}

/// An [`AtmosphereScenario`] entity and what became of it so far.
type ScenarioRequest<'a> = (Entity, Ref<'a, AtmosphereScenario>, Option<&'a AtmosphereScenarioStatus>);

/// Builds each [`AtmosphereScenario`] that is not an atmosphere yet (in `FixedUpdate`, after
/// the terrains were placed at the start of the tick).
pub(crate) fn build_scenario_atmospheres(
    mut commands: Commands,
    requests: Query<ScenarioRequest, Without<Atmosphere>>,
    terrains: Query<&Terrain>,
) {
    for (entity, request, status) in &requests {
        if matches!(status, Some(AtmosphereScenarioStatus::Rejected(_))) && !request.is_changed() {
            continue;
        }
        let reject = |commands: &mut Commands, e: ConfigError| {
            error!("atmosphere {entity}: scenario `{}` not built: {e}", request.scenario);
            commands.entity(entity).insert(AtmosphereScenarioStatus::Rejected(e.to_string()));
        };
        // The values are checked at once, before waiting for a terrain.
        let scenario = match request.validate() {
            Ok(scenario) => scenario,
            Err(e) => {
                reject(&mut commands, e);
                continue;
            }
        };
        let terrain = terrains.iter().find(|t| t.contains(0.0, 0.0));
        if request.over_terrain && terrain.is_none() {
            if status != Some(&AtmosphereScenarioStatus::WaitingForTerrain) {
                commands.entity(entity).insert(AtmosphereScenarioStatus::WaitingForTerrain);
            }
            continue;
        }
        let terrain = terrain.filter(|_| request.over_terrain);
        let built =
            prespun_state(&scenario, request.grid, terrain, request.prespin).and_then(|(state, events)| {
                scenario.params.validate()?;
                let work = Workspace::new(&state)?;
                Ok((state, events, work))
            });
        match built {
            Ok((state, events, work)) => {
                insert_atmosphere(&mut commands, entity, state, scenario.params, work);
                commands.entity(entity).insert((AtmosphereTimeline(events), AtmosphereScenarioStatus::Built));
            }
            Err(e) => reject(&mut commands, e),
        }
    }
}
