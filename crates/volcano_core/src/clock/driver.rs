//! Driver systems and the `App` extension that registers a simulation domain.

use bevy::app::{App, FixedUpdate};
use bevy::ecs::schedule::{
    IntoScheduleConfigs, LogLevel, ScheduleBuildSettings, ScheduleLabel, SingleThreadedExecutor,
};
use bevy::ecs::world::World;
use bevy::log::error;
use bevy::prelude::{Res, ResMut};
use bevy::reflect::TypePath;
use bevy::time::{Fixed, Time};

use super::{Cadence, DomainClock, SimControl, SimSystems, SimTick};

/// Registers simulation domains on an [`App`].
pub trait SimDomainAppExt {
    /// Adds domain `D` (its schedule label) stepping with `cadence`, driven inside `set`.
    /// Creates the schedule (with ambiguity detection as an error, so systems added to a
    /// domain must be ordered and the domain stays deterministic; it runs them one after the
    /// other on the driving thread, see below), the clock
    /// `Time<DomainClock<D>>`, and the driver system. Panics only on a zero cadence, which is
    /// a programming error in plugin code, not user input. The clock is registered for
    /// reflection (a saved world keeps each domain's phase).
    fn add_sim_domain<D: ScheduleLabel + Default + Clone + TypePath>(
        &mut self,
        set: SimSystems,
        cadence: Cadence,
    ) -> &mut Self;
}

impl SimDomainAppExt for App {
    fn add_sim_domain<D: ScheduleLabel + Default + Clone + TypePath>(
        &mut self,
        set: SimSystems,
        cadence: Cadence,
    ) -> &mut Self {
        let clock = DomainClock::<D>::new(cadence).expect("plugin registered a domain with a zero cadence");
        self.insert_resource(Time::new_with(clock)).register_type::<Time<DomainClock<D>>>();
        self.init_schedule(D::default());
        self.edit_schedule(D::default(), |s| {
            s.set_build_settings(ScheduleBuildSettings {
                ambiguity_detection: LogLevel::Error,
                ..Default::default()
            });
            // Its systems are ordered (above), so the multi-threaded executor could run none of
            // them in parallel; it would only hand each to a compute-pool thread and wait. On a
            // two-core machine that thread competes with the off-thread weather step, and the
            // wait cost 2–3 ms on every weather tick (`volcano bench`). The systems' own
            // parallel loops still use the pool.
            s.set_executor(SingleThreadedExecutor::new());
        });
        self.add_systems(FixedUpdate, drive_domain::<D>.in_set(set));
        self
    }
}

/// `SimSystems::Begin`: decides whether this base tick is simulated and counts it.
pub(crate) fn begin_tick(
    mut control: ResMut<SimControl>,
    mut tick: ResMut<SimTick>,
    fixed: Res<Time<Fixed>>,
) {
    let run = if !control.paused {
        true
    } else if control.pending_ticks > 0 {
        control.pending_ticks -= 1;
        true
    } else {
        false
    };
    control.running_this_tick = run;
    if let Some(fixed) = control.correct() {
        error!("SimControl: {fixed} (a value written past its setter, e.g. through reflection)");
    }
    if run {
        tick.0 += 1;
        let step = scaled(fixed.timestep(), control.speed());
        control.simulated += step;
    }
}

/// Run condition for drivers.
pub(crate) fn tick_is_running(control: Res<SimControl>) -> bool {
    control.running_this_tick
}

/// Runs domain `D`'s schedule according to its cadence, with the generic `Time` replaced by the
/// domain clock while it runs.
pub(crate) fn drive_domain<D: ScheduleLabel + Default + Clone>(world: &mut World) {
    if !world.resource::<SimControl>().running_this_tick() {
        return;
    }
    let base = world.resource::<Time<Fixed>>().timestep();
    let speed = world.resource::<SimControl>().speed();
    let (runs, step) = {
        let mut clock = world.resource_mut::<Time<DomainClock<D>>>();
        let ctx = clock.context_mut();
        if let Some(fixed) = ctx.correct() {
            error!(
                "DomainClock<{}>: {fixed} (a value written past its setters, e.g. through reflection)",
                std::any::type_name::<D>()
            );
        }
        ctx.ticks_seen += 1;
        let runs = if ctx.paused {
            if ctx.pending_steps > 0 {
                ctx.pending_steps -= 1;
                1
            } else {
                0
            }
        } else {
            ctx.cadence.steps_at_tick(ctx.ticks_seen, base)
        };
        (runs, scaled(ctx.step_duration(base), speed))
    };
    if runs == 0 {
        return;
    }
    let saved = *world.resource::<Time>();
    for _ in 0..runs {
        {
            let mut clock = world.resource_mut::<Time<DomainClock<D>>>();
            clock.advance_by(step);
            clock.context_mut().steps_run += 1;
            let generic = clock.as_generic();
            *world.resource_mut::<Time>() = generic;
        }
        // A domain without systems has no schedule run to do; that is not an error.
        let _ = world.try_run_schedule(D::default());
    }
    *world.resource_mut::<Time>() = saved;
}

/// `d × speed`, exact at speed 1.
fn scaled(d: std::time::Duration, speed: f64) -> std::time::Duration {
    if speed == 1.0 { d } else { d.mul_f64(speed) }
}
