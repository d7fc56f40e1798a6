//! The cloud volume rebuild off the main thread. When an atmosphere's weather time moves (a
//! weather step was written back), a layer is edited or the [`CloudRenderSettings`] change,
//! the main thread takes a snapshot of the layers ([`cloud_state`]: their fields shared, copied
//! by the task) and the previous k-means clustering, and starts [`build_cloud_image`] on them on Bevy's
//! `AsyncComputeTaskPool`. The clustering memory travels with the task and comes back with the
//! image, which replaces the old one in the first `PostUpdate` after the task has finished.
//!
//! Content is deterministic, timing is not: the image built from a snapshot is a function of
//! that snapshot, the settings and the clustering memory of the previous build only (tested
//! equal to the synchronous build), but when it appears depends on the worker. One build per
//! atmosphere runs at a time; weather steps that land while one runs are not built on their
//! own — the next build takes the newest state (as the synchronous rebuild skipped steps when
//! several landed in one frame), so a slow machine may chain the clustering memory through
//! fewer steps than a fast one. Clouds are render-only: nothing in the simulation reads them.

use bevy::light::{NotShadowCaster, NotShadowReceiver};
use bevy::prelude::*;
use volcano_atmosphere::view::ClusterMemory;
use volcano_atmosphere::{AirLayer, Atmosphere};
use volcano_core::ConfigError;

use super::material::box_transform;
use super::{
    CloudDraw, CloudMaterial, CloudRenderSettings, CloudSnapshot, CloudVolume, build_cloud_image,
    cloud_material, cloud_state,
};
use crate::build_job::{BuildJob, is_running, take_finished};

/// What a rebuild produces, with the memory and inputs it was made from.
pub struct BuiltClouds {
    /// Density image, fog transform and filled fraction (or why it failed).
    pub result: Result<(Image, Transform, f32), ConfigError>,
    /// The clustering of this build, which the next one starts from.
    pub memory: ClusterMemory,
    /// Weather time of the snapshot (s).
    pub time_s: f64,
    /// The settings it was built with.
    pub settings: CloudRenderSettings,
}

/// Builds the clouds of a snapshot (what the task runs; also callable directly).
pub fn build_clouds(
    snapshot: CloudSnapshot,
    settings: CloudRenderSettings,
    cloud_threshold: f64,
    mut memory: ClusterMemory,
    time_s: f64,
) -> BuiltClouds {
    let state = snapshot.into_state();
    let result = build_cloud_image(&state, &settings, cloud_threshold, &mut memory);
    BuiltClouds { result, memory, time_s, settings }
}

/// On an [`Atmosphere`] entity while its cloud rebuild runs (not reflected: it holds a task).
#[derive(Component)]
pub struct CloudBuild {
    job: Option<BuildJob<BuiltClouds>>,
    /// A layer was edited after the snapshot: build again when this one is applied.
    restart: bool,
}

impl CloudBuild {
    /// Whether the build runs on a worker (false once finished or when built inline).
    pub fn running(&self) -> bool {
        is_running(&self.job)
    }
}

/// Marks an atmosphere whose clouds must be rebuilt although its weather time has not moved.
#[derive(Component)]
pub(super) struct CloudStale;

/// Counts of cloud rebuilds (diagnostics, tests).
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct CloudBuildStatus {
    /// Builds started.
    pub started: u64,
    /// Of those, built on the main thread (`off_thread` off, or no task pool).
    pub on_main_thread: u64,
    /// Builds whose image was applied.
    pub applied: u64,
}

/// Starts a rebuild for every atmosphere whose clouds are stale and that has none running.
#[expect(clippy::type_complexity, reason = "one query over the atmospheres and their builds")]
pub(super) fn start_cloud_builds(
    mut commands: Commands,
    settings: Res<CloudRenderSettings>,
    mut status: ResMut<CloudBuildStatus>,
    mut atmospheres: Query<(
        Entity,
        &Atmosphere,
        Option<&mut CloudVolume>,
        Option<&mut CloudBuild>,
        Has<CloudStale>,
    )>,
    layers: Query<Ref<AirLayer>>,
    mut draws: Query<&mut Visibility, With<CloudDraw>>,
) {
    for (entity, atmo, mut volume, build, marked) in &mut atmospheres {
        let mine: Vec<Ref<AirLayer>> = layers.iter().filter(|l| l.atmosphere == entity).collect();
        // `is_added` counts as changed: skip the layers' first frame when the volume was built
        // for the same weather time.
        let changed = mine.iter().any(|l| l.is_changed() && !l.is_added());
        let stale = marked
            || match &volume {
                None => true,
                Some(v) => changed || v.built_at_s != atmo.time_s || v.settings != *settings,
            };
        if !stale {
            continue;
        }
        if let Some(v) = &volume
            && let Ok(mut vis) = draws.get_mut(v.draw)
        {
            vis.set_if_neq(if settings.enabled { Visibility::Inherited } else { Visibility::Hidden });
        }
        if !settings.enabled {
            continue;
        }
        if let Some(mut b) = build {
            b.restart |= changed;
            continue;
        }
        if let Err(e) = settings.validate() {
            warn_once!("clouds not rendered: {e}");
            continue;
        }
        let refs: Vec<&AirLayer> = mine.iter().map(|l| &**l).collect();
        let state = match cloud_state(atmo, &refs) {
            Ok(s) => s,
            Err(e) => {
                warn_once!("clouds of {entity} not rendered: {e}");
                continue;
            }
        };
        let memory = volume.as_mut().map(|v| std::mem::take(&mut v.memory)).unwrap_or_default();
        let (s, threshold, time) = (settings.clone(), atmo.params.cloud_threshold, atmo.time_s);
        let (job, inline) =
            BuildJob::start(settings.off_thread, move || build_clouds(state, s, threshold, memory, time));
        status.started += 1;
        status.on_main_thread += u64::from(inline);
        commands.entity(entity).remove::<CloudStale>().insert(CloudBuild { job: Some(job), restart: false });
    }
}

/// The asset stores a rebuild writes to: density images, cloud materials, box meshes.
type CloudAssets<'w> =
    (ResMut<'w, Assets<Image>>, ResMut<'w, Assets<CloudMaterial>>, ResMut<'w, Assets<Mesh>>);

/// Applies every finished rebuild: replaces the density image and the material (or spawns
/// the box for a new atmosphere), hands the clustering memory back to the [`CloudVolume`].
pub(super) fn apply_cloud_builds(
    mut commands: Commands,
    mut status: ResMut<CloudBuildStatus>,
    mut atmospheres: Query<(Entity, &mut CloudBuild, Option<&mut CloudVolume>)>,
    mut draws: Query<&mut Transform, With<CloudDraw>>,
    (mut images, mut materials, mut meshes): CloudAssets,
    mut removed: RemovedComponents<Atmosphere>,
    orphans: Query<(Entity, &CloudDraw)>,
) {
    for gone in removed.read() {
        for (fog, owner) in &orphans {
            if owner.atmosphere == gone {
                commands.entity(fog).despawn();
            }
        }
    }
    for (entity, mut build, volume) in &mut atmospheres {
        let Some(built) = take_finished(&mut build.job) else { continue };
        let mut e = commands.entity(entity);
        e.remove::<CloudBuild>();
        if build.restart {
            e.insert(CloudStale);
        }
        let BuiltClouds { result, memory, time_s, settings } = built;
        let (image, transform, filled) = match result {
            Ok(b) => b,
            Err(err) => {
                warn_once!("clouds of {entity} not rendered: {err}");
                if let Some(mut v) = volume {
                    v.memory = memory;
                    v.built_at_s = time_s;
                    v.settings = settings;
                }
                continue;
            }
        };
        status.applied += 1;
        debug!("clouds of {entity} rebuilt: {:.1} % of voxels filled", 100.0 * filled);
        match volume {
            Some(mut v) => {
                // A new image under a new handle: the material then differs from its twin in
                // front of the ash (`split`), which is updated in the same frame. Replaced in
                // place under the old handle, the image would get a new texture that the twin's
                // bind group never sees: it would keep drawing the first volume (`density_image`
                // makes images Bevy cannot update in place). The old image is freed when the last
                // material holding it lets go.
                v.image = images.add(image);
                if materials
                    .insert(v.material.id(), cloud_material(v.image.clone(), &transform, &settings))
                    .is_err()
                {
                    warn_once!("cloud material of {entity} could not be replaced");
                }
                if let Ok(mut t) = draws.get_mut(v.draw) {
                    *t = box_transform(&transform, settings.shadow_floor_m);
                }
                v.built_at_s = time_s;
                v.filled_fraction = filled;
                v.memory = memory;
                v.settings = settings;
            }
            None => {
                let handle = images.add(image);
                let material = materials.add(cloud_material(handle.clone(), &transform, &settings));
                let draw = commands
                    .spawn((
                        Name::new("Clouds"),
                        CloudDraw { atmosphere: entity },
                        Mesh3d(meshes.add(Cuboid::new(1.0, 1.0, 1.0))),
                        MeshMaterial3d(material.clone()),
                        box_transform(&transform, settings.shadow_floor_m),
                        NotShadowCaster,
                        NotShadowReceiver,
                    ))
                    .id();
                commands.entity(entity).insert(CloudVolume {
                    draw,
                    image: handle,
                    material,
                    built_at_s: time_s,
                    filled_fraction: filled,
                    memory,
                    settings,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clouds::CloudRenderPlugin;
    use bevy::asset::AssetPlugin;
    use volcano_atmosphere::{AtmosphereParams, WeatherScenario, spawn_atmosphere};

    /// A convection atmosphere with a cloud wall over its western half, on a coarse volume.
    fn app(off_thread: bool) -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Image>()
            .init_asset::<Mesh>()
            .add_plugins(CloudRenderPlugin)
            .insert_resource(CloudRenderSettings { voxels_xy: 24, voxels_z: 8, off_thread, ..default() })
            .add_systems(Startup, |mut commands: Commands| {
                let mut state = WeatherScenario::builtin("convection").unwrap().build(Some(16)).unwrap();
                let n = state.grid.n;
                for layer in &mut state.layers {
                    for k in 0..n * n {
                        if state.grid.centre(k).0 < 0.0 {
                            layer.w.data_mut()[k] = 1.0;
                            layer.d.data_mut()[k] = 1.0;
                        }
                    }
                }
                spawn_atmosphere(&mut commands, state, AtmosphereParams::default()).unwrap();
            });
        app
    }

    /// The state the app's snapshot is taken from, built the same way on this thread.
    fn reference(world: &mut World) -> BuiltClouds {
        let (entity, atmo) = {
            let mut q = world.query::<(Entity, &Atmosphere)>();
            let (e, a) = q.single(world).unwrap();
            (e, a.clone())
        };
        let mut q = world.query::<&AirLayer>();
        let layers: Vec<&AirLayer> = q.iter(world).filter(|l| l.atmosphere == entity).collect();
        let state = cloud_state(&atmo, &layers).unwrap();
        let settings = world.resource::<CloudRenderSettings>().clone();
        build_clouds(state, settings, atmo.params.cloud_threshold, ClusterMemory::default(), atmo.time_s)
    }

    fn run_until_applied(app: &mut App) {
        for _ in 0..20_000 {
            app.update();
            if app.world().resource::<CloudBuildStatus>().applied > 0 {
                return;
            }
            std::thread::yield_now();
        }
        panic!("no cloud build was applied");
    }

    #[test]
    fn the_rebuild_runs_on_a_worker_and_builds_what_the_main_thread_would() {
        let mut app = app(true);
        app.update();
        let status = *app.world().resource::<CloudBuildStatus>();
        assert_eq!((status.started, status.on_main_thread), (1, 0), "{status:?}");
        run_until_applied(&mut app);
        let expected = reference(app.world_mut());
        let (want, want_t, want_f) = expected.result.unwrap();
        let world = app.world_mut();
        let v = world.query::<&CloudVolume>().single(world).unwrap().clone();
        let got = world.resource::<Assets<Image>>().get(&v.image).unwrap();
        assert_eq!(got.data, want.data, "the worker's image differs from the main thread's");
        assert!(want_f > 0.0, "empty image: the comparison would say nothing");
        assert_eq!(
            (v.filled_fraction, world.get::<Transform>(v.draw).copied()),
            (want_f, Some(box_transform(&want_t, -500.0)))
        );
        assert_eq!(v.memory, expected.memory, "the clustering memory did not come back");
        let status = *app.world().resource::<CloudBuildStatus>();
        assert_eq!((status.started, status.on_main_thread, status.applied), (1, 0, 1), "{status:?}");
    }

    /// A rebuilt volume reaches the box drawn in front of the ash too (`split`'s twin): its
    /// material is modified, so the renderer builds its bind group again with the new image.
    /// (With the image replaced in place, the twin's material would be unchanged and left
    /// alone: the part of the clouds and the ash fall in front of the column would keep
    /// drawing the first volume.)
    #[test]
    fn a_rebuild_reaches_the_twin_in_front_of_the_ash() {
        use crate::clouds::split::CloudFrontDraw;
        let mut app = app(false);
        let depth =
            app.world_mut().resource_mut::<Assets<Image>>().add(crate::plume::ash_depth_image(UVec2::ONE));
        app.insert_resource(crate::plume::AshDepthImage { image: depth, in_use: false });
        for _ in 0..3 {
            app.update();
        }
        let world = app.world_mut();
        let draw = world.query::<&CloudVolume>().single(world).unwrap().draw;
        let twin = world.get::<CloudFrontDraw>(draw).expect("the box has no twin").0;
        let twin_material = world.get::<MeshMaterial3d<CloudMaterial>>(twin).unwrap().0.clone();
        let mut cursor = world.resource::<Messages<AssetEvent<CloudMaterial>>>().get_cursor_current();
        // The weather moves: a rebuild in the frame (off the worker).
        world.query::<&mut Atmosphere>().single_mut(world).unwrap().time_s += 60.0;
        app.update();
        app.update();
        assert_eq!(app.world().resource::<CloudBuildStatus>().applied, 2);
        let events = app.world().resource::<Messages<AssetEvent<CloudMaterial>>>();
        let touched = cursor.read(events).filter(|e| e.is_modified(&twin_material)).count();
        assert!(touched > 0, "the twin's material was not modified by the rebuild");
        let world = app.world();
        let materials = world.resource::<Assets<CloudMaterial>>();
        let original = &world.get::<MeshMaterial3d<CloudMaterial>>(draw).unwrap().0;
        assert_eq!(materials.get(&twin_material).unwrap().density, materials.get(original).unwrap().density);
    }

    #[test]
    fn off_thread_off_builds_in_the_frame() {
        let mut app = app(false);
        app.update();
        let status = *app.world().resource::<CloudBuildStatus>();
        assert_eq!((status.started, status.on_main_thread, status.applied), (1, 1, 1), "{status:?}");
        // Nothing moved: no further build.
        app.update();
        assert_eq!(app.world().resource::<CloudBuildStatus>().started, 1);
        // A settings change rebuilds.
        app.world_mut().resource_mut::<CloudRenderSettings>().voxels_z = 12;
        app.update();
        assert_eq!(app.world().resource::<CloudBuildStatus>().applied, 2);
    }
}
