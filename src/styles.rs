//! Eruption styles that span domains. An [`EruptionScript`] drives the plume; its timeline's
//! `lava_rate` channel drives the volcano's own [`LavaVent`] too (0 stops the vent), so one
//! timeline tells a mixed eruption — a Plinian hour that ends in an effusive week. A Hawaiian
//! eruption is a lava vent with a fountain: [`hawaiian`].

use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_lava::{LavaFountain, LavaVent};
use volcano_plume::EruptionScript;

/// A Hawaiian eruption's components for a volcano: a vent effusing `rate` m³/s under a fountain
/// `height` m high. Errors name the bad value.
pub fn hawaiian(rate: f64, height: f64) -> Result<(LavaVent, LavaFountain), ConfigError> {
    Ok((LavaVent::effusive(rate)?, LavaFountain::with_height(height)?))
}

/// Applies scripted timelines across domains (in `VolcanoSimPlugins`).
#[derive(Debug, Default, Clone)]
pub struct EruptionStylePlugin;

impl Plugin for EruptionStylePlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(FixedUpdate, script_lava.after(SimSystems::Plume).before(SimSystems::Lava));
    }
}

/// Sets each scripted volcano's `LavaVent` rate (and whether it emits) from its timeline's
/// `lava_rate` at the script's clock; a vent whose timeline gives no rate is left alone.
fn script_lava(mut vents: Query<(&EruptionScript, &mut LavaVent)>) {
    for (script, mut vent) in &mut vents {
        let Some(rate) = script.timeline.sample(script.elapsed_s).lava_rate else { continue };
        let active = rate > 0.0;
        if vent.rate != rate || vent.active != active {
            vent.rate = rate;
            vent.active = active;
        }
    }
}
