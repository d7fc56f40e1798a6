//! The lava part of a scene: a `LavaField` placed on the scene's terrain with its sources
//! (`lava: Some((...))` in a scene's RON), and the Fig 5.10 test tables as a terrain
//! (`terrain: LavaTable(...)`).

use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use volcano_core::Terrain;
use volcano_core::error::{ConfigError, finite, in_range};
use volcano_lava::{
    LavaField, LavaFountain, LavaParams, LavaSource, LavaVent, Placement, ScenarioKind, VentLavaSettings,
};

/// A lava source of a scene.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LavaSourceSpec {
    /// World (x, z) of the source (m).
    pub position: (f32, f32),
    /// Volume rate (m³/s).
    pub rate: f64,
    /// Lava temperature (K); the liquidus (1473 K) if left out.
    #[serde(default = "liquidus")]
    pub temperature: f64,
    /// Radius of the fed disc (m); 0 = one cell.
    #[serde(default)]
    pub radius: f64,
}

fn liquidus() -> f64 {
    LavaParams::default().liquidus
}

/// A lava field of a scene: a grid of `cells` cells of `cell` m centred on `centre` (world
/// x, z), resampling the scene's terrain, with default (thesis Table 5.2) parameters.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LavaSceneSpec {
    /// World (x, z) of the grid centre (m).
    pub centre: (f32, f32),
    /// Cells along x and z.
    pub cells: (u32, u32),
    /// Cell size (m), thesis 0.5.
    pub cell: f64,
    /// Sources.
    #[serde(default)]
    pub sources: Vec<LavaSourceSpec>,
    /// Seed of the fold layer.
    #[serde(default)]
    pub seed: u64,
}

impl LavaSceneSpec {
    /// The field's placement.
    pub fn placement(&self) -> Placement {
        Placement {
            centre: Vec2::new(self.centre.0, self.centre.1),
            nx: self.cells.0 as usize,
            ny: self.cells.1 as usize,
            cell: self.cell,
        }
    }

    /// The field component (default parameters, open edges).
    pub fn field(&self) -> Result<LavaField, ConfigError> {
        let mut field = LavaField::new(self.placement(), LavaParams::default())?;
        field.seed = self.seed;
        Ok(field)
    }

    /// The source components.
    pub fn source_components(&self) -> Result<Vec<LavaSource>, ConfigError> {
        self.sources
            .iter()
            .map(|s| {
                LavaSource::new(s.rate)?
                    .at(Vec3::new(s.position.0, 0.0, s.position.1))?
                    .with_temperature(s.temperature)?
                    .with_radius(s.radius)
            })
            .collect()
    }

    /// Checks every value (whether the grid lies on the terrain is checked when it is built).
    pub fn validate(&self) -> Result<(), ConfigError> {
        finite("lava.centre.x", self.centre.0 as f64)?;
        finite("lava.centre.y", self.centre.1 as f64)?;
        self.field()?;
        self.source_components()?;
        Ok(())
    }

    /// Spawns the field and its sources; returns their entities.
    pub fn spawn(&self, commands: &mut Commands) -> Vec<Entity> {
        let mut spawned = Vec::new();
        // Validated when the scene was loaded.
        if let Ok(field) = self.field() {
            spawned.push(commands.spawn((Name::new("Lava field"), field)).id());
        }
        for src in self.source_components().unwrap_or_default() {
            spawned.push(commands.spawn((Name::new("Lava source"), src)).id());
        }
        spawned
    }
}

/// Lava from the scene volcano's own vent (`vent_lava: Some((...))`): a `LavaVent` on the
/// volcano, its runout over the whole terrain ([`volcano_lava::TerrainLava`]).
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VentLavaSpec {
    /// Effusion rate (m³/s).
    pub rate: f64,
    /// World (x, z) offset of the lava vent from the volcano's vent (m): a flank vent.
    #[serde(default)]
    pub offset: (f32, f32),
    /// Radius of the fed area around the vent (m).
    #[serde(default = "vent_radius")]
    pub radius: f64,
    /// Half a fissure, from the vent to one end (x, z; m); none: a point vent.
    #[serde(default)]
    pub fissure: (f32, f32),
    /// Simulated seconds of lava per second of the scene (`VentLavaSettings::time_scale`):
    /// hours of an effusive eruption in a minute.
    #[serde(default = "one")]
    pub time_scale: f64,
    /// A Hawaiian fountain over the vent this high (m); none: the lava wells out.
    #[serde(default)]
    pub fountain: Option<f64>,
}

fn vent_radius() -> f64 {
    15.0
}

fn one() -> f64 {
    1.0
}

impl VentLavaSpec {
    /// The vent component.
    pub fn vent(&self) -> Result<LavaVent, ConfigError> {
        let v = LavaVent {
            offset: Vec2::new(self.offset.0, self.offset.1),
            fissure: Vec2::new(self.fissure.0, self.fissure.1),
            radius: self.radius,
            ..LavaVent::effusive(self.rate)?
        };
        v.validate()?;
        Ok(v)
    }

    /// The fountain component, if the vent has one.
    pub fn fountain(&self) -> Result<Option<LavaFountain>, ConfigError> {
        self.fountain.map(LavaFountain::with_height).transpose()
    }

    /// The settings resource the scene sets (its time scale).
    pub fn settings(&self) -> Result<VentLavaSettings, ConfigError> {
        let s = VentLavaSettings { time_scale: self.time_scale, ..Default::default() };
        s.validate()?;
        Ok(s)
    }

    /// Checks every value.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.vent()?;
        self.fountain()?;
        self.settings()?;
        Ok(())
    }
}

/// Terrain of a Fig 5.10 test table (`obstacle`, `split`, `canyon`, `slope`): `cells` × `cells`
/// of `cell` m descending toward +z at `slope_deg`, centred on the origin, with `margin` cells
/// of continued slope around it.
pub fn table_terrain(
    scenario: &str,
    cells: u32,
    cell: f64,
    slope_deg: f64,
    margin: u32,
) -> Result<Terrain, ConfigError> {
    let kind: ScenarioKind = scenario.parse()?;
    in_range("cells", cells as f64, 8.0, 4096.0)?;
    in_range("cell", cell, 0.01, 100.0)?;
    in_range("slope_deg", slope_deg, 0.0, 45.0)?;
    volcano_lava::scenario_terrain(kind, cells as usize, cell, slope_deg, margin as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_lava_specs_are_errors() {
        let good = LavaSceneSpec {
            centre: (0.0, 0.0),
            cells: (64, 64),
            cell: 0.5,
            sources: vec![LavaSourceSpec {
                position: (0.0, -10.0),
                rate: 1.0,
                temperature: 1473.0,
                radius: 0.75,
            }],
            seed: 1,
        };
        good.validate().unwrap();
        let mut bad = good.clone();
        bad.sources[0].rate = -1.0;
        assert!(bad.validate().unwrap_err().to_string().contains("rate"));
        let mut bad = good.clone();
        bad.sources[0].temperature = f64::NAN;
        assert!(bad.validate().is_err());
        let mut bad = good.clone();
        bad.cell = 0.0;
        assert!(bad.validate().is_err());
        assert!(table_terrain("volcano", 64, 0.5, 3.0, 8).is_err());
        assert!(table_terrain("obstacle", 64, 0.5, 80.0, 8).is_err());
        let t = table_terrain("obstacle", 64, 0.5, 3.0, 8).unwrap();
        assert_eq!(t.heights().nx(), 80);
        let vent = VentLavaSpec {
            rate: 5.0,
            offset: (10.0, 0.0),
            radius: 15.0,
            fissure: (0.0, 0.0),
            time_scale: 60.0,
            fountain: Some(120.0),
        };
        vent.validate().unwrap();
        assert!(vent.fountain().unwrap().is_some());
        assert!(VentLavaSpec { fountain: Some(-5.0), ..vent.clone() }.validate().is_err());
        assert!(VentLavaSpec { rate: f64::NAN, ..vent.clone() }.validate().is_err());
        assert!(VentLavaSpec { time_scale: 0.0, ..vent.clone() }.validate().is_err());
        assert!(VentLavaSpec { offset: (f32::INFINITY, 0.0), ..vent.clone() }.validate().is_err());
        assert!(VentLavaSpec { fissure: (9_000.0, 0.0), ..vent }.validate().is_err());
    }
}
