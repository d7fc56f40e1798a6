//! How a scene writes a [`Terrain`]: a terrain is a built heightfield with no sensible default
//! value, so Bevy's scenes (`bsn!`) build it from a [`TerrainTemplate`], its generator's
//! parameters, when the scene spawns. Invalid parameters fail the spawn with an error naming
//! the parameter, never a panic.
//!
//! ```text
//! bsn! { Terrain::Stratovolcano(StratovolcanoParams { resolution: 256, cell: 80.0 }) }
//! bsn! { Terrain::Flat { resolution: 64, cell: 10.0, altitude: 300.0 } }
//! ```

use bevy::ecs::error::BevyError;
use bevy::ecs::template::{FromTemplate, Template, TemplateContext};
use bevy::prelude::ReflectDefault;
use bevy::reflect::Reflect;

use super::Terrain;
use super::generate::StratovolcanoParams;
use crate::error::{ConfigError, finite, in_range, positive};

/// The generator a scene builds a [`Terrain`] with (`Terrain`'s `FromTemplate::Template`). In
/// `bsn!` its variants are written on `Terrain`: `Terrain::Stratovolcano(StratovolcanoParams {
/// .. })` patches the named fields over the generator's defaults, and a bare `Terrain` is the
/// default stratovolcano. A terrain built in code (a PNG, the game's own heights) is spawned as
/// the component itself; one loaded as an asset through `volcano::assets::HeightmapSource`.
///
/// Not `Clone`: a `Default + Clone` type is its own template in Bevy, so a template that
/// builds something else copies itself with [`Template::clone_template`].
#[derive(Debug, PartialEq, Reflect)]
#[reflect(Default, Debug, PartialEq)]
pub enum TerrainTemplate {
    /// A procedural stratovolcano ([`StratovolcanoParams::generate`]).
    Stratovolcano(StratovolcanoParams),
    /// Flat ground of `resolution × resolution` samples `cell` m apart at `altitude` m, with no
    /// sea ([`Terrain::flat`]).
    Flat {
        /// Samples per side (2..=4097).
        resolution: u32,
        /// Distance between samples (m), > 0.
        cell: f64,
        /// Altitude of the ground (m), finite.
        altitude: f32,
    },
}

impl Default for TerrainTemplate {
    /// The default stratovolcano (`StratovolcanoParams::default()`: a 2.5 km cone on a 20 km
    /// square at 512² samples).
    fn default() -> Self {
        Self::Stratovolcano(StratovolcanoParams::default())
    }
}

impl From<StratovolcanoParams> for TerrainTemplate {
    fn from(params: StratovolcanoParams) -> Self {
        Self::Stratovolcano(params)
    }
}

impl TerrainTemplate {
    /// What `bsn!` starts from when a scene names the `Stratovolcano` variant: the default
    /// parameters, which the scene's fields then patch.
    pub fn default_stratovolcano() -> Self {
        Self::default()
    }

    /// What `bsn!` starts from when a scene names the `Flat` variant: 64² samples 10 m apart
    /// at altitude 0, which the scene's fields then patch.
    pub fn default_flat() -> Self {
        Self::Flat { resolution: 64, cell: 10.0, altitude: 0.0 }
    }

    /// Builds the terrain; the error names the first invalid parameter.
    pub fn build(&self) -> Result<Terrain, ConfigError> {
        match self {
            Self::Stratovolcano(params) => params.generate(),
            Self::Flat { resolution, cell, altitude } => {
                in_range("resolution", *resolution as f64, 2.0, 4097.0)?;
                positive("cell", *cell)?;
                finite("altitude", *altitude as f64)?;
                Terrain::flat(*resolution as usize, *cell, *altitude)
            }
        }
    }
}

impl Template for TerrainTemplate {
    type Output = Terrain;

    fn build_template(&self, _context: &mut TemplateContext) -> Result<Terrain, BevyError> {
        self.build().map_err(|e| BevyError::from(format!("terrain not built: {e}")))
    }

    fn clone_template(&self) -> Self {
        match self {
            Self::Stratovolcano(params) => Self::Stratovolcano(params.clone()),
            Self::Flat { resolution, cell, altitude } => {
                Self::Flat { resolution: *resolution, cell: *cell, altitude: *altitude }
            }
        }
    }
}

impl FromTemplate for Terrain {
    type Template = TerrainTemplate;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_variants_build_their_terrains() {
        let t = TerrainTemplate::Flat { resolution: 8, cell: 5.0, altitude: 120.0 }.build().unwrap();
        assert_eq!((t.heights().nx(), t.heights().cell(), t.height_at(3.0, -4.0)), (8, 5.0, 120.0));
        let params = StratovolcanoParams { resolution: 32, cell: 400.0, ..Default::default() };
        let t = TerrainTemplate::from(params.clone()).clone_template().build().unwrap();
        assert_eq!(t, params.generate().unwrap(), "the generator's terrain, bit for bit");
        assert_eq!(TerrainTemplate::default(), TerrainTemplate::default_stratovolcano());
    }

    #[test]
    fn invalid_parameters_are_errors_naming_them() {
        let bad = StratovolcanoParams { cell: 0.0, ..Default::default() };
        assert!(TerrainTemplate::Stratovolcano(bad).build().unwrap_err().to_string().contains("cell"));
        for (template, name) in [
            (TerrainTemplate::Flat { resolution: 1, cell: 5.0, altitude: 0.0 }, "resolution"),
            (TerrainTemplate::Flat { resolution: 8, cell: -5.0, altitude: 0.0 }, "cell"),
            (TerrainTemplate::Flat { resolution: 8, cell: 5.0, altitude: f32::NAN }, "altitude"),
        ] {
            let e = template.build().unwrap_err();
            assert!(e.to_string().contains(name), "{e}");
        }
    }
}
