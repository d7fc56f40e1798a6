//! Rendering for the volcano plugin set: the terrain mesh with per-pixel ground detail and vent
//! markers ([`terrain`]), the eruption column ([`plume`]), the ash deposit
//! ([`terrain::deposit`]), lava ([`lava`]), volumetric clouds ([`clouds`]), an orbit camera
//! ([`camera`]), the opt-in sun, ambient light and sky ([`sky`]) and windowless offscreen
//! capture for tests and the CLI ([`headless`]).
//!
//! [`VolcanoRenderPlugins`] draws the simulation and touches nothing of the game's lighting or
//! cameras, except that a camera the game tags [`GlowCamera`] is HDR with bloom. Scenes without lighting of their own add [`VolcanoSkyPlugin`] and spawn their camera
//! with [`camera_bundle`] (a [`VolcanoViewer`] and [`VolcanoSkyCamera`]); the same scene code
//! renders to a window (with `DefaultPlugins`) or to a PNG (with [`headless_default_plugins`]
//! and [`HeadlessCapturePlugin`]). Any member of the group can be left out:
//! `VolcanoRenderPlugins.build().disable::<LavaRenderPlugin>()`.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use volcano_core::{StratovolcanoParams, Volcano, VolcanoCorePlugin};
//! use volcano_render::{OrbitCamera, VolcanoRenderPlugins, VolcanoSkyPlugin, camera_bundle};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, VolcanoCorePlugin, VolcanoRenderPlugins, VolcanoSkyPlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn(StratovolcanoParams::default().generate().unwrap());
//!         commands.spawn((Volcano::default(), Transform::default()));
//!         commands.spawn(camera_bundle(OrbitCamera::default()));
//!     })
//!     .run();
//! ```
#![forbid(unsafe_code)]

pub mod ash_fall;
mod build_job;
pub mod camera;
pub mod clouds;
pub mod density_volume;
pub mod headless;
pub mod lava;
pub mod plume;
pub mod sky;
pub mod smooth_motion;
pub mod terrain;
pub mod window_capture;

use bevy::app::{App, PluginGroup, PluginGroupBuilder};
use bevy::asset::AssetApp;
use bevy::pbr::{Material, MaterialPlugin};
use bevy::render::RenderApp;

pub use ash_fall::{AshFallBuildStatus, AshFallDraw, AshFallRenderPlugin, AshFallSettings, AshFallVolume};
pub use camera::{
    CAMERA_FOV_DEG, GlowCamera, OrbitCamera, OrbitCameraPlugin, PointerCaptured, VolcanoViewer,
    camera_bundle, glow_bloom,
};
pub use clouds::{CloudDraw, CloudMaterial, CloudRenderPlugin, CloudRenderSettings, CloudVolume};
pub use headless::{CaptureStatus, HeadlessCapturePlugin, headless_default_plugins, write_png_rgb};
pub use lava::{LavaRenderMode, LavaRenderPlugin, LavaRenderSettings};
pub use plume::{AshCloud, PlumeRenderMode, PlumeRenderPlugin, PlumeVisuals};
pub use sky::{
    ActiveSky, GradientSky, SkyMode, SkySettings, Sun, VolcanoSky, VolcanoSkyCamera, VolcanoSkyPlugin,
    sky_camera_components, sun_bundle,
};
pub use smooth_motion::SmoothMotionPlugin;
pub use terrain::{
    DepositRenderPlugin, DepositTint, GroundDetail, GroundDetailExtension, GroundSample, HorizonError,
    Relief, TerrainHorizon, TerrainHorizonMesh, TerrainMaterial, TerrainMesh, TerrainRenderPlugin,
    UnrenderedTerrain, VentMarker, ground_color, horizon_mesh, terrain_mesh,
};
pub use window_capture::WindowScreenshotPlugin;

/// The simulation's visuals, one plugin per part so any can be disabled: terrain meshes and
/// vent markers, the orbit camera controller, the eruption column, the deposit tint, lava,
/// volumetric clouds, the ash fall, and the plume drawn between ticks ([`SmoothMotionPlugin`]).
/// Needs the render plugins (`DefaultPlugins` or
/// [`headless_default_plugins`]). Does not add the sky ([`VolcanoSkyPlugin`]) nor headless
/// capture.
#[derive(Debug, Default, Clone, Copy)]
pub struct VolcanoRenderPlugins;

impl PluginGroup for VolcanoRenderPlugins {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add(TerrainRenderPlugin)
            .add(OrbitCameraPlugin)
            .add(PlumeRenderPlugin)
            .add(DepositRenderPlugin)
            .add(LavaRenderPlugin)
            .add(CloudRenderPlugin)
            .add(AshFallRenderPlugin)
            .add(SmoothMotionPlugin)
    }
}

/// Adds `M`'s [`MaterialPlugin`] once; in an app without a renderer (tests that run the
/// plugins without `RenderPlugin`) only `M`'s asset type, so the systems that hold
/// `Assets<M>` still run. Each of the crate's own materials goes
/// through here (the clouds' and the terrain's).
pub(crate) fn add_material<M: Material>(app: &mut App)
where
    M::Data: PartialEq + Eq + std::hash::Hash + Clone,
{
    if app.get_sub_app(RenderApp).is_none() {
        app.init_asset::<M>();
    } else if !app.is_plugin_added::<MaterialPlugin<M>>() {
        app.add_plugins(MaterialPlugin::<M>::default());
    }
}

/// Everything a scene usually needs from this crate.
pub mod prelude {
    pub use crate::{
        GlowCamera, HeadlessCapturePlugin, OrbitCamera, PlumeRenderMode, PointerCaptured, SkySettings, Sun,
        TerrainHorizon, UnrenderedTerrain, VolcanoRenderPlugins, VolcanoSkyCamera, VolcanoSkyPlugin,
        VolcanoViewer, camera_bundle, headless_default_plugins, sun_bundle,
    };
}
