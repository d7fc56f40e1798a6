//! The scene registry shared by the examples and `volcano render --scene NAME`, so what CI
//! renders is what a user runs. Scenes are RON files in `assets/scenes/`, embedded in the
//! binary so they work from any working directory; [`SceneSpec::from_ron`] loads a user's own.

use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use volcano_core::error::{ConfigError, finite, in_range, positive};
use volcano_core::terrain::png_io::HeightmapScale;
use volcano_core::{StratovolcanoParams, Terrain, VolcanoSpec};

mod atmosphere;
mod sky;
pub use atmosphere::SceneAtmosphere;
pub(crate) use atmosphere::spawn as spawn_atmosphere;
pub use sky::{SceneRgb, SceneSky};

/// Built-in scenes: (name, RON text).
pub(crate) const BUILTIN: &[(&str, &str)] = &[
    ("eruption", include_str!("../assets/scenes/eruption.ron")),
    ("eruption_collapse", include_str!("../assets/scenes/eruption_collapse.ron")),
    ("eruption_night", include_str!("../assets/scenes/eruption_night.ron")),
    ("effusive_night", include_str!("../assets/scenes/effusive_night.ron")),
    ("effusive_day", include_str!("../assets/scenes/effusive_day.ron")),
    ("plinian_plume", include_str!("../assets/scenes/plinian_plume.ron")),
    ("pyroclastic_flow", include_str!("../assets/scenes/pyroclastic_flow.ron")),
    ("lava_folds", include_str!("../assets/scenes/lava_folds.ron")),
    ("skyscape", include_str!("../assets/scenes/skyscape.ron")),
    ("skyscape_island", include_str!("../assets/scenes/skyscape_island.ron")),
];

/// Names of the built-in scenes.
pub fn names() -> Vec<&'static str> {
    BUILTIN.iter().map(|(n, _)| *n).collect()
}

/// A built-in scene by name, parsed and validated.
pub fn by_name(name: &str) -> Result<SceneSpec, ConfigError> {
    let (_, text) = BUILTIN.iter().find(|(n, _)| *n == name).ok_or_else(|| ConfigError::UnknownName {
        kind: "scene",
        name: name.to_string(),
        known: names().join(", "),
    })?;
    SceneSpec::from_ron(text)
}

/// Where the terrain comes from.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
pub enum TerrainSpec {
    /// The procedural stratovolcano generator.
    Stratovolcano(StratovolcanoParams),
    /// A greyscale PNG heightmap (16-bit preferred): `h = base_altitude + value · metres_per_unit`.
    Heightmap {
        /// Path of the PNG file.
        path: String,
        /// Metres per PNG unit.
        metres_per_unit: f64,
        /// Altitude of value 0 (m).
        base_altitude: f64,
        /// Distance between samples (m).
        cell: f64,
        /// Sea level (m).
        sea_level: f32,
    },
    /// A flat square (tests, lava tables).
    Flat {
        /// Samples per side.
        resolution: u32,
        /// Distance between samples (m).
        cell: f64,
        /// Altitude (m).
        altitude: f32,
    },
    /// A lava test table of thesis Fig 5.10 (`obstacle`, `split`, `canyon`; or `slope`), see
    /// [`crate::lava_scene::table_terrain`].
    LavaTable {
        /// Scenario name.
        scenario: String,
        /// Cells per side of the table.
        cells: u32,
        /// Cell size (m).
        cell: f64,
        /// Slope (degrees), descending toward +z.
        slope_deg: f64,
        /// Cells of continued slope around the table.
        margin: u32,
    },
}

impl TerrainSpec {
    /// Builds (generates or loads) the terrain.
    pub fn build(&self) -> Result<Terrain, ConfigError> {
        match self {
            TerrainSpec::Stratovolcano(p) => p.generate(),
            TerrainSpec::Heightmap { path, metres_per_unit, base_altitude, cell, sea_level } => {
                let scale = HeightmapScale {
                    metres_per_unit: *metres_per_unit,
                    base_altitude: *base_altitude,
                    cell: *cell,
                    sea_level: *sea_level,
                };
                Terrain::from_png_file(path, scale)
            }
            TerrainSpec::Flat { resolution, cell, altitude } => {
                in_range("resolution", *resolution as f64, 2.0, 4097.0)?;
                finite("altitude", *altitude as f64)?;
                Terrain::flat(*resolution as usize, *cell, *altitude)
            }
            TerrainSpec::LavaTable { scenario, cells, cell, slope_deg, margin } => {
                crate::lava_scene::table_terrain(scenario, *cells, *cell, *slope_deg, *margin)
            }
        }
    }
}

/// The initial orbit camera of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
pub struct CameraSpec {
    /// Point the camera looks at (world, m).
    pub focus: (f32, f32, f32),
    /// Horizontal angle around the focus (degrees).
    pub yaw_deg: f32,
    /// Angle above the horizon (degrees, −89..89).
    pub pitch_deg: f32,
    /// Distance from the focus (m).
    pub distance: f32,
}

/// The sun of a scene.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
pub struct SunSpec {
    /// Compass direction of the sun, degrees clockwise from north (north = −z, east = +x).
    pub azimuth_deg: f32,
    /// Height of the sun above the horizon (degrees).
    pub elevation_deg: f32,
    /// Illuminance on a surface facing the sun (lux).
    pub illuminance_lux: f32,
}

/// A far ring of ground around the scene's terrain, fading into the sky's haze (drawn by
/// `volcano_render::TerrainHorizon`; fields as there). Omitted fields take its defaults.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HorizonSpec {
    /// How far the ring reaches beyond the terrain's edge (m).
    pub width: f32,
    /// Distance over which the border heights blend to the base level (m).
    pub blend: f32,
    /// Altitude of the far land (m); `None`: the median height of the terrain's border.
    pub base_altitude: Option<f32>,
    /// Amplitude of the far land's hills (m).
    pub hills: f32,
}

impl Default for HorizonSpec {
    fn default() -> Self {
        Self { width: 110_000.0, blend: 12_000.0, base_altitude: None, hills: 120.0 }
    }
}

impl HorizonSpec {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("horizon.width", self.width as f64)?;
        positive("horizon.blend", self.blend as f64)?;
        in_range("horizon.hills", self.hills as f64, 0.0, 1.0e4)?;
        if let Some(b) = self.base_altitude {
            finite("horizon.base_altitude", b as f64)?;
        }
        Ok(())
    }

    /// The component on the terrain entity.
    #[cfg(feature = "render")]
    pub fn component(&self) -> volcano_render::TerrainHorizon {
        volcano_render::TerrainHorizon {
            width: self.width,
            blend: self.blend,
            base_altitude: self.base_altitude,
            hills: self.hills,
            ..Default::default()
        }
    }
}

/// Which eruption a scene's volcano starts with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Reflect, Serialize, Deserialize)]
pub enum EruptionPreset {
    /// Thesis Table 3.1 as written (v₀ = 150 m/s): collapses at ≈1.9 km.
    Thesis,
    /// Table 3.1 with v₀ = 200 m/s and a light wind: a Plinian column with an umbrella.
    Plinian,
    /// Table 3.1 at v₀ = 70 m/s: the column collapses into pyroclastic flows.
    Pyroclastic,
    /// The physical column (3 wt% gas, 2.7·10⁷ kg/s, docs/physics/plume.md §4.5): its top is
    /// near the air's temperature, so the moisture it lifts condenses into a cap cloud.
    Physical,
}

impl EruptionPreset {
    /// The component.
    pub fn eruption(self) -> volcano_plume::Eruption {
        match self {
            EruptionPreset::Thesis => volcano_plume::Eruption::thesis(),
            EruptionPreset::Plinian => volcano_plume::Eruption::plinian(),
            EruptionPreset::Pyroclastic => volcano_plume::Eruption::pyroclastic(),
            EruptionPreset::Physical => volcano_plume::Eruption::physical(),
        }
    }
}

/// A scene: terrain, volcano, camera and sun.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Registry name.
    pub name: String,
    /// One-line description for `volcano scenes`.
    pub description: String,
    /// Terrain source.
    pub terrain: TerrainSpec,
    /// The volcano.
    pub volcano: VolcanoSpec,
    /// Its eruption, if any.
    #[serde(default)]
    pub eruption: Option<EruptionPreset>,
    /// Initial camera.
    pub camera: CameraSpec,
    /// Sun.
    pub sun: SunSpec,
    /// A lava field with its sources, if any.
    #[serde(default)]
    pub lava: Option<crate::lava_scene::LavaSceneSpec>,
    /// Lava from the volcano's own vent, if any.
    #[serde(default)]
    pub vent_lava: Option<crate::lava_scene::VentLavaSpec>,
    /// A layered atmosphere over the terrain, if any.
    #[serde(default)]
    pub atmosphere: Option<SceneAtmosphere>,
    /// A far ring of ground around the terrain, if any (drawn only with the `render` feature;
    /// a game embedding the plugins gets one only by adding `TerrainHorizon` itself).
    #[serde(default)]
    pub horizon: Option<HorizonSpec>,
    /// Exposure, ambient light and sky colours other than the default day's, if any (applied
    /// only with the `render` feature, when the scene spawns its camera).
    #[serde(default)]
    pub sky: Option<SceneSky>,
}

impl SceneSpec {
    /// Parses and validates a RON scene.
    pub fn from_ron(text: &str) -> Result<Self, ConfigError> {
        let spec: Self = ron::from_str(text)?;
        spec.validate()?;
        Ok(spec)
    }

    /// Checks every field that can be checked without building the terrain.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.volcano.validate()?;
        if let TerrainSpec::Stratovolcano(p) = &self.terrain {
            p.validate()?;
        }
        let c = &self.camera;
        for (n, v) in
            [("camera.focus.x", c.focus.0), ("camera.focus.y", c.focus.1), ("camera.focus.z", c.focus.2)]
        {
            finite(n, v as f64)?;
        }
        finite("camera.yaw_deg", c.yaw_deg as f64)?;
        in_range("camera.pitch_deg", c.pitch_deg as f64, -89.0, 89.0)?;
        positive("camera.distance", c.distance as f64)?;
        finite("sun.azimuth_deg", self.sun.azimuth_deg as f64)?;
        in_range("sun.elevation_deg", self.sun.elevation_deg as f64, -90.0, 90.0)?;
        in_range("sun.illuminance_lux", self.sun.illuminance_lux as f64, 0.0, 1.0e6)?;
        if let Some(lava) = &self.lava {
            lava.validate()?;
        }
        if let Some(v) = &self.vent_lava {
            v.validate()?;
        }
        if let Some(a) = &self.atmosphere {
            a.validate()?;
        }
        if let Some(h) = &self.horizon {
            h.validate()?;
        }
        if let Some(s) = &self.sky {
            s.validate()?;
        }
        Ok(())
    }
}

/// Spawns a scene at startup: the terrain and the volcano, plus the camera and sun when the
/// `render` feature is on (a scene is lit by its own sun and sky, so with `render` it adds
/// `VolcanoSkyPlugin`). The terrain is built when the plugin is created, so
/// a bad file or parameter is an error there, not a panic later.
#[derive(Debug, Clone)]
pub struct VolcanoScenePlugin {
    spec: SceneSpec,
    terrain: Terrain,
    headless: bool,
}

impl VolcanoScenePlugin {
    /// Validates the scene and builds its terrain.
    pub fn new(spec: SceneSpec) -> Result<Self, ConfigError> {
        spec.validate()?;
        let terrain = spec.terrain.build()?;
        Ok(Self { spec, terrain, headless: false })
    }

    /// The simulation only: no sky, camera or sun, for apps without the render stack
    /// (`MinimalPlugins` + `VolcanoSimPlugins`; `volcano bench`).
    pub fn headless(self) -> Self {
        Self { headless: true, ..self }
    }
    /// A built-in scene by name.
    pub fn builtin(name: &str) -> Result<Self, ConfigError> {
        Self::new(by_name(name)?)
    }
    /// The scene description.
    pub fn spec(&self) -> &SceneSpec {
        &self.spec
    }
}

/// The scene being shown (for panels and tools).
#[derive(Resource, Debug, Clone, Reflect)]
#[reflect(Resource)]
pub struct ActiveScene(pub SceneSpec);

impl Plugin for VolcanoScenePlugin {
    fn build(&self, app: &mut App) {
        let spec = self.spec.clone();
        let terrain = self.terrain.clone();
        app.insert_resource(ActiveScene(spec.clone())).register_type::<ActiveScene>();
        // Harmless if the game adds it too, before or after.
        #[cfg(feature = "render")]
        if !self.headless {
            app.add_plugins(volcano_render::VolcanoSkyPlugin);
        }
        let headless = self.headless;
        if let Some(a) = &spec.atmosphere {
            atmosphere::build(app, a, &terrain);
        }
        app.add_systems(Startup, move |mut commands: Commands| {
            spawn_simulation(&mut commands, &spec, terrain.clone(), !headless);
            #[cfg(feature = "render")]
            if !headless {
                spawn_view(&mut commands, &spec);
            }
        });
    }
}

/// Spawns a scene's simulation: its terrain (with its far ring if `horizon` and the `render`
/// feature), its volcano with its eruption, and its lava field with its sources, not its
/// atmosphere, camera or sun. Returns the entities. The spec must have been validated.
pub(crate) fn spawn_simulation(
    commands: &mut Commands,
    spec: &SceneSpec,
    terrain: Terrain,
    horizon: bool,
) -> Vec<Entity> {
    let ground = commands.spawn((Name::new("Terrain"), terrain)).id();
    #[cfg(feature = "render")]
    if let Some(h) = spec.horizon.filter(|_| horizon) {
        commands.entity(ground).insert(h.component());
    }
    let _ = horizon;
    let mut spawned = vec![ground];
    // `build` cannot fail here: the spec was validated.
    if let Ok((volcano, transform)) = spec.volcano.build() {
        let mut e = commands.spawn((Name::new("Volcano"), volcano, transform));
        if let Some(preset) = spec.eruption {
            e.insert(preset.eruption());
        }
        // Validated with the scene.
        let vent_lava = spec.vent_lava.as_ref().and_then(|v| Some((v.vent().ok()?, v.settings().ok()?)));
        if let Some((vent, _)) = &vent_lava {
            e.insert(vent.clone());
        }
        if let Some(fountain) = spec.vent_lava.as_ref().and_then(|v| v.fountain().ok().flatten()) {
            e.insert(fountain);
        }
        let id = e.id();
        if let Some((_, settings)) = vent_lava {
            commands.insert_resource(settings);
        }
        spawned.push(id);
    }
    if let Some(lava) = &spec.lava {
        spawned.extend(lava.spawn(commands));
    }
    spawned
}

/// Runs built-in scene `name` in a window with `VolcanoPlugins`, the scene's sky and `extra`
/// (the examples pass `EguiPlugin`, `volcano_egui::EguiOverlayCameraPlugin` and the debug
/// panels; egui without the overlay draws nothing on the scene camera, which is HDR with
/// bloom, `volcano_render::GlowCamera`), at the thesis' fixed rate
/// (`THESIS_TICK_HZ`, the game's choice here). `VOLCANO_SCREENSHOT=out.png` (e.g. under
/// xvfb-run) takes a screenshot after 60 frames and exits. An unknown or invalid scene prints
/// the error and exits with an error code.
#[cfg(feature = "render")]
pub fn run_scene_window<M>(name: &str, extra: impl bevy::app::Plugins<M>) -> AppExit {
    let scene = match VolcanoScenePlugin::builtin(name) {
        Ok(scene) => scene,
        Err(e) => {
            eprintln!("error: {e}");
            return AppExit::error();
        }
    };
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window { title: format!("volcano: {name}"), ..default() }),
        ..default()
    }))
    .add_plugins((crate::VolcanoPlugins, scene))
    .add_plugins(extra)
    .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
    // HDR with bloom on the scene camera, as `volcano render` has: the examples draw their
    // panels on `volcano_egui::EguiOverlayCameraPlugin`'s camera (bevy_egui draws nothing on
    // an HDR camera).
    .add_observer(|add: On<Add, volcano_render::VolcanoViewer>, mut commands: Commands| {
        commands.entity(add.entity).insert(volcano_render::GlowCamera);
    });
    if let Some(capture) = volcano_render::WindowScreenshotPlugin::from_env() {
        app.add_plugins(capture);
    }
    app.run()
}

#[cfg(feature = "render")]
fn spawn_view(commands: &mut Commands, spec: &SceneSpec) {
    use volcano_render::sky::sun_cascades_for;
    use volcano_render::{OrbitCamera, Sun, camera_bundle, sun_bundle};
    let c = spec.camera;
    let orbit = OrbitCamera {
        focus: Vec3::new(c.focus.0, c.focus.1, c.focus.2),
        yaw: c.yaw_deg.to_radians(),
        pitch: c.pitch_deg.to_radians(),
        distance: c.distance,
        ..Default::default()
    };
    commands.spawn(camera_bundle(orbit));
    if let Some(sky) = spec.sky {
        // The scene plugin added `VolcanoSkyPlugin`, which owns the settings.
        commands.queue(move |world: &mut World| {
            if let Some(mut settings) = world.get_resource_mut::<volcano_render::SkySettings>() {
                sky.apply(&mut settings);
            }
        });
    }
    let s = spec.sun;
    commands
        .spawn(sun_bundle(Sun {
            azimuth_deg: s.azimuth_deg,
            elevation_deg: s.elevation_deg,
            illuminance: s.illuminance_lux,
        }))
        // Shadow texels to match the view: decimetres on a lava close-up (fold ropes).
        .insert(sun_cascades_for(c.distance));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_scenes_parse_and_validate() {
        for name in names() {
            let s = by_name(name).unwrap();
            assert_eq!(s.name, name);
        }
        let e = by_name("nope").unwrap_err();
        assert!(e.to_string().contains("eruption"), "{e}");
    }

    #[test]
    fn malformed_and_invalid_scenes_are_errors() {
        let good = include_str!("../assets/scenes/eruption.ron");
        let e = SceneSpec::from_ron(&good.replace("vent_radius: 100.0", "vent_radius: -1.0")).unwrap_err();
        assert!(e.to_string().contains("vent_radius"), "{e}");
        let mut spec = SceneSpec::from_ron(good).unwrap();
        spec.camera.pitch_deg = 95.0;
        let e = spec.validate().unwrap_err();
        assert!(e.to_string().contains("pitch_deg"), "{e}");
        assert!(VolcanoScenePlugin::new(spec).is_err());
        let e = SceneSpec::from_ron(&good.replace("cell: 40.0", "cell: 0.0")).unwrap_err();
        assert!(e.to_string().contains("cell"), "{e}");
        let e = SceneSpec::from_ron(&good[..good.len() / 2]).unwrap_err();
        assert!(matches!(e, ConfigError::Ron(_)), "{e}");
        let bad_map = TerrainSpec::Heightmap {
            path: "/nonexistent.png".into(),
            metres_per_unit: 1.0,
            base_altitude: 0.0,
            cell: 30.0,
            sea_level: 0.0,
        };
        assert!(matches!(bad_map.build(), Err(ConfigError::Io { .. })));
    }
}
