//! Keeps the plume's step inside the range its slice model is validated for: one step is the
//! base tick ÷ the domain's substeps × its time scale × the simulation speed, and a game's
//! fixed rate and speed can push that past [`MAX_PLUME_STEP_S`] (a 1 Hz fixed update at the
//! default 10 substeps is already at it; a speed of 100 at 50 Hz is twice it), where the
//! explicit slice integration (thesis eqs 3.1–3.8) is no longer checked. The plume then takes
//! more substeps instead, and says so.

use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::PlumeStep;

/// Longest plume step (s): the bound `PlumeParams::validate` puts on the model's `dt`.
pub const MAX_PLUME_STEP_S: f64 = 0.1;

/// In `SimSystems::Begin`: raises the plume's substeps when one step would exceed
/// [`MAX_PLUME_STEP_S`] (up to [`Cadence::MAX_SUBSTEPS`]), with a warning naming the step.
pub(super) fn keep_plume_steps_short(
    fixed: Res<Time<Fixed>>,
    control: Res<SimControl>,
    mut clock: ResMut<Time<DomainClock<PlumeStep>>>,
) {
    let (speed, scale) = (control.speed(), clock.context().time_scale());
    // Out-of-range values written through reflection are corrected by the clock this tick.
    if !(speed.is_finite() && speed > 0.0 && scale.is_finite() && scale > 0.0) {
        return;
    }
    let base = fixed.timestep();
    let cadence = clock.context().cadence();
    let step = cadence.step_duration(base).as_secs_f64() * scale * speed;
    if step <= MAX_PLUME_STEP_S {
        return;
    }
    let needed = (base.as_secs_f64() * scale * speed / MAX_PLUME_STEP_S).ceil();
    let substeps = needed.min(f64::from(Cadence::MAX_SUBSTEPS)) as u32;
    let wanted = Cadence::Substeps(substeps);
    if wanted == cadence || clock.context_mut().set_cadence(wanted).is_err() {
        warn_once!(
            "plume steps of {step:.3} s exceed {MAX_PLUME_STEP_S} s even at {} substeps (fixed timestep \
             {base:?}, speed {speed}, time scale {scale})",
            Cadence::MAX_SUBSTEPS
        );
        return;
    }
    warn!(
        "plume: a step of {step:.3} s (fixed timestep {base:?} × speed {speed} × time scale {scale} with \
         {cadence:?}) exceeds {MAX_PLUME_STEP_S} s; the plume now takes {substeps} substeps per tick"
    );
}
