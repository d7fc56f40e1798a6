//! The ash-fall volume a renderer rebuilds after each weather step
//! (`volcano_render::ash_fall::volume::ash_density_volume`), at the `eruption` scene's size:
//! five 2 km layers on a 128² grid of 200 m, 128² × 64 voxels. Three variants beside a
//! same-run memory sweep over the volume's bytes (one read-modify-write pass over 4 MiB, the
//! floor of anything that writes every voxel): the default look, without the meander (its
//! 2 · 33² · 64 noise calls), and without streaks, blur, relief or meander (the sampling alone).
//!
//! Then what the main thread pays for it: one `app.update()` of an app holding only that
//! atmosphere and the ash-fall systems, its weather time moved every update so that every
//! update is due a rebuild, with the rebuild on the main thread (`off_thread: false`) and on
//! the task pool (the default; the main thread takes a snapshot and looks for a finished
//! build).

use std::hint::black_box;

use bevy::asset::AssetPlugin;
use bevy::prelude::*;
use criterion::{Criterion, criterion_group, criterion_main};
use volcano_atmosphere::view::{GridSpec, LayerFields};
use volcano_atmosphere::{AirLayer, Atmosphere, AtmosphereParams, WeatherScenario, spawn_atmosphere};
use volcano_render::ash_fall::volume::{AshVolumeSpec, ash_density_volume, meander_offsets};
use volcano_render::{AshFallRenderPlugin, AshFallSettings, CloudRenderPlugin, CloudRenderSettings};

/// Five layers with a curtain of ash east of the centre, thinning with altitude.
fn layers(grid: GridSpec) -> Vec<LayerFields> {
    (0..5)
        .map(|i| {
            let bottom = 2_000.0 * i as f64;
            let mut l = LayerFields::new(grid, bottom + 1_000.0, bottom, 2_000.0, 280.0);
            for k in 0..grid.n * grid.n {
                let (x, y) = grid.centre(k);
                let r = (x - 4_000.0).hypot(y / 2.0);
                l.ash.data_mut()[k] = if r < 6_000.0 { 0.05 * (1.0 - r / 6_000.0) } else { 0.0 };
            }
            l
        })
        .collect()
}

fn spec(meander_m: f64, look: bool) -> AshVolumeSpec {
    AshVolumeSpec {
        nxy: 128,
        nz: 64,
        z_min: 0.0,
        z_max: 10_000.0,
        streaks: if look { 1.0 } else { 0.0 },
        streak_m: 2_000.0,
        seed: 11,
        edge_fraction: if look { 0.12 } else { 0.0 },
        blur_m: if look { 1_200.0 } else { 0.0 },
        relief: if look { 0.8 } else { 0.0 },
        relief_m: 6_000.0,
        meander_m,
    }
}

fn bench(c: &mut Criterion) {
    let grid = GridSpec::new(128, 200.0).unwrap();
    let owned = layers(grid);
    let refs: Vec<&LayerFields> = owned.iter().collect();
    let mut group = c.benchmark_group("ash_volume_128x128x64");
    group.sample_size(20);
    group.bench_function("default_look", |b| {
        b.iter(|| black_box(ash_density_volume(&refs, grid, None, &spec(800.0, true)).unwrap()))
    });
    group.bench_function("no_meander", |b| {
        b.iter(|| black_box(ash_density_volume(&refs, grid, None, &spec(0.0, true)).unwrap()))
    });
    group.bench_function("sampling_only", |b| {
        b.iter(|| black_box(ash_density_volume(&refs, grid, None, &spec(0.0, false)).unwrap()))
    });
    group.bench_function("sampling_and_meander", |b| {
        b.iter(|| black_box(ash_density_volume(&refs, grid, None, &spec(800.0, false)).unwrap()))
    });
    group.bench_function("meander_offsets_alone", |b| {
        b.iter(|| black_box(meander_offsets(&spec(800.0, true), grid.extent())))
    });
    let mut volume = vec![0.5f32; 128 * 128 * 64];
    group.bench_function("memory_sweep", |b| {
        b.iter(|| {
            volume.iter_mut().for_each(|v| *v = *v * 0.999_999 + 1e-9);
            black_box(&volume);
        })
    });
    group.finish();
}

/// An app holding the `eruption` scenario's atmosphere on a 128² grid with a curtain of ash
/// in every layer, the clouds off, the ash rebuilt on or off the main thread.
fn app(off_thread: bool) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, AssetPlugin::default()))
        .init_asset::<Image>()
        .init_asset::<Mesh>()
        .add_plugins((CloudRenderPlugin, AshFallRenderPlugin))
        .insert_resource(CloudRenderSettings { enabled: false, ..default() })
        .insert_resource(AshFallSettings { off_thread, ..default() })
        .add_systems(Startup, |mut commands: Commands| {
            let mut state = WeatherScenario::builtin("eruption").unwrap().build(Some(128)).unwrap();
            for layer in &mut state.layers {
                for k in 0..state.grid.n * state.grid.n {
                    let (x, y) = state.grid.centre(k);
                    let r = (x - 4_000.0).hypot(y / 2.0);
                    layer.ash.data_mut()[k] = if r < 6_000.0 { 0.05 * (1.0 - r / 6_000.0) } else { 0.0 };
                }
            }
            spawn_atmosphere(&mut commands, state, AtmosphereParams::default()).unwrap();
        });
    app.update();
    app
}

fn frame(c: &mut Criterion) {
    let mut group = c.benchmark_group("ash_rebuild_frame");
    group.sample_size(20);
    for (name, off_thread) in [("update_rebuild_inline", false), ("update_rebuild_off_thread", true)] {
        let mut app = app(off_thread);
        group.bench_function(name, |b| {
            b.iter(|| {
                let world = app.world_mut();
                world.query::<&mut Atmosphere>().single_mut(world).unwrap().time_s += 1.0;
                app.update();
            })
        });
        let world = app.world_mut();
        let built = world.resource::<volcano_render::AshFallBuildStatus>().applied;
        let layers = world.query::<&AirLayer>().iter(world).count();
        assert!(built > 1 && layers > 1, "nothing was built ({built} builds, {layers} layers)");
    }
    group.finish();
}

criterion_group!(benches, bench, frame);
criterion_main!(benches);
