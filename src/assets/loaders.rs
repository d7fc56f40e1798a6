//! The asset types and their loaders: RON files for plume presets, eruption timelines, scenes
//! and atmosphere scenarios (one generic loader, each type parsing and validating its own
//! text), and 16-bit greyscale PNG heightmaps. A bad file fails to load with an error that
//! names the field (RON's "unknown field `x`" with its position, or the validation's
//! "invalid parameter `name`").

use std::marker::PhantomData;

use bevy::asset::io::Reader;
use bevy::asset::{Asset, AssetLoader, LoadContext};
use bevy::reflect::TypePath;
use serde::{Deserialize, Serialize};
use volcano_atmosphere::WeatherScenario;
use volcano_core::terrain::png_io::HeightmapScale;
use volcano_core::{ConfigError, Terrain};
use volcano_plume::{EruptionTimeline, PlumeParams};

use crate::scenes::SceneSpec;

/// Why an asset file did not load.
#[derive(Debug, thiserror::Error)]
pub enum VolcanoAssetError {
    /// The bytes could not be read.
    #[error("could not read the file: {0}")]
    Io(#[from] std::io::Error),
    /// A RON file is not UTF-8.
    #[error("not UTF-8 text: {0}")]
    Utf8(#[from] std::str::Utf8Error),
    /// The content is malformed or a value is out of range (the message names the field).
    #[error(transparent)]
    Config(#[from] ConfigError),
}

/// A type loaded from a RON file by [`RonAssetLoader`].
pub trait RonAsset: Asset + Sized {
    /// File extensions (without the dot) the loader claims; typed loads work with any name.
    const EXTENSIONS: &'static [&'static str];
    /// Parses and validates the text.
    fn parse(text: &str) -> Result<Self, ConfigError>;
}

/// Loads any [`RonAsset`].
#[derive(TypePath)]
pub struct RonAssetLoader<A: RonAsset>(PhantomData<fn() -> A>);

impl<A: RonAsset> Default for RonAssetLoader<A> {
    fn default() -> Self {
        Self(PhantomData)
    }
}

impl<A: RonAsset + TypePath> AssetLoader for RonAssetLoader<A> {
    type Asset = A;
    type Settings = ();
    type Error = VolcanoAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        _settings: &(),
        _load_context: &mut LoadContext<'_>,
    ) -> Result<A, VolcanoAssetError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        Ok(A::parse(std::str::from_utf8(&bytes)?)?)
    }

    fn extensions(&self) -> &[&str] {
        A::EXTENSIONS
    }
}

/// A plume parameter set (`*.plume.ron`, the format of `crates/volcano_plume/presets/`;
/// missing fields take the thesis' values). [`super::PlumePresetSource`] applies it to an
/// eruption.
#[derive(Asset, TypePath, Debug, Clone, PartialEq)]
pub struct PlumePresetAsset(pub PlumeParams);

impl RonAsset for PlumePresetAsset {
    const EXTENSIONS: &'static [&'static str] = &["plume.ron"];
    fn parse(text: &str) -> Result<Self, ConfigError> {
        PlumeParams::from_ron(text).map(Self)
    }
}

/// An eruption's story (`*.timeline.ron`, [`EruptionTimeline`]). [`super::EruptionTimelineSource`]
/// drives an eruption with it.
#[derive(Asset, TypePath, Debug, Clone, PartialEq)]
pub struct EruptionTimelineAsset(pub EruptionTimeline);

impl RonAsset for EruptionTimelineAsset {
    const EXTENSIONS: &'static [&'static str] = &["timeline.ron"];
    fn parse(text: &str) -> Result<Self, ConfigError> {
        EruptionTimeline::from_ron(text).map(Self)
    }
}

/// A scene description (`*.scene.ron`, [`SceneSpec`], the format of `assets/scenes/`).
#[derive(Asset, TypePath, Debug, Clone, PartialEq)]
pub struct SceneAsset(pub SceneSpec);

impl RonAsset for SceneAsset {
    const EXTENSIONS: &'static [&'static str] = &["scene.ron"];
    fn parse(text: &str) -> Result<Self, ConfigError> {
        SceneSpec::from_ron(text).map(Self)
    }
}

/// A layered-atmosphere scenario (`*.atmosphere.ron`, [`WeatherScenario`], the format of
/// `crates/volcano_atmosphere/scenarios/`).
#[derive(Asset, TypePath, Debug, Clone)]
pub struct AtmosphereScenarioAsset(pub WeatherScenario);

impl RonAsset for AtmosphereScenarioAsset {
    const EXTENSIONS: &'static [&'static str] = &["atmosphere.ron"];
    fn parse(text: &str) -> Result<Self, ConfigError> {
        WeatherScenario::from_ron(text).map(Self)
    }
}

/// A terrain from a greyscale PNG heightmap (16-bit preferred), centred on the origin.
/// [`super::HeightmapSource`] puts it on an entity as its [`Terrain`].
#[derive(Asset, TypePath, Debug, Clone)]
pub struct HeightmapAsset(pub Terrain);

/// How a heightmap's values and pixels map to metres (the loader's settings: a `.meta` file
/// beside the PNG, or `AssetServer::load_with_settings`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HeightmapSettings {
    /// Metres per PNG unit (16-bit: 0.1 m spans 0–6,553.5 m).
    pub metres_per_unit: f64,
    /// Altitude of value 0 (m).
    pub base_altitude: f64,
    /// Distance between samples (m).
    pub cell: f64,
    /// Sea level (m): cells below it are water.
    pub sea_level: f32,
    /// Altitude (m) above which the ground is snow.
    pub snow_line: f32,
    /// Slope (degrees) above which the ground is bare rock; gentler land is vegetation.
    pub bare_slope_deg: f32,
}

impl Default for HeightmapSettings {
    /// The scale of the heightmaps this crate writes (`volcano` CLI and the bundled
    /// `terrain/stratovolcano.height.png`): 0.1 m per unit from 0 m, 80 m cells.
    fn default() -> Self {
        Self {
            metres_per_unit: 0.1,
            base_altitude: 0.0,
            cell: 80.0,
            sea_level: 0.0,
            snow_line: 2_300.0,
            bare_slope_deg: 28.0,
        }
    }
}

impl HeightmapSettings {
    fn scale(&self) -> HeightmapScale {
        HeightmapScale {
            metres_per_unit: self.metres_per_unit,
            base_altitude: self.base_altitude,
            cell: self.cell,
            sea_level: self.sea_level,
        }
    }
}

/// Loads [`HeightmapAsset`]s (`*.height.png`; typed loads of any PNG).
#[derive(TypePath, Default)]
pub struct HeightmapLoader;

impl AssetLoader for HeightmapLoader {
    type Asset = HeightmapAsset;
    type Settings = HeightmapSettings;
    type Error = VolcanoAssetError;

    async fn load(
        &self,
        reader: &mut dyn Reader,
        settings: &HeightmapSettings,
        _load_context: &mut LoadContext<'_>,
    ) -> Result<HeightmapAsset, VolcanoAssetError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).await?;
        let terrain = Terrain::from_png_bytes(&bytes, settings.scale())?;
        Ok(HeightmapAsset(terrain.with_relief_cover(settings.snow_line, settings.bare_slope_deg)?))
    }

    fn extensions(&self) -> &[&str] {
        &["height.png"]
    }
}
