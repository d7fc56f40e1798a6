//! [`AtmospherePlugin`]: the weather domain (`WeatherStep`, `Period(1 s)` = one 1 s step per
//! simulated second at any fixed rate by default, docs/ARCHITECTURE.md §3.4). An [`Atmosphere`] entity carries the grid,
//! coefficients, clock and ground; each [`AirLayer`] entity holds one layer's fields in one
//! component. Systems gather, call [`crate::model::step::step`], write back.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::model::fields::{AtmosphereState, GridSpec, Ground, LayerFields};
use crate::model::params::AtmosphereParams;
use crate::model::run::apply_event;
use crate::model::scenario::{Event, Scenario};
use crate::model::step::{StepReport, Workspace, step};

/// Schedule of the weather domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct WeatherStep;

/// The layered atmosphere: systems in [`WeatherStep`] and the messages they send.
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
            .register_type::<Atmosphere>()
            .register_type::<AirLayer>()
            .register_type::<AtmosphereGround>()
            .register_type::<AtmosphereTimeline>()
            .add_systems(WeatherStep, step_weather);
    }
}

/// The atmosphere over one terrain: grid, coefficients, clock and budgets.
#[derive(Component, Debug, Clone, Reflect)]
pub struct Atmosphere {
    /// Cells per side.
    pub n: usize,
    /// Cell size (m).
    pub dx: f64,
    /// Model coefficients (live-editable; invalid edits freeze the weather until fixed).
    pub params: AtmosphereParams,
    /// Simulated weather time since the start (s).
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

/// One air layer's fields (thesis Table 4.2), on its own entity.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(opaque)]
pub struct AirLayer {
    /// The [`Atmosphere`] entity it belongs to.
    pub atmosphere: Entity,
    /// Position in the stack (0 = lowest).
    pub index: usize,
    /// The fields.
    pub fields: LayerFields,
}

/// The ground under an atmosphere (terrain heights, cover, temperature, water).
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(opaque)]
pub struct AtmosphereGround(pub Ground);

/// Timeline events still to fire (sorted by time), from a scenario.
#[derive(Component, Debug, Clone, Default, Reflect)]
#[reflect(opaque)]
pub struct AtmosphereTimeline(pub Vec<Event>);

/// Scratch buffers, reused between steps.
#[derive(Component, Debug, Clone)]
pub struct AtmosphereWork(Workspace);

/// Sent after every weather step of an atmosphere.
#[derive(Message, Debug, Clone)]
pub struct WeatherStepped {
    /// The atmosphere entity.
    pub atmosphere: Entity,
    /// What the step did.
    pub report: StepReport,
}

/// Spawns an atmosphere from a model state (e.g. `Scenario::build`): one [`Atmosphere`]
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
            AtmosphereWork(work),
        ))
        .id();
    for (index, fields) in layers.into_iter().enumerate() {
        commands.spawn((
            Name::new(format!("Air layer {index} ({} m)", fields.altitude)),
            AirLayer { atmosphere, index, fields },
            ChildOf(atmosphere),
        ));
    }
    Ok(atmosphere)
}

/// Spawns a scenario (its state on an `n × n` grid, or its own, its coefficients and its
/// timeline) as in [`spawn_atmosphere`]. Returns the atmosphere entity.
pub fn spawn_scenario(
    commands: &mut Commands,
    scenario: &Scenario,
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
/// at the cell centres, `Scenario::build_with_terrain`), after running `prespin_steps` model
/// steps of the scenario's Δt (timeline events included) so a scene starts with developed
/// weather. Returns the atmosphere entity.
pub fn spawn_scenario_with(
    commands: &mut Commands,
    scenario: &Scenario,
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

/// Gathers each atmosphere's layers, fires due timeline events, steps the model, writes the
/// fields back.
fn step_weather(
    time: Res<Time>,
    mut atmospheres: Query<(
        Entity,
        &mut Atmosphere,
        &mut AtmosphereGround,
        &mut AtmosphereWork,
        Option<&mut AtmosphereTimeline>,
    )>,
    mut layers: Query<&mut AirLayer>,
    mut stepped: MessageWriter<WeatherStepped>,
) {
    let dt = time.delta_secs_f64();
    if dt <= 0.0 {
        return;
    }
    for (entity, mut atmo, mut ground, mut work, timeline) in &mut atmospheres {
        let Ok(grid) = GridSpec::new(atmo.n, atmo.dx) else {
            continue;
        };
        let mut mine: Vec<Mut<AirLayer>> = layers.iter_mut().filter(|l| l.atmosphere == entity).collect();
        mine.sort_by_key(|l| l.index);
        if mine.len() < 2 || mine.iter().any(|l| l.fields.t.nx() != grid.n) {
            continue;
        }
        let mut state = AtmosphereState {
            grid,
            layers: mine.iter_mut().map(|l| std::mem::take(&mut l.fields)).collect(),
            ground: std::mem::take(&mut ground.0),
            time_s: atmo.time_s,
            start_hour: atmo.start_hour,
            day_of_year: atmo.day_of_year,
            latitude_deg: atmo.latitude_deg,
            precipitated: atmo.precipitated,
        };
        if let Some(mut timeline) = timeline {
            let due = timeline.0.iter().take_while(|e| e.at_s <= state.time_s).count();
            for event in timeline.0.drain(..due) {
                apply_event(&mut state, &event);
            }
        }
        let result = step(&mut state, &atmo.params, &mut work.0, dt);
        // docs/ARCHITECTURE.md §7.1: debug builds check that the state stays finite and
        // non-negative.
        debug_assert!(state.is_valid(), "atmosphere {entity} produced a non-finite or negative field");
        for (layer, fields) in mine.iter_mut().zip(state.layers) {
            layer.fields = fields;
        }
        ground.0 = state.ground;
        match result {
            Ok(report) => {
                atmo.time_s = state.time_s;
                atmo.precipitated = state.precipitated;
                stepped.write(WeatherStepped { atmosphere: entity, report });
            }
            Err(e) => warn_once!("atmosphere {entity} not stepped: {e}"),
        }
    }
}
