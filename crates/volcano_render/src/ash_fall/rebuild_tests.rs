//! Tests of the ash volume rebuild (the parent module's systems in an app without a renderer).

use super::*;
use crate::clouds::{CloudRenderPlugin, CloudRenderSettings};
use crate::{AshFallRenderPlugin, AshFallSettings};
use bevy::asset::AssetPlugin;
use volcano_atmosphere::{AtmosphereParams, WeatherScenario, spawn_atmosphere};

/// An atmosphere with a disc of ash in every layer (none with `ash` false), drawn on a coarse
/// volume; the clouds are off so that only the ash is built.
fn app(off_thread: bool, ash: bool) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, AssetPlugin::default()))
        .init_asset::<Image>()
        .init_asset::<Mesh>()
        .add_plugins((CloudRenderPlugin, AshFallRenderPlugin))
        .insert_resource(CloudRenderSettings { enabled: false, ..default() })
        .insert_resource(AshFallSettings { voxels_xy: 24, voxels_z: 12, off_thread, ..default() })
        .add_systems(Startup, move |mut commands: Commands| {
            let mut state = WeatherScenario::builtin("eruption").unwrap().build(Some(16)).unwrap();
            for layer in &mut state.layers {
                for k in 0..state.grid.n * state.grid.n {
                    let (x, y) = state.grid.centre(k);
                    if ash && x.hypot(y) < 8_000.0 {
                        layer.ash.data_mut()[k] = 0.05;
                    }
                }
            }
            spawn_atmosphere(&mut commands, state, AtmosphereParams::default()).unwrap();
        });
    app
}

fn status(app: &App) -> (u64, u64, u64) {
    let s = *app.world().resource::<AshFallBuildStatus>();
    (s.started, s.on_main_thread, s.applied)
}

/// The image the main thread builds from the app's current state.
fn reference(world: &mut World) -> (Image, Transform, f32) {
    let (atmo, ground) = {
        let mut q = world.query::<(Entity, &Atmosphere, Option<&AtmosphereGround>)>();
        let (e, a, g) = q.single(world).unwrap();
        (a.clone(), (e, g.map(|g| g.0.height.clone())))
    };
    let mut q = world.query::<&AirLayer>();
    let layers: Vec<&AirLayer> = q.iter(world).filter(|l| l.atmosphere == ground.0).collect();
    let fields = volcano_atmosphere::atmosphere_fields(layers, ground.0);
    let grid = GridSpec::new(atmo.n, atmo.dx).unwrap();
    let settings = world.resource::<AshFallSettings>();
    build_ash_image(&fields, grid, ground.1.as_ref(), settings).unwrap()
}

fn visibility(world: &mut World) -> Visibility {
    *world.query_filtered::<&Visibility, With<AshFallDraw>>().single(world).unwrap()
}

#[test]
fn the_rebuild_runs_on_a_worker_and_builds_what_the_main_thread_would() {
    let mut app = app(true, true);
    app.update();
    // (A worker may finish this small build before the apply system runs in the same frame.)
    assert_eq!((status(&app).0, status(&app).1), (1, 0), "started once, on a worker");
    for _ in 0..20_000 {
        if status(&app).2 > 0 {
            break;
        }
        app.update();
        std::thread::yield_now();
    }
    assert_eq!(status(&app), (1, 0, 1), "the build was not applied");
    let (want, want_t, want_f) = reference(app.world_mut());
    assert!(want_f > 0.05, "nearly empty image ({want_f}): the comparison would say little");
    let world = app.world_mut();
    let v = world.query::<&AshFallVolume>().single(world).unwrap().clone();
    let got = world.resource::<Assets<Image>>().get(&v.image).unwrap();
    assert_eq!(got.data, want.data, "the worker's image differs from the main thread's");
    assert_eq!((v.filled_fraction, world.get::<Transform>(v.draw).copied()), (want_f, Some(want_t)));
    assert!(v.airborne_g > 0.0);
    assert_eq!(visibility(world), Visibility::Inherited);
}

#[test]
fn inline_builds_land_in_the_frame_and_only_when_something_moved() {
    let mut app = app(false, true);
    app.update();
    assert_eq!(status(&app), (1, 1, 1));
    // The weather has not moved: no further build.
    app.update();
    assert_eq!(status(&app).0, 1);
    // A weather step (its time moves): one build.
    app.world_mut().query::<&mut Atmosphere>().single_mut(app.world_mut()).unwrap().time_s += 60.0;
    app.update();
    app.update();
    assert_eq!(status(&app), (2, 2, 2));
    // Drawing off: hidden in that frame, nothing built; on again: rebuilt and shown.
    app.world_mut().resource_mut::<AshFallSettings>().enabled = false;
    app.update();
    assert_eq!((status(&app).0, visibility(app.world_mut())), (2, Visibility::Hidden));
    app.world_mut().resource_mut::<AshFallSettings>().enabled = true;
    app.update();
    assert_eq!((status(&app).0, visibility(app.world_mut())), (3, Visibility::Inherited));
    // A settings edit rebuilds with it.
    app.world_mut().resource_mut::<AshFallSettings>().voxels_z = 16;
    app.update();
    assert_eq!(status(&app), (4, 4, 4));
    let world = app.world_mut();
    let v = world.query::<&AshFallVolume>().single(world).unwrap().clone();
    // The image's height is its vertical resolution (`density_volume::density_image`).
    let levels = world.resource::<Assets<Image>>().get(&v.image).unwrap().texture_descriptor.size.height;
    assert_eq!(levels, 16, "the image was not rebuilt at the new resolution");
}

#[test]
fn ash_free_air_is_looked_at_once_per_weather_time_and_gets_no_box() {
    let mut app = app(false, false);
    for _ in 0..5 {
        app.update();
    }
    assert_eq!(status(&app), (1, 1, 1), "one look per weather time, not one per frame");
    let world = app.world_mut();
    assert_eq!(world.query::<&AshFallVolume>().iter(world).count(), 0);
    assert_eq!(world.query::<&AshFallDraw>().iter(world).count(), 0);
}
