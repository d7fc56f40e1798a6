//! The ash volume rebuild off the main thread ([`AshFallSettings::off_thread`]). When an
//! atmosphere's weather time moves (a weather step was written back) or the settings change,
//! the main thread takes an [`AshSnapshot`] (the layers' fields shared, not copied; the ground
//! heights copied) and starts [`build_ash`] on it on Bevy's `AsyncComputeTaskPool`; the task
//! copies the fields and lets go of them first, then builds the density image (tens of ms at
//! the default 128² × 64 voxels, `cargo bench -p volcano_render --bench ash_volume`), which
//! replaces the old one in the first `PostUpdate` after it has finished.
//!
//! Content is deterministic, timing is not: the image is a function of the snapshot and the
//! settings only (tested equal to the synchronous build), but when it appears depends on the
//! worker. One build per atmosphere runs at a time; weather steps that land while one runs are
//! not built on their own, the next build takes the newest state. The ash volume is
//! render-only: nothing in the simulation reads it. The same scheme as the clouds'
//! (`crate::clouds::rebuild`), which also cluster; the two share no state.

use std::sync::Arc;

use bevy::light::{NotShadowCaster, NotShadowReceiver};
use bevy::prelude::*;
use volcano_atmosphere::plugin::AtmosphereGround;
use volcano_atmosphere::view::GridSpec;
use volcano_atmosphere::{AirLayer, Atmosphere, LayerFields};
use volcano_core::{ConfigError, Grid2};

use super::{AshFallDraw, AshFallSettings, AshFallVolume, airborne_grams, ash_material, build_ash_image};
use crate::build_job::{BuildJob, is_running, take_finished};
use crate::clouds::CloudMaterial;

/// What a rebuild reads: an atmosphere's layers (sorted by index, shared copy-on-write) and
/// the terrain under it.
#[derive(Debug, Clone)]
pub struct AshSnapshot {
    layers: Vec<Arc<LayerFields>>,
    ground: Option<Grid2<f32>>,
    grid: Result<GridSpec, ConfigError>,
    time_s: f64,
}

impl AshSnapshot {
    /// Takes the snapshot of `atmo` from its `layers` (any order) and `ground`.
    pub fn new(atmo: &Atmosphere, layers: &[&AirLayer], ground: Option<&Grid2<f32>>) -> Self {
        let mut sorted = layers.to_vec();
        sorted.sort_by_key(|l| l.index);
        Self {
            layers: sorted.iter().map(|l| l.fields.share()).collect(),
            ground: ground.cloned(),
            grid: GridSpec::new(atmo.n, atmo.dx),
            time_s: atmo.time_s,
        }
    }
}

/// What a rebuild produces.
pub struct BuiltAsh {
    /// Density image, box transform and filled fraction; `None` when the layers hold less
    /// than [`AshFallSettings::min_grams`] (or the drawing is off); or why it failed.
    pub result: Result<Option<(Image, Transform, f32)>, ConfigError>,
    /// Ash in the layers (g).
    pub airborne_g: f64,
    /// Weather time of the snapshot (s).
    pub time_s: f64,
    /// The settings it was built with.
    pub settings: AshFallSettings,
}

/// Builds the ash volume of a snapshot (what the task runs; also callable directly).
pub fn build_ash(snapshot: AshSnapshot, settings: AshFallSettings) -> BuiltAsh {
    let AshSnapshot { layers, ground, grid, time_s } = snapshot;
    // Copy the fields and let go of the shared ones at once: a write to a layer while they
    // are held would copy it on the main thread.
    let owned: Vec<LayerFields> = layers.iter().map(|l| (**l).clone()).collect();
    drop(layers);
    let fields: Vec<&LayerFields> = owned.iter().collect();
    let (airborne_g, result) = match grid {
        Err(e) => (0.0, Err(e)),
        Ok(grid) => {
            let grams = airborne_grams(&fields, grid.dx);
            let result = if settings.enabled && grams >= settings.min_grams {
                build_ash_image(&fields, grid, ground.as_ref(), &settings).map(Some)
            } else {
                Ok(None)
            };
            (grams, result)
        }
    };
    BuiltAsh { result, airborne_g, time_s, settings }
}

/// On an [`Atmosphere`] entity once its ash has been looked at (not reflected: it holds a
/// task): the build in flight, and what the last one was started from.
#[derive(Component)]
pub struct AshFallBuild {
    job: Option<BuildJob<BuiltAsh>>,
    /// Weather time (s) of the last snapshot.
    snapshot_s: f64,
    /// The settings of the last snapshot.
    settings: AshFallSettings,
}

impl AshFallBuild {
    /// Whether a build runs on a worker (false once finished or when built inline).
    pub fn running(&self) -> bool {
        is_running(&self.job)
    }
}

/// Counts of ash volume rebuilds (diagnostics, tests).
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct AshFallBuildStatus {
    /// Builds started.
    pub started: u64,
    /// Of those, built on the main thread (`off_thread` off, or no task pool).
    pub on_main_thread: u64,
    /// Builds finished and applied (an image, or the volume hidden for lack of ash).
    pub applied: u64,
}

/// Starts a rebuild for every atmosphere whose weather time or ash settings moved since its
/// last snapshot and that has none running; hides the volumes at once when drawing is off.
pub(super) fn start_ash_builds(
    mut commands: Commands,
    settings: Res<AshFallSettings>,
    materials: Option<Res<Assets<CloudMaterial>>>,
    mut status: ResMut<AshFallBuildStatus>,
    mut atmospheres: Query<(Entity, &Atmosphere, Option<&AshFallVolume>, Option<&mut AshFallBuild>)>,
    (grounds, layers): (Query<&AtmosphereGround>, Query<&AirLayer>),
    mut draws: Query<&mut Visibility, With<AshFallDraw>>,
) {
    if materials.is_none() {
        if settings.enabled && !atmospheres.is_empty() {
            warn_once!("ash fall not drawn: it needs CloudRenderPlugin (its lit pass draws the ash)");
        }
        return;
    }
    for (entity, atmo, volume, mut build) in &mut atmospheres {
        if !settings.enabled {
            if let Some(v) = volume
                && let Ok(mut vis) = draws.get_mut(v.draw)
            {
                vis.set_if_neq(Visibility::Hidden);
            }
            // Turning the drawing on again then counts as a change and rebuilds.
            if let Some(b) = build.as_mut() {
                b.settings.enabled = false;
            }
            continue;
        }
        let stale = build.as_ref().is_none_or(|b| b.snapshot_s != atmo.time_s || b.settings != *settings);
        if !stale || build.as_ref().is_some_and(|b| b.job.is_some()) {
            continue;
        }
        let mine: Vec<&AirLayer> = layers.iter().filter(|l| l.atmosphere == entity).collect();
        let ground = grounds.get(entity).ok().map(|g| &g.0.height);
        let snapshot = AshSnapshot::new(atmo, &mine, ground);
        let s = settings.clone();
        let (job, inline) = BuildJob::start(settings.off_thread, move || build_ash(snapshot, s));
        status.started += 1;
        status.on_main_thread += u64::from(inline);
        match build {
            Some(mut b) => {
                b.job = Some(job);
                b.snapshot_s = atmo.time_s;
                b.settings = settings.clone();
            }
            None => {
                commands.entity(entity).insert(AshFallBuild {
                    job: Some(job),
                    snapshot_s: atmo.time_s,
                    settings: settings.clone(),
                });
            }
        }
    }
}

/// The asset stores a rebuild writes to: density images, the pass's materials, box meshes.
type AshAssets<'w> =
    (ResMut<'w, Assets<Image>>, Option<ResMut<'w, Assets<CloudMaterial>>>, ResMut<'w, Assets<Mesh>>);

/// Applies every finished rebuild: replaces the density image and the material (or spawns the
/// box for a new atmosphere), or hides the box when the layers hold too little ash.
#[expect(clippy::too_many_arguments, reason = "one system keeping every atmosphere's ash box in step")]
pub(super) fn apply_ash_builds(
    mut commands: Commands,
    current: Res<AshFallSettings>,
    mut status: ResMut<AshFallBuildStatus>,
    mut atmospheres: Query<(Entity, &mut AshFallBuild, Option<&AshFallVolume>)>,
    mut draws: Query<(&mut Transform, &mut Visibility), With<AshFallDraw>>,
    (mut images, materials, mut meshes): AshAssets,
    mut removed: RemovedComponents<Atmosphere>,
    orphans: Query<(Entity, &AshFallDraw)>,
) {
    for gone in removed.read() {
        for (draw, owner) in &orphans {
            if owner.atmosphere == gone {
                commands.entity(draw).despawn();
            }
        }
    }
    let Some(mut materials) = materials else { return };
    for (entity, mut build, volume) in &mut atmospheres {
        let Some(built) = take_finished(&mut build.job) else { continue };
        status.applied += 1;
        let BuiltAsh { result, airborne_g, time_s, settings } = built;
        let shown = match result {
            Ok(shown) => shown,
            Err(e) => {
                warn_once!("ash fall of {entity} not rendered: {e}");
                None
            }
        };
        // Drawing turned off while the build ran: keep the box hidden.
        let visible = shown.is_some() && current.enabled;
        if let Some(v) = volume
            && let Ok((_, mut vis)) = draws.get_mut(v.draw)
        {
            vis.set_if_neq(if visible { Visibility::Inherited } else { Visibility::Hidden });
        }
        let Some((image, transform, filled)) = shown else { continue };
        match volume {
            Some(v) => {
                // A new image under a new handle, as for the clouds (`clouds::rebuild`): the
                // twin drawn in front of the ash follows the material's new handle.
                let image = images.add(image);
                if materials
                    .insert(v.material.id(), ash_material(image.clone(), &transform, &settings))
                    .is_err()
                {
                    warn_once!("ash material of {entity} could not be replaced");
                }
                if let Ok((mut t, _)) = draws.get_mut(v.draw) {
                    *t = transform;
                }
                commands.entity(entity).insert(AshFallVolume {
                    image,
                    built_at_s: time_s,
                    airborne_g,
                    filled_fraction: filled,
                    ..v.clone()
                });
            }
            None => {
                let handle = images.add(image);
                let material = materials.add(ash_material(handle.clone(), &transform, &settings));
                let draw = commands
                    .spawn((
                        Name::new("Ash fall"),
                        AshFallDraw { atmosphere: entity },
                        Mesh3d(meshes.add(Cuboid::new(1.0, 1.0, 1.0))),
                        MeshMaterial3d(material.clone()),
                        transform,
                        if visible { Visibility::Inherited } else { Visibility::Hidden },
                        NotShadowCaster,
                        NotShadowReceiver,
                    ))
                    .id();
                commands.entity(entity).insert(AshFallVolume {
                    draw,
                    image: handle,
                    material,
                    built_at_s: time_s,
                    airborne_g,
                    filled_fraction: filled,
                });
            }
        }
    }
}

#[cfg(test)]
#[path = "rebuild_tests.rs"]
mod tests;
