//! Weather steps off the main thread, pipelined deterministically (docs/ARCHITECTURE.md §3.3).
//!
//! At a weather tick k the domain schedule ([`WeatherStep`]) copies the ground, shares the
//! layers' fields ([`SharedFields`], copy-on-write) and starts the
//! model step: on Bevy's `AsyncComputeTaskPool` when the pool exists and
//! [`WeatherPipelineSettings::off_thread`] is set, otherwise at once on the main thread. The
//! step first copies the shared layers into its own buffers (so that copy, most of a snapshot's
//! bytes, is off the main thread too), applies the timeline events due, then steps. The result
//! is written back at the next weather tick (k + k_cadence for `EveryNthTick(k_cadence)`), in
//! [`WeatherSystems::Apply`](crate::WeatherSystems::Apply) before the coupling's transfers;
//! that join only blocks if the worker has not finished. The components therefore always hold
//! a complete state one weather step behind the weather clock, and the state at every tick is
//! the same whichever thread ran the step and whatever the frame rate.

use std::sync::Arc;
use std::time::Instant;

use bevy::prelude::*;
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on};
use volcano_core::parallel;
use volcano_core::prelude::*;

use super::components::{
    AirLayer, Atmosphere, AtmosphereGround, AtmosphereTimeline, WeatherStep, WeatherStepped,
};
use super::shared::SharedFields;
use super::snapshot::{merge_ground, snapshot_ground, snapshot_layers};
use crate::model::fields::{AtmosphereState, Ground, LayerFields};
use crate::model::params::AtmosphereParams;
use crate::model::run::apply_event;
use crate::model::scenario::Event;
use crate::model::step::{WeatherStepReport, Workspace, step};

/// The pool the weather step's bands run on: the async compute pool, whose tasks never wait for
/// a system (with the compute pool, `tests/pool.rs` hangs).
const POOL: parallel::Pool = parallel::Pool::AsyncCompute;

/// Where weather steps run (a resource of [`crate::AtmospherePlugin`]).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Default)]
pub struct WeatherPipelineSettings {
    /// Run each step on Bevy's `AsyncComputeTaskPool` (when the app has one, e.g. through
    /// `TaskPoolPlugin`). When false, or without the pool, the step runs on the main thread
    /// as it starts and its result still waits for the next weather tick: the state is
    /// bit-identical either way, only the thread differs.
    pub off_thread: bool,
    /// Wall-clock time an off-thread step waits before it starts working (default 20 ms).
    /// Started at once, its first burst (a newly woken thread copying the layers, 5 MB at
    /// 128² × 5, at full memory bandwidth) lands on the main thread's busiest tick: in the
    /// eruption scene on two cores the weather tick takes 2.3× the others without the delay
    /// and 1.15× with it (`volcano bench`, release), the other ticks alike. The result is
    /// applied at the same base tick whatever the delay (the state never depends on it), and a
    /// join ends the delay at once (several
    /// steps in one base tick, `join_weather`, `flush_weather`); keep it well under the weather
    /// cadence's wall time (a second of game time at 50 Hz), or the write-back waits.
    pub start_delay: std::time::Duration,
}

impl Default for WeatherPipelineSettings {
    fn default() -> Self {
        Self { off_thread: true, start_delay: std::time::Duration::from_millis(20) }
    }
}

/// What the weather pipeline of one atmosphere did (diagnostics; the `*_ms` and `waited`
/// fields are wall-clock measurements, never part of the simulated state).
#[derive(Component, Debug, Clone, Default, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct WeatherPipelineStatus {
    /// Base tick (`SimTick`) at which the step now in flight started; `None` when idle.
    pub in_flight_since: Option<u64>,
    /// Steps started.
    pub started: u64,
    /// Steps whose result was written back.
    pub applied: u64,
    /// Of the started steps, those run on the `AsyncComputeTaskPool`.
    pub off_thread: u64,
    /// Write-backs that had to wait for the worker to finish.
    pub waited: u64,
    /// Main-thread time of the last start (snapshot copy and spawn; the whole step when it
    /// ran on the main thread), ms.
    pub last_start_ms: f64,
    /// Main-thread time of the last write-back (join included), ms.
    pub last_apply_ms: f64,
}

/// What a step starts from: the shared layers, buffers to copy them into, the rest of the state
/// (ground copied, no layers), the timeline events due and the scratch buffers, if any yet.
struct StepInput {
    shared: Vec<Arc<LayerFields>>,
    spare_layers: Option<Vec<LayerFields>>,
    shell: AtmosphereState,
    events: Vec<Event>,
    work: Option<Workspace>,
}

/// A finished step: its state, the scratch buffers it used and what it reported.
struct Stepped {
    state: AtmosphereState,
    work: Option<Workspace>,
    result: Result<WeatherStepReport, ConfigError>,
}

enum Job {
    Running(Task<Stepped>),
    Done(Box<Stepped>),
}

struct InFlight {
    started_tick: u64,
    /// The layer entities the step was started from, by index: its result goes back only into
    /// these (a layer despawned and replaced meanwhile, even by one of the same shape, does not
    /// receive the stale result).
    layers: Vec<Entity>,
    job: Job,
    /// Dropped to end the task's start delay at once (a join never waits for the delay).
    wake: Option<std::sync::mpsc::Sender<()>>,
}

impl InFlight {
    /// Waits for the step if needed; also says whether it had to wait.
    fn join(self) -> (Stepped, bool, u64, Vec<Entity>) {
        let InFlight { started_tick, layers, job, wake } = self;
        drop(wake);
        match job {
            Job::Done(s) => (*s, false, started_tick, layers),
            Job::Running(task) => {
                let waited = !task.is_finished();
                (block_on(task), waited, started_tick, layers)
            }
        }
    }
}

/// An atmosphere's weather pipeline: the step in flight and the buffers reused between steps
/// (not reflected: it holds a task; see [`WeatherPipelineStatus`]). A required component of
/// `Atmosphere` (registered by the plugin): an atmosphere loaded from a saved world gets an
/// empty one, whose buffers are built at its first step.
#[derive(Component, Default)]
pub struct AtmosphereWork {
    work: Option<Workspace>,
    spare: Option<AtmosphereState>,
    in_flight: Option<InFlight>,
}

impl std::fmt::Debug for AtmosphereWork {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("AtmosphereWork")
            .field("in_flight_since", &self.in_flight.as_ref().map(|i| i.started_tick))
            .finish_non_exhaustive()
    }
}

impl AtmosphereWork {
    pub(crate) fn new(work: Workspace) -> Self {
        Self { work: Some(work), spare: None, in_flight: None }
    }
    /// Whether a step has started and not been written back.
    pub fn in_flight(&self) -> bool {
        self.in_flight.is_some()
    }
    /// Waits until the step in flight (if any) has finished, without writing it back.
    fn finish(&mut self) {
        if let Some(InFlight { started_tick, layers, job, wake }) = self.in_flight.take() {
            drop(wake);
            let job = match job {
                Job::Running(task) => Job::Done(Box::new(block_on(task))),
                done => done,
            };
            self.in_flight = Some(InFlight { started_tick, layers, job, wake: None });
        }
    }
}

/// One model step of the pipeline: copies the shared layers (and lets go of them), applies the
/// events due, steps. Its bands run on the async compute pool, on or off the main thread alike:
/// a system joins this step one weather step later, and a compute-pool thread helping with the
/// step's bands could pick up that very system and wait for itself (`volcano_core::parallel`'s
/// module docs).
fn run_step(input: StepInput, params: &AtmosphereParams, dt: f64) -> Stepped {
    let StepInput { shared, spare_layers, shell, events, work } = input;
    let refs: Vec<&LayerFields> = shared.iter().map(|l| &**l).collect();
    let layers = snapshot_layers(spare_layers, &refs);
    drop(refs);
    // From here on a write into the components no longer copies them.
    drop(shared);
    let mut state = AtmosphereState { layers, ..shell };
    for event in &events {
        apply_event(&mut state, event);
    }
    let (work, result) = match work.map_or_else(|| Workspace::new(&state), Ok) {
        Ok(mut work) => {
            let result = parallel::on_pool(POOL, || step(&mut state, params, &mut work, dt));
            (Some(work), result)
        }
        Err(e) => (None, Err(e)),
    };
    Stepped { state, work, result }
}

/// The layers of `atmosphere`, sorted by index (read through `Mut` without marking them
/// changed until written), and their entities in the same order.
fn layers_of<'a>(
    atmosphere: Entity,
    layers: &'a mut Query<(Entity, &mut AirLayer)>,
) -> (Vec<Entity>, Vec<Mut<'a, AirLayer>>) {
    let mut mine: Vec<(Entity, Mut<AirLayer>)> =
        layers.iter_mut().filter(|(_, l)| l.atmosphere == atmosphere).collect();
    mine.sort_by_key(|(_, l)| l.index);
    mine.into_iter().unzip()
}

/// One atmosphere's components, as the write-back needs them.
struct Target<'a, 'w> {
    entity: Entity,
    atmo: &'a mut Atmosphere,
    ground: &'a mut Ground,
    layers: &'a mut [Mut<'w, AirLayer>],
    /// The entities of `layers`, in the same order.
    layer_entities: &'a [Entity],
    status: &'a mut WeatherPipelineStatus,
}

/// What [`write_back`] did: the messages to send and whether it had to wait.
struct Applied {
    stepped: Option<WeatherStepped>,
    /// The guard repaired cells in the step ([`WeatherStepReport::repaired`]).
    fault: Option<SimFault>,
    waited: bool,
}

/// Waits for the step `flight` (if still running) and writes it into the components. A result
/// that no longer fits (layers added, removed, replaced or regridded since the step started)
/// is dropped.
fn write_back(t: Target, work: &mut AtmosphereWork, flight: InFlight, now: u64) -> Applied {
    let (done, waited, started_tick, started_layers) = flight.join();
    let Stepped { mut state, work: scratch, result } = done;
    work.work = scratch;
    t.status.in_flight_since = None;
    let fits = t.layer_entities == started_layers.as_slice()
        && t.layers.len() == state.layers.len()
        && t.layers
            .iter()
            .zip(&state.layers)
            .all(|(l, s)| l.fields.t.nx() == s.t.nx() && l.fields.t.ny() == s.t.ny())
        && t.ground.ash.data().len() == state.ground.ash.data().len();
    if !fits {
        warn_once!("atmosphere {}: its layers changed during a weather step; the step is dropped", t.entity);
        return Applied { stepped: None, fault: None, waited };
    }
    // The result goes in without a copy; the old fields (no longer shared: the worker let
    // go of them before stepping) become the next step's buffers.
    let mut spare = Vec::with_capacity(state.layers.len());
    for (layer, fields) in t.layers.iter_mut().zip(state.layers.drain(..)) {
        spare.push(std::mem::replace(&mut layer.fields, SharedFields::new(fields)).into_inner());
    }
    state.layers = spare;
    merge_ground(t.ground, &mut state.ground);
    t.status.applied += 1;
    let (stepped, fault) = match result {
        Ok(report) => {
            t.atmo.time_s = state.time_s;
            t.atmo.precipitated = state.precipitated;
            let r = report.repaired;
            let fault = r.any().then(|| SimFault {
                lost_ash_kg: r.lost_ash_g * 1e-3,
                lost_water_kg: r.lost_water_g * 1e-3,
                ..SimFault::new(t.entity, SimDomain::Atmosphere, r.cells)
            });
            (Some(WeatherStepped { atmosphere: t.entity, report, started_tick, applied_tick: now }), fault)
        }
        Err(e) => {
            warn_once!("atmosphere {} not stepped: {e}", t.entity);
            (None, None)
        }
    };
    work.spare = Some(state);
    Applied { stepped, fault, waited }
}

/// Sends what a write-back produced (the fault logged as a warning).
fn send(applied: Applied, stepped: &mut MessageWriter<WeatherStepped>, faults: &mut MessageWriter<SimFault>) {
    if let Some(fault) = applied.fault {
        fault.warn();
        faults.write(fault);
    }
    if let Some(m) = applied.stepped {
        stepped.write(m);
    }
}

type AtmosphereItems<'a> = (
    Entity,
    &'a mut Atmosphere,
    &'a mut AtmosphereGround,
    &'a mut AtmosphereWork,
    &'a mut WeatherPipelineStatus,
);

/// Run condition of [`apply_weather`]: this base tick runs and the weather steps in it, or
/// the weather domain is paused (a paused weather shows its latest step, and edits made while
/// it is paused, such as paint strokes, are not overwritten by a step started before).
pub(crate) fn weather_due(
    control: Option<Res<SimControl>>,
    clock: Option<Res<Time<DomainClock<WeatherStep>>>>,
    fixed: Option<Res<Time<Fixed>>>,
) -> bool {
    let (Some(clock), Some(fixed)) = (clock, fixed) else { return false };
    let ctx = clock.context();
    let base = fixed.timestep();
    ctx.is_paused() || (control.is_none_or(|c| c.running_this_tick()) && ctx.steps_at_next_tick(base) > 0)
}

/// [`WeatherSystems::Apply`](super::components::WeatherSystems::Apply): writes back the steps
/// started one weather step ago (waiting for them if they are still running).
pub(crate) fn apply_weather(
    tick: Option<Res<SimTick>>,
    mut atmospheres: Query<AtmosphereItems>,
    mut layers: Query<(Entity, &mut AirLayer)>,
    mut stepped: MessageWriter<WeatherStepped>,
    mut faults: MessageWriter<SimFault>,
) {
    let now = tick.map_or(0, |t| t.0);
    for (entity, mut atmo, mut ground, mut work, mut status) in &mut atmospheres {
        let Some(flight) = work.in_flight.take() else { continue };
        let clock = Instant::now();
        let (ids, mut mine) = layers_of(entity, &mut layers);
        let target = Target {
            entity,
            atmo: &mut atmo,
            ground: &mut ground.0,
            layers: &mut mine,
            layer_entities: &ids,
            status: &mut status,
        };
        let applied = write_back(target, &mut work, flight, now);
        status.waited += u64::from(applied.waited);
        send(applied, &mut stepped, &mut faults);
        status.last_apply_ms = clock.elapsed().as_secs_f64() * 1e3;
    }
}

/// The [`WeatherStep`] system: writes back a step still in flight (several steps per base
/// tick), fires due timeline events on a snapshot of the components and starts the step.
pub(crate) fn start_weather(
    time: Res<Time>,
    tick: Option<Res<SimTick>>,
    settings: Res<WeatherPipelineSettings>,
    mut atmospheres: Query<(AtmosphereItems, Option<&mut AtmosphereTimeline>)>,
    mut layers: Query<(Entity, &mut AirLayer)>,
    mut stepped: MessageWriter<WeatherStepped>,
    mut faults: MessageWriter<SimFault>,
) {
    let dt = time.delta_secs_f64();
    if dt <= 0.0 {
        return;
    }
    let now = tick.map_or(0, |t| t.0);
    let pool = if settings.off_thread { AsyncComputeTaskPool::try_get() } else { None };
    for ((entity, mut atmo, mut ground, mut work, mut status), timeline) in &mut atmospheres {
        let clock = Instant::now();
        let (ids, mut mine) = layers_of(entity, &mut layers);
        if let Some(flight) = work.in_flight.take() {
            let target = Target {
                entity,
                atmo: &mut atmo,
                ground: &mut ground.0,
                layers: &mut mine,
                layer_entities: &ids,
                status: &mut status,
            };
            send(write_back(target, &mut work, flight, now), &mut stepped, &mut faults);
        }
        let template = match atmo.state_shell() {
            Ok(t) => t,
            Err(e) => {
                warn_once!("atmosphere {entity}: {e}; the weather waits until the value is fixed");
                continue;
            }
        };
        if mine.len() < 2 || mine.iter().any(|l| l.fields.t.nx() != template.grid.n) {
            continue;
        }
        let shared: Vec<Arc<LayerFields>> = mine.iter().map(|l| l.fields.share()).collect();
        let (spare_layers, spare_ground) = match work.spare.take() {
            Some(s) => (Some(s.layers), Some(s.ground)),
            None => (None, None),
        };
        let shell = AtmosphereState { ground: snapshot_ground(spare_ground, &ground.0), ..template };
        let mut events: Vec<Event> = match timeline {
            Some(mut timeline) => {
                let due = timeline.0.iter().take_while(|e| e.at_s <= shell.time_s).count();
                if due > 0 { timeline.0.drain(..due).collect() } else { Vec::new() }
            }
            None => Vec::new(),
        };
        // Events a game pushed into the timeline are checked as they fire, like a scenario's
        // when it loads.
        events.retain(|e| {
            e.validate(mine.len())
                .inspect_err(|err| warn!("atmosphere {entity}: timeline event dropped: {err}"))
                .is_ok()
        });
        let input = StepInput { shared, spare_layers, shell, events, work: work.work.take() };
        let params = atmo.params.clone();
        let (wake, woken) = std::sync::mpsc::channel::<()>();
        let job = match pool {
            Some(pool) => {
                status.off_thread += 1;
                let delay = settings.start_delay;
                Job::Running(pool.spawn(async move {
                    // A blocking wait: the task is about to occupy this thread for the whole
                    // step anyway (`WeatherPipelineSettings::start_delay`). It ends early when
                    // the step is joined (several steps in one base tick, a flush, the exit).
                    if !delay.is_zero() {
                        let _ = woken.recv_timeout(delay);
                    }
                    run_step(input, &params, dt)
                }))
            }
            None => Job::Done(Box::new(run_step(input, &params, dt))),
        };
        work.in_flight = Some(InFlight { started_tick: now, layers: ids, job, wake: Some(wake) });
        status.in_flight_since = Some(now);
        status.started += 1;
        status.last_start_ms = clock.elapsed().as_secs_f64() * 1e3;
    }
}

/// In `Last`: when the app is exiting, waits for the steps in flight, so no worker is left
/// computing while the world is torn down.
pub(crate) fn join_on_exit(mut exit: MessageReader<AppExit>, mut works: Query<&mut AtmosphereWork>) {
    if exit.read().next().is_some() {
        for mut w in &mut works {
            w.finish();
        }
    }
}

/// Waits until every weather step in flight has finished, without writing it back (it is
/// still applied at its regular tick, so the run is unchanged). Returns how many were in
/// flight.
pub fn join_weather(world: &mut World) -> usize {
    let mut q = world.query::<&mut AtmosphereWork>();
    let mut n = 0;
    for mut w in q.iter_mut(world) {
        if w.in_flight() {
            w.finish();
            n += 1;
        }
    }
    n
}

/// Writes back every weather step in flight now (sending [`WeatherStepped`]), e.g. before a
/// scene is saved, so the components hold everything simulated so far. The next weather tick
/// then has nothing to write back and only starts a step: a flush moves the results of that one
/// step earlier, so a run with a flush differs from one without. Returns how many were applied.
pub fn flush_weather(world: &mut World) -> usize {
    let pending = world.query::<&AtmosphereWork>().iter(world).filter(|w| w.in_flight()).count();
    if pending > 0
        && let Err(e) = world.run_system_cached(apply_weather)
    {
        warn!("weather flush failed: {e}");
        return 0;
    }
    pending
}
