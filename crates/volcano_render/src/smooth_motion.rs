//! [`SmoothMotionPlugin`]: slices, s1 and umbrella spheres and pyroclastic particles are drawn
//! between their last two base ticks, through
//! [`volcano_core::interpolation`]: the simulation runs at the game's fixed rate (50–64 Hz),
//! the ash moves on every rendered frame. A member of
//! [`VolcanoRenderPlugins`](crate::VolcanoRenderPlugins); disable it to draw the ticks as they
//! are.

use bevy::prelude::*;
use volcano_core::interpolation::{TickInterpolation, TickInterpolationPlugin};
use volcano_plume::{PlumeSlice, PyroParticle, S1, Umbrella};

/// Makes [`TickInterpolation`] a required component of the plume's moving entities and adds
/// [`TickInterpolationPlugin`].
#[derive(Debug, Default, Clone)]
pub struct SmoothMotionPlugin;

impl Plugin for SmoothMotionPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<TickInterpolationPlugin>() {
            app.add_plugins(TickInterpolationPlugin);
        }
        let world = app.world_mut();
        for result in [
            world.try_register_required_components::<PlumeSlice, TickInterpolation>(),
            world.try_register_required_components::<S1, TickInterpolation>(),
            world.try_register_required_components::<Umbrella, TickInterpolation>(),
            world.try_register_required_components::<PyroParticle, TickInterpolation>(),
        ] {
            if let Err(e) = result {
                // Already required (a game registered it) or entities exist already: those
                // entities move tick by tick.
                warn!("volcano: smooth motion: {e}");
            }
        }
    }
}
