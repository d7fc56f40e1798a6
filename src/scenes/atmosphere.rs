//! The optional atmosphere of a scene: a built-in layered-atmosphere scenario
//! (`volcano_atmosphere`) run over the scene's own terrain, pre-spun at startup so the clouds
//! are there in the first frame, with a weather time scale so they move at a watchable pace.
//! A [`crate::quality::VolcanoQuality`] present at startup scales its grid.

use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use volcano_atmosphere::{GridSpec, WeatherScenario, WeatherStep, spawn_scenario_with};
use volcano_core::error::{ConfigError, in_range};
use volcano_core::{DomainClock, Terrain};

/// A scene's atmosphere (`atmosphere: Some((scenario: "mixed", …))` in a scene file).
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneAtmosphere {
    /// Built-in scenario name (`convection`, `island`, `sea-breeze`, `orographic`, `mixed`).
    pub scenario: String,
    /// Cells per side (power of two); the scenario's own if `None`.
    #[serde(default)]
    pub grid: Option<usize>,
    /// Model steps of the scenario's Δt run at startup (0–10,000).
    #[serde(default)]
    pub prespin_steps: u32,
    /// Weather seconds per simulated second (the weather steps once per simulated second, so
    /// this is its Δt), 0.01–1,000. Default 30 (the scenarios' Δt).
    #[serde(default = "default_time_scale")]
    pub time_scale: f64,
}

fn default_time_scale() -> f64 {
    30.0
}

impl SceneAtmosphere {
    /// Checks the scenario name and the numbers.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let scenario = WeatherScenario::builtin(&self.scenario)?;
        if let Some(n) = self.grid {
            GridSpec::new(n, scenario.extent_m / n.max(1) as f64)?;
        }
        in_range("atmosphere.prespin_steps", self.prespin_steps as f64, 0.0, 10_000.0)?;
        in_range("atmosphere.time_scale", self.time_scale, 0.01, 1_000.0)?;
        Ok(())
    }
}

/// Spawns the atmosphere over `terrain` at startup and sets the weather's time scale.
pub(crate) fn build(app: &mut App, spec: &SceneAtmosphere, terrain: &Terrain) {
    let (spec, terrain) = (spec.clone(), terrain.clone());
    app.add_systems(
        Startup,
        move |mut commands: Commands,
              clock: Option<ResMut<Time<DomainClock<WeatherStep>>>>,
              quality: Option<Res<crate::quality::VolcanoQuality>>| {
            if let Err(e) =
                spawn(&mut commands, &spec, &terrain, quality.as_deref(), clock.map(|c| c.into_inner()))
            {
                error!("scene atmosphere `{}` not spawned: {e}", spec.scenario);
            }
        },
    );
}

/// Spawns the atmosphere of `spec` over `terrain` (its grid scaled by `quality`, if any) and
/// sets the weather clock's time scale (a scene's choice). Returns the atmosphere entity (its
/// air layers are its children).
pub(crate) fn spawn(
    commands: &mut Commands,
    spec: &SceneAtmosphere,
    terrain: &Terrain,
    quality: Option<&crate::quality::VolcanoQuality>,
    clock: Option<&mut Time<DomainClock<WeatherStep>>>,
) -> Result<Entity, ConfigError> {
    if let Some(clock) = clock {
        clock.context_mut().set_time_scale(spec.time_scale)?;
    }
    let s = WeatherScenario::builtin(&spec.scenario)?;
    // A quality level scales the scene's grid (read here only: a restart applies it).
    let grid = match quality {
        Some(q) => Some(q.atmosphere_cells(spec.grid.unwrap_or(s.grid))),
        None => spec.grid,
    };
    spawn_scenario_with(commands, &s, grid, Some(terrain), spec.prespin_steps)
}
