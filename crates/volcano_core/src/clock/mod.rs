//! The multi-rate simulation clock (docs/ARCHITECTURE.md §3).
//!
//! The *base tick* is the game's `Time<Fixed>`, at whatever rate the game set (Bevy's default
//! is 64 Hz; the volcano never changes it). Each simulation domain (plume, weather, lava, …)
//! has its own [`ScheduleLabel`](bevy::ecs::schedule::ScheduleLabel), its own clock
//! `Time<DomainClock<D>>` and a [`Cadence`]: `Substeps(n)` runs the domain schedule `n` times
//! per base tick with `Δt = base/n`; `EveryNthTick(k)` runs it once every `k` ticks with
//! `Δt = k·base`; `Period(p)` runs it once per `p` of simulated time (rounded to whole ticks).
//! A driver system per domain, placed in a chained [`SimSystems`] set in `FixedUpdate`, swaps
//! the generic `Time` for the domain clock while the domain runs and restores it afterwards, so
//! systems inside a domain read their own `Res<Time>`. Because everything happens per base
//! tick, results do not depend on the frame rate.
//!
//! Control: [`SimControl`] pauses all domains, single-steps base ticks and sets the simulation
//! speed (every domain step covers `speed ×` its length; the game's clocks are untouched); each
//! [`DomainClock`] can be paused, single-stepped, and given its own time scale (each step
//! advances `scale × Δt` of domain time, e.g. 30 s of weather per step for a standalone
//! skyscape).

pub(crate) mod driver;

use std::marker::PhantomData;
use std::time::Duration;

use bevy::ecs::reflect::ReflectResource;
use bevy::ecs::resource::Resource;
use bevy::ecs::schedule::SystemSet;
use bevy::reflect::{Reflect, std_traits::ReflectDefault};
use serde::{Deserialize, Serialize};

use crate::error::ConfigError;

pub use driver::SimDomainAppExt;

/// How often a domain steps relative to the base tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Reflect, Serialize, Deserialize)]
pub enum Cadence {
    /// `n ≥ 1` steps per base tick, each `base/n` long.
    Substeps(u32),
    /// One step every `k ≥ 1` base ticks, `k·base` long.
    EveryNthTick(u32),
    /// One step per `period > 0` of simulated time at any base rate: every
    /// `k = max(1, round(period / base))` base ticks, `k·base` long (exactly `period` whenever
    /// the base tick divides it, e.g. 1 s at 50 or 64 Hz).
    Period(Duration),
}

impl Cadence {
    /// Most substeps per base tick: each runs the domain's whole schedule, so a count beyond
    /// this would stall the game's fixed update.
    pub const MAX_SUBSTEPS: u32 = 1_000;

    /// Errors on a zero count or period, and on more than [`Cadence::MAX_SUBSTEPS`] substeps.
    pub fn validate(self) -> Result<Self, ConfigError> {
        let (name, v) = match self {
            Cadence::Substeps(n) => ("Substeps", n),
            Cadence::EveryNthTick(k) => ("EveryNthTick", k),
            Cadence::Period(p) if p.is_zero() => ("Period", 0),
            Cadence::Period(_) => ("Period", 1),
        };
        if v == 0 {
            return Err(ConfigError::InvalidParameter {
                name,
                value: 0.0,
                reason: "cadence counts and periods must be at least 1 (ns)".into(),
            });
        }
        if let Cadence::Substeps(n) = self
            && n > Self::MAX_SUBSTEPS
        {
            return Err(ConfigError::InvalidParameter {
                name,
                value: f64::from(n),
                reason: format!("at most {} substeps per base tick", Self::MAX_SUBSTEPS),
            });
        }
        Ok(self)
    }

    /// The nearest valid cadence (a count or period of zero becomes 1 (ns), a substep count
    /// above the limit the limit).
    fn nearest_valid(self) -> Self {
        match self {
            Cadence::Substeps(n) => Cadence::Substeps(n.clamp(1, Self::MAX_SUBSTEPS)),
            Cadence::EveryNthTick(k) => Cadence::EveryNthTick(k.max(1)),
            Cadence::Period(p) => Cadence::Period(p.max(Duration::from_nanos(1))),
        }
    }

    /// Base ticks per domain step for a base tick of `base` (1 for `Substeps`).
    pub fn ticks_per_step(self, base: Duration) -> u64 {
        match self {
            Cadence::Substeps(_) => 1,
            Cadence::EveryNthTick(k) => u64::from(k.max(1)),
            Cadence::Period(p) => {
                let b = base.as_nanos().max(1);
                ((p.as_nanos() + b / 2) / b).clamp(1, u64::MAX as u128) as u64
            }
        }
    }

    /// Length of one domain step (before time scales) for a base tick of `base`.
    /// Exact whenever the base tick in nanoseconds is divisible by `n`.
    pub fn step_duration(self, base: Duration) -> Duration {
        let nanos = base.as_nanos();
        let step = match self {
            Cadence::Substeps(n) => nanos / n.max(1) as u128,
            _ => nanos * self.ticks_per_step(base) as u128,
        };
        Duration::from_nanos(step.min(u64::MAX as u128) as u64)
    }

    /// How many domain steps run at base tick number `tick` (1-based count of ticks run) for
    /// a base tick of `base`.
    pub fn steps_at_tick(self, tick: u64, base: Duration) -> u32 {
        match self {
            Cadence::Substeps(n) => n,
            _ => u32::from(tick.is_multiple_of(self.ticks_per_step(base))),
        }
    }
}

/// Context of `Time<DomainClock<D>>`: the clock of simulation domain `D` (its schedule label).
/// Reflected, and `Time<DomainClock<D>>` registered as a resource by
/// [`SimDomainAppExt::add_sim_domain`], so a saved world keeps each domain's phase.
#[derive(Debug, Reflect)]
#[reflect(Clone, Default)]
pub struct DomainClock<D> {
    cadence: Cadence,
    time_scale: f64,
    paused: bool,
    pending_steps: u32,
    ticks_seen: u64,
    steps_run: u64,
    #[reflect(ignore)]
    _domain: PhantomData<fn() -> D>,
}

impl<D> Default for DomainClock<D> {
    fn default() -> Self {
        Self {
            cadence: Cadence::Substeps(1),
            time_scale: 1.0,
            paused: false,
            pending_steps: 0,
            ticks_seen: 0,
            steps_run: 0,
            _domain: PhantomData,
        }
    }
}

impl<D> Clone for DomainClock<D> {
    fn clone(&self) -> Self {
        Self { _domain: PhantomData, ..*self }
    }
}

impl<D> DomainClock<D> {
    /// A clock with the given cadence (validated).
    pub fn new(cadence: Cadence) -> Result<Self, ConfigError> {
        Ok(Self { cadence: cadence.validate()?, ..Default::default() })
    }
    /// Current cadence.
    pub fn cadence(&self) -> Cadence {
        self.cadence
    }
    /// Changes the cadence (takes effect at the next base tick).
    pub fn set_cadence(&mut self, cadence: Cadence) -> Result<(), ConfigError> {
        self.cadence = cadence.validate()?;
        Ok(())
    }
    /// Domain seconds per simulated second.
    pub fn time_scale(&self) -> f64 {
        self.time_scale
    }
    /// Accepted time scales (pause instead of using 0).
    pub const TIME_SCALE_RANGE: (f64, f64) = (1e-6, 1e6);
    /// Sets the time scale, in [`DomainClock::TIME_SCALE_RANGE`].
    pub fn set_time_scale(&mut self, scale: f64) -> Result<(), ConfigError> {
        let (lo, hi) = Self::TIME_SCALE_RANGE;
        self.time_scale = crate::error::in_range("time_scale", scale, lo, hi)?;
        Ok(())
    }
    /// Whether this domain is paused.
    pub fn is_paused(&self) -> bool {
        self.paused
    }
    /// Pauses or resumes this domain alone.
    pub fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
    }
    /// While paused, runs `n` more single domain steps at the next base ticks (one per tick).
    pub fn request_steps(&mut self, n: u32) {
        self.pending_steps = self.pending_steps.saturating_add(n);
    }
    /// Base ticks this domain has seen (paused or not).
    pub fn ticks_seen(&self) -> u64 {
        self.ticks_seen
    }
    /// Domain steps run so far.
    pub fn steps_run(&self) -> u64 {
        self.steps_run
    }
    /// How many steps the driver will run at the next simulated base tick of length `base`
    /// (`Time<Fixed>::timestep()`; 0 while paused with no single step requested). Coupling
    /// systems that run just before a domain use it to act only on the ticks where the domain
    /// steps.
    pub fn steps_at_next_tick(&self, base: Duration) -> u32 {
        if self.paused {
            u32::from(self.pending_steps > 0)
        } else {
            self.cadence.steps_at_tick(self.ticks_seen + 1, base)
        }
    }
    /// Puts a cadence or time scale written past the setters (through reflection) back in
    /// range: an invalid cadence to the nearest valid one, a time scale to the nearest bound
    /// (1 if NaN). Returns what was corrected, for the driver to report.
    pub(crate) fn correct(&mut self) -> Option<String> {
        let mut fixed = Vec::new();
        if self.cadence.validate().is_err() {
            let valid = self.cadence.nearest_valid();
            fixed.push(format!("cadence {:?} -> {valid:?}", self.cadence));
            self.cadence = valid;
        }
        if let Some(scale) = nearest_in(self.time_scale, Self::TIME_SCALE_RANGE) {
            fixed.push(format!("time_scale {} -> {scale}", self.time_scale));
            self.time_scale = scale;
        }
        (!fixed.is_empty()).then(|| fixed.join(", "))
    }
    /// Length of one step of this domain, time scale included.
    pub fn step_duration(&self, base: Duration) -> Duration {
        let d = self.cadence.step_duration(base);
        if self.time_scale == 1.0 { d } else { d.mul_f64(self.time_scale) }
    }
}

/// Whether a step that ended at `elapsed` after lasting `delta` crossed a whole multiple of
/// `period` (for "once per simulated second" work inside a domain: pass the domain's
/// `Res<Time>` elapsed and delta). Over any run it is true once per `period` of domain time,
/// whatever the step length; false for a zero period.
pub fn crossed_period(elapsed: Duration, delta: Duration, period: Duration) -> bool {
    let p = period.as_nanos();
    if p == 0 {
        return false;
    }
    elapsed.as_nanos() / p != elapsed.saturating_sub(delta).as_nanos() / p
}

/// How many of the instants `offset + n·period` (n = 0, 1, …) a step that ended at `elapsed`
/// after lasting `delta` crossed (those in `(elapsed − delta, elapsed]`): for periodic work
/// inside a domain that should not fall on the ticks of other periodic work (the deposit's
/// relaxation runs a pass at 1/8, 3/8, 5/8 and 7/8 of each second, never on the tick of the
/// once-per-second weather step). Over any run it counts one per `period` of domain time,
/// whatever the step length; 0 for a zero period.
pub fn crossings(elapsed: Duration, delta: Duration, period: Duration, offset: Duration) -> u64 {
    let (p, o) = (period.as_nanos(), offset.as_nanos());
    if p == 0 {
        return 0;
    }
    // Instants at or before `x`.
    let upto = |x: u128| if x < o { 0 } else { (x - o) / p + 1 };
    (upto(elapsed.as_nanos()) - upto(elapsed.saturating_sub(delta).as_nanos())) as u64
}

/// Chained system sets in `FixedUpdate`: every base tick runs them in this order, so coupling
/// is causal (plume, then transfers into the weather, the weather step, transfers back, lava).
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SimSystems {
    /// Decides whether this base tick runs (pause / single step) and counts it.
    Begin,
    /// Plume domain (column slices, s1 spheres, umbrella).
    Plume,
    /// Pyroclastic domain (collapsed slices become particles; deposits; secondary columns).
    Pyroclastic,
    /// Coupling transfers just before the weather step (thesis §4.3.3).
    BeforeWeather,
    /// Layered atmosphere domain.
    Weather,
    /// Coupling transfers just after the weather step.
    AfterWeather,
    /// Lava domain.
    Lava,
    /// End of the base tick.
    End,
}

impl SimSystems {
    /// Every set, in the order a base tick runs them: `VolcanoCorePlugin` chains exactly this
    /// list, and tools that time or hook between the sets read it from here.
    pub const ORDER: [SimSystems; 8] = [
        SimSystems::Begin,
        SimSystems::Plume,
        SimSystems::Pyroclastic,
        SimSystems::BeforeWeather,
        SimSystems::Weather,
        SimSystems::AfterWeather,
        SimSystems::Lava,
        SimSystems::End,
    ];
}

/// Global simulation control: pause all domains, single-step base ticks, simulation speed.
/// Acts on the volcano's clocks only, never on the game's `Time<Virtual>` or `Time<Fixed>`.
#[derive(Resource, Debug, Clone, Reflect)]
#[reflect(Resource)]
pub struct SimControl {
    /// While true no base tick runs (except requested single steps).
    pub paused: bool,
    pending_ticks: u32,
    running_this_tick: bool,
    speed: f64,
    simulated: Duration,
}

impl Default for SimControl {
    fn default() -> Self {
        Self {
            paused: false,
            pending_ticks: 0,
            running_this_tick: false,
            speed: 1.0,
            simulated: Duration::ZERO,
        }
    }
}

impl SimControl {
    /// Accepted simulation speeds (multiples of the game's time).
    pub const SPEED_RANGE: (f64, f64) = (0.01, 100.0);

    /// Simulation speed: every domain step covers `speed ×` its cadence's length, so the
    /// volcano runs `speed` times faster than the game's fixed clock at the same cost per tick
    /// (coarser steps above 1, finer below). Default 1.
    pub fn speed(&self) -> f64 {
        self.speed
    }
    /// Sets the speed; errors outside [`SimControl::SPEED_RANGE`] (and on NaN).
    pub fn set_speed(&mut self, speed: f64) -> Result<(), ConfigError> {
        let (lo, hi) = Self::SPEED_RANGE;
        self.speed = crate::error::in_range("speed", speed, lo, hi)?;
        Ok(())
    }
    /// Puts a speed written past [`SimControl::set_speed`] (through reflection) back in range:
    /// the nearest bound, or 1 if NaN. Returns the correction, for the caller to report.
    pub(crate) fn correct(&mut self) -> Option<String> {
        let speed = nearest_in(self.speed, Self::SPEED_RANGE)?;
        let said = format!("speed {} -> {speed}", self.speed);
        self.speed = speed;
        Some(said)
    }
    /// Simulated time so far: the sum over the base ticks run of `timestep × speed`.
    pub fn simulated(&self) -> Duration {
        self.simulated
    }
    /// While paused, run `n` more base ticks (one per fixed update).
    pub fn step_ticks(&mut self, n: u32) {
        self.pending_ticks = self.pending_ticks.saturating_add(n);
    }
    /// Whether the current base tick is being simulated.
    pub fn running_this_tick(&self) -> bool {
        self.running_this_tick
    }
    /// Single steps still queued.
    pub fn pending_ticks(&self) -> u32 {
        self.pending_ticks
    }
}

/// `None` if `value` lies in `[lo, hi]`, else the nearest bound (1 clamped into the range if
/// `value` is NaN).
fn nearest_in(value: f64, (lo, hi): (f64, f64)) -> Option<f64> {
    if (lo..=hi).contains(&value) {
        None
    } else if value.is_nan() {
        Some(1.0f64.clamp(lo, hi))
    } else {
        Some(value.clamp(lo, hi))
    }
}

/// Number of base ticks simulated so far (not counting paused ticks): the simulation's
/// deterministic time. Same seed + same `SimTick` (at the same fixed rate and speed) = same
/// state.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource)]
pub struct SimTick(pub u64);
