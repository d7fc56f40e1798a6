//! Rendering for the volcano plugin set: the terrain mesh and vent markers ([`terrain`]), the sun,
//! ambient light and Bevy's physically based sky ([`sky`]), an orbit camera ([`camera`]) and
//! windowless offscreen capture for tests and the CLI ([`headless`]).
//!
//! Scenes spawn one camera with [`camera_bundle`] and let [`VolcanoRenderPlugin`] do the rest;
//! the same scene code renders to a window (with `DefaultPlugins`) or to a PNG (with
//! [`headless_default_plugins`] and [`HeadlessCapturePlugin`]).
//!
//! ```no_run
//! use bevy::prelude::*;
//! use volcano_core::{StratovolcanoParams, Volcano, VolcanoCorePlugin};
//! use volcano_render::{OrbitCamera, VolcanoRenderPlugin, camera_bundle};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, VolcanoCorePlugin, VolcanoRenderPlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn(StratovolcanoParams::default().generate().unwrap());
//!         commands.spawn((Volcano::default(), Transform::default()));
//!         commands.spawn(camera_bundle(OrbitCamera::default()));
//!     })
//!     .run();
//! ```

pub mod ash_fall;
pub mod camera;
pub mod clouds;
pub mod deposit;
pub mod headless;
pub mod lava;
pub mod plume;
pub mod sky;
pub mod terrain;
pub mod window_capture;

use bevy::app::{App, Plugin};

pub use ash_fall::{AshFallFog, AshFallRenderPlugin, AshFallSettings, AshFallVolume};
pub use camera::{MainCamera, OrbitCamera, OrbitCameraPlugin, PointerCaptured, camera_bundle};
pub use clouds::{CloudRenderPlugin, CloudRenderSettings, CloudVolume};
pub use deposit::{DepositRenderPlugin, DepositTint};
pub use headless::{
    CaptureStatus, HeadlessCapturePlugin, headless_default_plugins, png_pixel_stddev, read_png_rgb,
    rgb_region_mean, rgb_stddev, write_png_rgb,
};
pub use lava::{LavaRenderMode, LavaRenderPlugin, LavaRenderSettings};
pub use plume::{AshCloud, PlumeRenderMode, PlumeRenderPlugin, PlumeVisuals};
pub use sky::{
    ActiveSky, GradientSky, SkyMode, SkyPlugin, SkySettings, Sun, VolcanoSky, sky_camera_components,
    sun_bundle,
};
pub use terrain::{TerrainMesh, TerrainRenderPlugin, VentMarker, cover_color, terrain_mesh};
pub use window_capture::WindowScreenshotPlugin;

/// Terrain mesh and vent markers, sun and sky, orbit camera. Needs the render plugins
/// (`DefaultPlugins` or [`headless_default_plugins`]); does not add headless capture.
#[derive(Debug, Default, Clone)]
pub struct VolcanoRenderPlugin;

impl Plugin for VolcanoRenderPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((TerrainRenderPlugin, SkyPlugin, OrbitCameraPlugin, PlumeRenderPlugin));
        app.add_plugins((DepositRenderPlugin, LavaRenderPlugin, CloudRenderPlugin, AshFallRenderPlugin));
    }
}

/// Everything a scene usually needs from this crate.
pub mod prelude {
    pub use crate::{
        HeadlessCapturePlugin, MainCamera, OrbitCamera, PlumeRenderMode, PointerCaptured, SkySettings, Sun,
        VolcanoRenderPlugin, camera_bundle, headless_default_plugins, sun_bundle,
    };
}
