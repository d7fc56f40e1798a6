//! Offline export of a running volcano (docs/EXPORT.md): [`capture_frame`] reads a world's
//! plume, currents and atmosphere into OpenVDB grids and its lava into glTF meshes,
//! [`write_frame`] writes a frame folder's files (`frame_NNNN.vdb`, `frame_NNNN.glb` when
//! there is lava, `frame_NNNN.json`), [`capture_terrain`] and [`write_terrain`] the terrain
//! once (`terrain.glb`); each file is written whole or not at all. The command line is
//! `volcano export`; the writers and the splatting are the engine-free `volcano_export`
//! crate, re-exported here as [`vdb`], [`gltf`], [`splat`] and [`atomic`].
//!
//! Grids, in Bevy's world frame (metres, **y up**; `tools/blender_load.py` turns them z-up):
//! - `ash` (kg/m³): every sphere of the column, the umbrella and the pyroclastic currents, at
//!   every scale (s1, s2, s3, §3.3–3.5) and the ash clouds over the currents, splatted with
//!   their own radii at the density the renderer draws (a union: overlaps take the larger);
//! - `temperature` (K): the gas of the column's slices and of the currents, on the `ash`
//!   voxels they cover (the hotter where they overlap); umbrella and clouds have none;
//! - `cloud` (g/m³): the atmosphere's condensed water amplified onto voxels, as the cloud pass
//!   draws it (thesis §4.2.6);
//! - `ash_fall` (kg/m³): the ash the air carries (the coupling's tracer), on the same voxels;
//! - `air_temperature` (K): the layers' temperature on the same voxels, every voxel of the
//!   box (read between the layers as the ash is).

use std::path::{Path, PathBuf};

use bevy::prelude::*;
use serde::Serialize;
use volcano_atmosphere::view::{AtmosphereState, VolumeSpec, ash_at, cloud_density, layer_blend};
use volcano_atmosphere::{AirLayer, Atmosphere};
use volcano_core::ConfigError;
use volcano_core::error::in_range;
use volcano_plume::components::{PlumeSlice, S1};
use volcano_plume::pyroclastic::PyroParticle;
use volcano_plume::view::{for_each_sphere, gather_parents};

pub use volcano_export::{atomic, gltf, splat, vdb};

mod meshes;
pub use meshes::{fold_lines, lava_mesh, lava_meshes, terrain_mesh};

use gltf::{GltfError, LineData, MeshData};

use splat::{Combine, Fill, Sphere, splat_spheres};
use vdb::{FloatGrid, GridClass, MetaValue, Transform, VdbError};

/// How finely a frame is voxelised.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize)]
pub struct ExportSettings {
    /// Voxel edge of the `ash` and `temperature` grids (m).
    pub ash_voxel_m: f64,
    /// Voxel edge of the `cloud`, `ash_fall` and `air_temperature` grids (m).
    pub air_voxel_m: f64,
    /// Include the s2 and s3 detail spheres (the lobes of the look); without them the spheres
    /// are the s1 and umbrella parents only.
    pub detail_spheres: bool,
    /// Most active voxels in one grid (4 bytes each in memory and on disk): a frame that
    /// would need more is an error naming the grid, not an exhausted machine.
    pub max_voxels: u64,
    /// Cloud forms: k-means clusters and fragmentation threshold (as the cloud pass,
    /// `CloudRenderSettings`).
    pub cloud_clusters: usize,
    /// See `cloud_clusters`.
    pub cloud_fragmentation: f64,
    /// Most samples along a side of the terrain mesh (every n-th height is kept above it).
    pub terrain_max_side: usize,
}

impl Default for ExportSettings {
    fn default() -> Self {
        Self {
            ash_voxel_m: 50.0,
            air_voxel_m: 250.0,
            detail_spheres: true,
            max_voxels: 60_000_000,
            cloud_clusters: 8,
            cloud_fragmentation: 0.3,
            terrain_max_side: 513,
        }
    }
}

impl ExportSettings {
    /// Voxels of 0.5 m to 10 km, a budget of at least one voxel, 1 to 64 clusters, a
    /// fragmentation in [0, 1], a terrain mesh of 2 to 8,193 samples a side.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("ash_voxel_m", self.ash_voxel_m, 0.5, 10_000.0)?;
        in_range("air_voxel_m", self.air_voxel_m, 0.5, 10_000.0)?;
        in_range("max_voxels", self.max_voxels as f64, 1.0, f64::MAX)?;
        in_range("cloud_clusters", self.cloud_clusters as f64, 1.0, 64.0)?;
        in_range("cloud_fragmentation", self.cloud_fragmentation, 0.0, 1.0)?;
        in_range("terrain_max_side", self.terrain_max_side as f64, 2.0, 8_193.0)?;
        Ok(())
    }
}

/// What can stop an export.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// A setting out of range.
    #[error("export settings: {0}")]
    Settings(#[from] ConfigError),
    /// A grid could not be built or written.
    #[error("{0}")]
    Volume(#[from] VdbError),
    /// A mesh could not be written.
    #[error("{0}")]
    Mesh(#[from] GltfError),
    /// A file could not be created, flushed or renamed (nothing was left at its path).
    #[error("{0}")]
    File(#[from] atomic::FileError),
    /// The frame's JSON could not be written.
    #[error("cannot write {path}: {message}")]
    Json {
        /// The file.
        path: String,
        /// Why.
        message: String,
    },
}

/// The camera a frame was seen from (world, y up).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CameraView {
    /// Eye position (m).
    pub position: [f32; 3],
    /// Orientation `[x, y, z, w]`; the camera looks along its −z, y up (Bevy's convention).
    pub rotation: [f32; 4],
    /// Vertical field of view (degrees).
    pub vertical_fov_deg: f32,
}

/// The sun of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SunView {
    /// Unit vector from the ground towards the sun (world, y up).
    pub direction: [f32; 3],
    /// Illuminance on a surface facing it (lux).
    pub illuminance_lux: f32,
}

/// Camera and sun, written with a frame for the offline scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct FrameView {
    /// The camera, if known.
    pub camera: Option<CameraView>,
    /// The sun, if known.
    pub sun: Option<SunView>,
}

#[cfg(feature = "render")]
impl FrameView {
    /// A built-in scene's gallery camera (its orbit, 50° vertical field of view as
    /// `volcano_render::camera_bundle`) and sun.
    pub fn of_scene(spec: &crate::scenes::SceneSpec) -> Self {
        let c = spec.camera;
        let orbit = volcano_render::OrbitCamera {
            focus: Vec3::new(c.focus.0, c.focus.1, c.focus.2),
            yaw: c.yaw_deg.to_radians(),
            pitch: c.pitch_deg.to_radians(),
            distance: c.distance,
            ..Default::default()
        };
        let t = orbit.transform();
        let s = spec.sun;
        let sun = volcano_render::Sun {
            azimuth_deg: s.azimuth_deg,
            elevation_deg: s.elevation_deg,
            illuminance: s.illuminance_lux,
        };
        Self {
            camera: Some(CameraView {
                position: t.translation.to_array(),
                rotation: t.rotation.to_array(),
                vertical_fov_deg: volcano_render::CAMERA_FOV_DEG,
            }),
            sun: Some(SunView { direction: sun.direction().to_array(), illuminance_lux: s.illuminance_lux }),
        }
    }
}

/// One grid's entry in a frame's JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GridInfo {
    /// Grid name in the `.vdb`.
    pub name: String,
    /// Units of its values.
    pub units: &'static str,
    /// Voxel edge (m).
    pub voxel_m: f64,
    /// Active voxels.
    pub active_voxels: u64,
    /// World bounds of the active voxels' centres `[min, max]` (m), if any.
    pub bounds_m: Option<[[f64; 3]; 2]>,
}

/// What a frame's JSON holds beside its grids.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FrameInfo {
    /// Simulated time of the frame (s since the start).
    pub time_s: f64,
    /// Base tick (`SimTick`).
    pub tick: u64,
    /// Which world axis is up (`"y"`: Bevy's frame).
    pub up: &'static str,
    /// Camera and sun.
    pub view: FrameView,
    /// The grids of the `.vdb`.
    pub grids: Vec<GridInfo>,
    /// Meshes and line sets of the frame's `.glb` (none: no `.glb`).
    pub meshes: Vec<String>,
    /// Spheres splatted into `ash`.
    pub spheres: u64,
    /// Spheres skipped (non-finite or empty).
    pub skipped_spheres: u64,
    /// The settings the frame was made with.
    pub settings: ExportSettings,
}

/// A captured frame: its grids and what its JSON says.
#[derive(Debug, Clone)]
pub struct ExportFrame {
    /// `ash`, `temperature`, and `cloud`, `ash_fall`, `air_temperature` when the world has an
    /// atmosphere.
    pub grids: Vec<FloatGrid>,
    /// Lava surfaces.
    pub meshes: Vec<MeshData>,
    /// Fold ropes.
    pub lines: Vec<LineData>,
    /// The JSON side.
    pub info: FrameInfo,
}

/// Reads the world's plume spheres, pyroclastic currents, atmosphere and lava into a frame.
pub fn capture_frame(
    world: &mut World,
    settings: &ExportSettings,
    view: FrameView,
) -> Result<ExportFrame, ExportError> {
    settings.validate()?;
    // The volcano's own clock: base ticks run times the timestep and the simulation speed,
    // not the game's fixed clock (a paused or sped-up volcano differs from it).
    let time_s =
        world.get_resource::<volcano_core::SimControl>().map_or(0.0, |c| c.simulated().as_secs_f64());
    let tick = world.get_resource::<volcano_core::SimTick>().map_or(0, |t| t.0);
    let (mut grids, spheres, skipped) = column_grids(world, settings)?;
    grids.extend(air_grids(world, settings)?);
    for g in &mut grids {
        g.prune();
        g.insert_meta("volcano_time_s", MetaValue::Double(time_s))?;
        g.insert_meta("volcano_up_axis", MetaValue::String("y".into()))?;
    }
    let (meshes, lines) = lava_meshes(world);
    let info = FrameInfo {
        time_s,
        tick,
        up: "y",
        view,
        grids: grids.iter().map(grid_info).collect(),
        meshes: meshes.iter().map(|m| m.name.clone()).chain(lines.iter().map(|l| l.name.clone())).collect(),
        spheres,
        skipped_spheres: skipped,
        settings: settings.clone(),
    };
    Ok(ExportFrame { grids, meshes, lines, info })
}

fn units(name: &str) -> &'static str {
    match name {
        "ash" | "ash_fall" => "kg/m^3",
        "temperature" | "air_temperature" => "K",
        "cloud" => "g/m^3",
        _ => "",
    }
}

fn grid_info(g: &FloatGrid) -> GridInfo {
    let t = g.transform();
    GridInfo {
        name: g.name().to_owned(),
        units: units(g.name()),
        voxel_m: t.voxel_size(),
        active_voxels: g.active_voxel_count(),
        bounds_m: g.active_bbox().map(|(lo, hi)| [t.index_to_world(lo), t.index_to_world(hi)]),
    }
}

fn new_grid(name: &str, class: GridClass, voxel: f64, translation: [f64; 3]) -> Result<FloatGrid, VdbError> {
    let mut g = FloatGrid::new(name, class, Transform::new(voxel, translation)?)?;
    g.insert_meta("units", MetaValue::String(units(name).into()))?;
    Ok(g)
}

/// `ash` and `temperature` from every sphere (with the gas temperature of the slice or
/// current a sphere belongs to).
fn column_grids(
    world: &mut World,
    settings: &ExportSettings,
) -> Result<(Vec<FloatGrid>, u64, u64), VdbError> {
    use bevy::platform::collections::HashMap;
    // Parents are told apart by (volcano, current or not, id): ids are per volcano, and a
    // particle's and an s1 sphere's come from different counters.
    let slices: HashMap<Entity, (Entity, f64)> = world
        .query::<(Entity, &PlumeSlice)>()
        .iter(world)
        .map(|(e, s)| (e, (s.volcano, s.state.temperature)))
        .collect();
    let mut temperature_of: HashMap<(Entity, bool, u64), f32> = world
        .query::<&S1>()
        .iter(world)
        .filter_map(|s| slices.get(&s.slice).map(|&(v, t)| ((v, false, s.id), t as f32)))
        .collect();
    temperature_of.extend(
        world
            .query::<&PyroParticle>()
            .iter(world)
            .map(|p| ((p.volcano, true, p.id), p.particle.temperature as f32)),
    );
    let (eruptions, parents) = gather_parents(world);

    let h = settings.ash_voxel_m;
    let mut ash = new_grid("ash", GridClass::FogVolume, h, [0.0; 3])?;
    let mut temperature = new_grid("temperature", GridClass::Unknown, h, [0.0; 3])?;
    let (mut ash_spheres, mut hot_spheres) = (Vec::new(), Vec::new());
    for p in &parents {
        let volcano = eruptions.get(p.eruption).map(|e| e.entity);
        let temp = match (p.umbrella || p.cloud, volcano) {
            (false, Some(v)) => temperature_of.get(&(v, p.flow, p.id)).copied(),
            _ => None,
        };
        let mut add = |center: bevy::math::DVec3, radius: f64, density: f64| {
            let c = center.to_array();
            ash_spheres.push(Sphere { center: c, radius, density: density as f32 });
            if let Some(t) = temp {
                hot_spheres.push(Sphere { center: c, radius, density: t });
            }
        };
        if settings.detail_spheres {
            for_each_sphere(&eruptions, std::slice::from_ref(p), |s| add(s.center, s.radius, s.density));
        } else {
            add(p.center.as_dvec3(), p.radius as f64, p.density as f64);
        }
    }
    let r = splat_spheres(&mut ash, ash_spheres, Fill::Density, Combine::Max, settings.max_voxels)?;
    splat_spheres(&mut temperature, hot_spheres, Fill::Value, Combine::Max, settings.max_voxels)?;
    Ok((vec![ash, temperature], r.spheres, r.skipped))
}

/// The first atmosphere's state, rebuilt from its entity and layers.
fn atmosphere_state(world: &mut World) -> Option<(AtmosphereState, f64)> {
    let mut atmospheres = world.query::<(Entity, &Atmosphere)>();
    let (entity, atmo) = atmospheres.iter(world).min_by_key(|(e, _)| *e)?;
    let shell = atmo.state_shell().ok()?;
    let threshold = atmo.params.cloud_threshold;
    let mut layers: Vec<&AirLayer> =
        world.query::<&AirLayer>().iter(world).filter(|l| l.atmosphere == entity).collect();
    layers.sort_by_key(|l| l.index);
    let layers = layers.iter().map(|l| (*l.fields).clone()).collect();
    Some((AtmosphereState { layers, ..shell }, threshold))
}

/// `cloud`, `ash_fall` and `air_temperature` on cubic voxels over the atmosphere's
/// footprint, from its lowest layer's floor to one thickness above its top layer (where the
/// cloud pass draws).
fn air_grids(world: &mut World, settings: &ExportSettings) -> Result<Vec<FloatGrid>, ExportError> {
    let Some((state, threshold)) = atmosphere_state(world) else { return Ok(Vec::new()) };
    let extent = state.grid.extent();
    let nxy = ((extent / settings.air_voxel_m).round() as usize).max(1);
    let h = extent / nxy as f64;
    let z_min = state.layers.first().map_or(0.0, |l| l.bottom.max(0.0));
    let z_top = state.layers.last().map_or(1000.0, |l| l.altitude + l.thickness);
    let nz = (((z_top - z_min) / h).ceil() as usize).max(1);
    // `air_temperature` fills the box: every air grid fits the budget if the box does.
    if (nxy * nxy * nz) as u64 > settings.max_voxels {
        return Err(
            VdbError::TooManyVoxels { grid: "air_temperature".into(), limit: settings.max_voxels }.into()
        );
    }
    let spec = VolumeSpec { nxy, nz, z_min, z_max: z_min + nz as f64 * h, seed: 7 };
    let mut memory = Default::default();
    let water = cloud_density(
        &state,
        threshold,
        settings.cloud_clusters,
        settings.cloud_fragmentation,
        &mut memory,
        &spec,
    );
    // Voxel (ix, jy, iz) of the volume (x fastest, then the grid's y = world z, then altitude)
    // is VDB voxel (ix, iz, jy) at world (x, altitude, z).
    let origin = [-0.5 * extent + 0.5 * h, z_min + 0.5 * h, -0.5 * extent + 0.5 * h];
    let mut cloud = new_grid("cloud", GridClass::FogVolume, h, origin)?;
    let mut ash_fall = new_grid("ash_fall", GridClass::FogVolume, h, origin)?;
    let mut air_temperature = new_grid("air_temperature", GridClass::Unknown, h, origin)?;
    let layers: Vec<&volcano_atmosphere::LayerFields> = state.layers.iter().collect();
    for iz in 0..nz {
        for jy in 0..nxy {
            for ix in 0..nxy {
                let ijk = [ix as i32, iz as i32, jy as i32];
                let w = water[(iz * nxy + jy) * nxy + ix];
                let [x, y, z] = cloud.transform().index_to_world(ijk);
                let xz = Vec2::new(x as f32, z as f32);
                // g/m³ → kg/m³.
                let a = (ash_at(&layers, xz.x, y, xz.y) * 1e-3) as f32;
                let t = air_temperature_at(&layers, xz, y);
                for (g, v) in [(&mut cloud, w), (&mut ash_fall, a), (&mut air_temperature, t)] {
                    if v > 0.0 {
                        g.set(ijk, v)?;
                    }
                }
            }
        }
    }
    Ok(vec![cloud, ash_fall, air_temperature])
}

/// The air's temperature (K) at world `(x, z)` = `xz` and `altitude`, read as the ash is
/// ([`layer_blend`]: linear between adjacent layers' centres, bilinear in each layer's field);
/// 0 outside the stack.
fn air_temperature_at(layers: &[&volcano_atmosphere::LayerFields], xz: Vec2, altitude: f64) -> f32 {
    let Some((lo, hi, w)) = layer_blend(layers, altitude) else { return 0.0 };
    let at = |k: usize| layers[k].t.sample(xz, volcano_core::Boundary::Clamp);
    let (a, b) = (at(lo), at(hi));
    (a as f64 + (b as f64 - a as f64) * w) as f32
}

/// The first terrain's mesh (entity order), `None` without a terrain.
pub fn capture_terrain(
    world: &mut World,
    settings: &ExportSettings,
) -> Result<Option<MeshData>, ExportError> {
    settings.validate()?;
    let mut q = world.query::<(Entity, &volcano_core::Terrain)>();
    Ok(q.iter(world).min_by_key(|(e, _)| *e).map(|(_, t)| terrain_mesh(t, settings.terrain_max_side)))
}

/// Writes `dir/terrain.glb`; returns its path.
pub fn write_terrain(dir: &Path, terrain: &MeshData) -> Result<PathBuf, ExportError> {
    let path = dir.join("terrain.glb");
    gltf::write_glb_file(&path, std::slice::from_ref(terrain), &[])?;
    Ok(path)
}

/// The files of frame `index` in `dir`: its `.vdb` and its `.json` (and its `.glb` beside them
/// when it has lava).
pub fn frame_paths(dir: &Path, index: u32) -> (PathBuf, PathBuf) {
    (dir.join(format!("frame_{index:04}.vdb")), dir.join(format!("frame_{index:04}.json")))
}

/// Writes frame `index` of `dir`: its grids as `frame_NNNN.vdb`, its lava as `frame_NNNN.glb`
/// (if it has any) and its [`FrameInfo`] as `frame_NNNN.json`, each through a temporary file
/// renamed when complete.
pub fn write_frame(dir: &Path, index: u32, frame: &ExportFrame) -> Result<(PathBuf, PathBuf), ExportError> {
    let (vdb_path, json_path) = frame_paths(dir, index);
    let grids: Vec<&FloatGrid> = frame.grids.iter().collect();
    let file_meta = [("creator", MetaValue::String(format!("volcano {}", env!("CARGO_PKG_VERSION"))))];
    vdb::write_vdb_file(&vdb_path, &grids, &file_meta)?;
    if !frame.meshes.is_empty() || !frame.lines.is_empty() {
        gltf::write_glb_file(&vdb_path.with_extension("glb"), &frame.meshes, &frame.lines)?;
    }
    let text = serde_json::to_string_pretty(&frame.info)
        .map_err(|e| ExportError::Json { path: json_path.display().to_string(), message: e.to_string() })?;
    atomic::write_atomically::<ExportError>(&json_path, |w| {
        use std::io::Write;
        w.write_all(text.as_bytes()).map_err(|e| VdbError::Io(e).into())
    })?;
    Ok((vdb_path, json_path))
}
