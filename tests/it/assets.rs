//! Bevy assets: bad files give errors naming the field, a reloaded preset
//! changes the next slices, a timeline asset drives an eruption, the built-ins load from
//! `embedded://`, the bundled heightmap is the default stratovolcano, and a scene asset spawns
//! its simulation and respawns it when reloaded.

use std::path::{Path, PathBuf};
use std::time::Duration;

use bevy::asset::{AssetPlugin, LoadState};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::assets::*;
use volcano::prelude::*;

/// A fresh asset folder for one test.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("volcano_assets_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn app(assets: &Path) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin { file_path: assets.display().to_string(), ..default() },
        VolcanoSimPlugins,
        VolcanoAssetPlugin,
    ))
    .insert_resource(Time::<Fixed>::from_hz(volcano::core::units::THESIS_TICK_HZ))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)));
    app
}

/// Updates until `done` or 10 s of wall time (loads run on the IO pool).
fn pump(app: &mut App, mut done: impl FnMut(&mut App) -> bool) {
    let start = std::time::Instant::now();
    while !done(app) {
        assert!(start.elapsed() < Duration::from_secs(10), "timed out waiting for the asset server");
        app.update();
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The load error of `path` as type `A`, as the asset server reports it.
fn load_error<A: Asset>(app: &mut App, path: &str) -> String {
    let handle: Handle<A> = app.world().resource::<AssetServer>().load(path.to_string());
    let mut message = String::new();
    pump(app, |app| match app.world().resource::<AssetServer>().load_state(&handle) {
        LoadState::Failed(e) => {
            message = e.to_string();
            true
        }
        LoadState::Loaded => panic!("{path} loaded"),
        _ => false,
    });
    message
}

#[test]
fn a_bad_field_is_named_in_the_load_error() {
    let dir = folder("bad");
    let scenario = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/volcano_atmosphere/scenarios/convection.ron"),
    )
    .unwrap()
    .replace("grid: 128,", "gird: 128,");
    let cases: [(&str, &str, &str); 6] = [
        ("typo.plume.ron", "(vee0: 200.0)", "vee0"),
        ("slow.plume.ron", "(v0: -5.0)", "v0"),
        ("order.timeline.ron", "(keys: [(at_s: 5), (at_s: 2)])", "keys[1].at_s"),
        ("probe.scene.ron", "(scene_name_probe: 1)", "scene_name_probe"),
        ("typo.atmosphere.ron", &scenario, "gird"),
        ("text.height.png", "not a png", "image"),
    ];
    for (file, body, _) in &cases {
        std::fs::write(dir.join(file), body).unwrap();
    }
    let mut app = app(&dir);
    let errors = [
        load_error::<PlumePresetAsset>(&mut app, cases[0].0),
        load_error::<PlumePresetAsset>(&mut app, cases[1].0),
        load_error::<EruptionTimelineAsset>(&mut app, cases[2].0),
        load_error::<SceneAsset>(&mut app, cases[3].0),
        load_error::<AtmosphereScenarioAsset>(&mut app, cases[4].0),
        load_error::<HeightmapAsset>(&mut app, cases[5].0),
    ];
    for ((file, _, field), error) in cases.iter().zip(&errors) {
        assert!(error.contains(field), "{file}: `{error}` does not name `{field}`");
        assert!(error.contains(file), "{file}: `{error}` does not name the file");
    }
}

#[test]
fn a_reloaded_preset_changes_the_next_slices() {
    let dir = folder("reload");
    let write = |v0: f64| {
        let text = Preset::PlinianShowcase.ron().replace("v0: 200.0", &format!("v0: {v0:.1}"));
        assert!(text.contains(&format!("v0: {v0:.1}")), "the preset file changed its v0 line");
        std::fs::write(dir.join("vent.plume.ron"), text).unwrap();
    };
    write(200.0);
    let mut app = app(&dir);
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    let handle = app.world().resource::<AssetServer>().load("vent.plume.ron");
    let volcano = app
        .world_mut()
        .spawn((
            Volcano::new(100.0, 3).unwrap(),
            Eruption::thesis(),
            PlumePresetSource(handle),
            Transform::default(),
        ))
        .id();
    let v0 = |app: &App| app.world().get::<Eruption>(volcano).unwrap().params.v0;
    pump(&mut app, |app| v0(app) == 200.0);
    assert_eq!(app.world().get::<Eruption>(volcano).unwrap().params, Preset::PlinianShowcase.params());
    for _ in 0..50 {
        app.update();
    }
    let newest = |app: &mut App| {
        let world = app.world_mut();
        world
            .query::<&PlumeSlice>()
            .iter(world)
            .filter(|s| !s.secondary)
            .max_by_key(|s| s.index)
            .cloned()
            .unwrap()
    };
    let before = newest(&mut app);
    assert!((before.state.velocity.length() - 200.0).abs() < 20.0, "{:?}", before.state.velocity);

    write(120.0);
    app.world().resource::<AssetServer>().reload("vent.plume.ron");
    pump(&mut app, |app| v0(app) == 120.0);
    let at_reload = newest(&mut app).index;
    pump(&mut app, |app| newest(app).index > at_reload);
    let after = newest(&mut app);
    let speed = after.state.velocity.length();
    assert!((speed - 120.0).abs() < 12.0, "a slice emitted after the reload leaves at {speed} m/s");
}

#[test]
fn the_built_ins_load_from_embedded() {
    let dir = folder("embedded");
    let mut app = app(&dir);
    let server = app.world().resource::<AssetServer>().clone();
    let preset: Handle<PlumePresetAsset> =
        server.load("embedded://volcano/presets/pyroclastic_showcase.plume.ron");
    let timeline: Handle<EruptionTimelineAsset> =
        server.load("embedded://volcano/timelines/plinian_to_collapse.timeline.ron");
    let scene: Handle<SceneAsset> = server.load("embedded://volcano/scenes/eruption.scene.ron");
    let scenario: Handle<AtmosphereScenarioAsset> =
        server.load("embedded://volcano/scenarios/sea-breeze.atmosphere.ron");
    let ids = [preset.id().untyped(), timeline.id().untyped(), scene.id().untyped(), scenario.id().untyped()];
    pump(&mut app, |app| {
        ids.iter()
            .all(|id| matches!(app.world().resource::<AssetServer>().load_state(*id), LoadState::Loaded))
    });
    let world = app.world();
    assert_eq!(
        world.resource::<Assets<PlumePresetAsset>>().get(&preset).unwrap().0,
        Preset::PyroclasticShowcase.params()
    );
    assert_eq!(
        world.resource::<Assets<SceneAsset>>().get(&scene).unwrap().0,
        volcano::scenes::by_name("eruption").unwrap()
    );
    assert_eq!(
        world.resource::<Assets<AtmosphereScenarioAsset>>().get(&scenario).unwrap().0,
        volcano::atmosphere::WeatherScenario::builtin("sea-breeze").unwrap()
    );
    let story = &world.resource::<Assets<EruptionTimelineAsset>>().get(&timeline).unwrap().0;
    assert_eq!(story.sample(75.0).v0, Some(135.0), "halfway down the 60–90 s ramp");
}

#[test]
fn a_timeline_asset_scripts_the_eruption_and_a_heightmap_asset_is_its_terrain() {
    let dir = folder("script");
    let mut app = app(&dir);
    let server = app.world().resource::<AssetServer>().clone();
    let terrain = app
        .world_mut()
        .spawn(HeightmapSource(server.load("embedded://volcano/terrain/stratovolcano.height.png")))
        .id();
    let volcano = app
        .world_mut()
        .spawn((
            Volcano::new(100.0, 3).unwrap(),
            Eruption::thesis(),
            EruptionTimelineSource(
                server.load("embedded://volcano/timelines/plinian_to_collapse.timeline.ron"),
            ),
            Transform::default(),
        ))
        .id();
    pump(&mut app, |app| {
        app.world().get::<Terrain>(terrain).is_some() && app.world().get::<EruptionScript>(volcano).is_some()
    });
    for _ in 0..10 {
        app.update();
    }
    // The first key switched the thesis eruption to the Plinian showcase.
    assert_eq!(app.world().get::<Eruption>(volcano).unwrap().params.v0, 200.0);
    let t = app.world().get::<Terrain>(terrain).unwrap();
    assert_eq!((t.heights().nx(), t.heights().ny()), (257, 257));
    // Land cover from the relief: snow on the summit, bare steep flanks, vegetation below.
    let count = |c: LandCover| t.cover().data().iter().filter(|&&x| x == c).count();
    let (snow, ground, green) =
        (count(LandCover::Snow), count(LandCover::Ground), count(LandCover::Vegetation));
    assert!(
        snow > 0 && ground > 0 && green > snow + ground,
        "snow {snow}, ground {ground}, vegetation {green}"
    );
}

/// The bundled heightmap is the default stratovolcano on 257 × 257 samples of 80 m, to the
/// 0.1 m of a 16-bit unit. `VOLCANO_WRITE_ASSETS=1 cargo test --test assets bundled` rewrites it.
#[test]
fn the_bundled_heightmap_is_the_default_stratovolcano() {
    let generated =
        StratovolcanoParams { resolution: 257, cell: 80.0, ..Default::default() }.generate().unwrap();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/terrain/stratovolcano.height.png");
    let defaults = HeightmapSettings::default();
    if std::env::var_os("VOLCANO_WRITE_ASSETS").is_some() {
        std::fs::write(&path, generated.to_png16(defaults.metres_per_unit, defaults.base_altitude).unwrap())
            .unwrap();
    }
    let scale = volcano::core::terrain::png_io::HeightmapScale {
        metres_per_unit: defaults.metres_per_unit,
        base_altitude: defaults.base_altitude,
        cell: defaults.cell,
        sea_level: defaults.sea_level,
    };
    let bundled = Terrain::from_png_bytes(&std::fs::read(&path).unwrap(), scale).unwrap();
    let (a, b) = (bundled.heights(), generated.heights());
    assert_eq!((a.nx(), a.ny(), a.cell(), a.origin()), (b.nx(), b.ny(), b.cell(), b.origin()));
    let worst = a.data().iter().zip(b.data()).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    assert!(worst <= 0.051, "bundled heightmap differs from the generator by up to {worst} m");
}

/// A small scene file: a 6.4 km stratovolcano, a Plinian eruption, a lava patch with one
/// source, and a coarse atmosphere (16² cells).
fn small_scene(eruption: &str, vent_x: f64) -> String {
    format!(
        r#"(
    name: "small",
    description: "test",
    terrain: Stratovolcano((resolution: 64, cell: 100.0, base_altitude: 200.0, summit_height: 1500.0,
        cone_radius: 2500.0, flank_exponent: 1.6, crater_radius: 150.0, crater_depth: 50.0,
        ridge_amplitude: 20.0, hills_amplitude: 30.0, sea_level: 0.0, snow_line: 2300.0,
        bare_slope_deg: 28.0, seed: 3)),
    volcano: (vent: ({vent_x}, 0.0), vent_radius: 100.0, seed: 3),
    eruption: {eruption},
    camera: (focus: (0.0, 0.0, 0.0), yaw_deg: 0.0, pitch_deg: 10.0, distance: 9000.0),
    sun: (azimuth_deg: 140.0, elevation_deg: 30.0, illuminance_lux: 100000.0),
    atmosphere: Some((scenario: "eruption", grid: Some(16), time_scale: 1.0)),
    lava: Some((centre: (1200.0, 0.0), cells: (32, 32), cell: 1.0,
        sources: [(position: (1200.0, 0.0), rate: 1.0, radius: 2.0)], seed: 3)),
)"#
    )
}

#[test]
fn a_scene_asset_spawns_its_simulation_and_respawns_it_on_reload() {
    let dir = folder("scene");
    std::fs::write(dir.join("small.scene.ron"), small_scene("Some(Plinian)", 0.0)).unwrap();
    let mut app = app(&dir);
    let handle = app.world().resource::<AssetServer>().load("small.scene.ron");
    let source = app.world_mut().spawn(VolcanoSceneSource(handle)).id();
    let spawned = |app: &App| app.world().get::<SpawnedScene>(source).unwrap().0.clone();
    pump(&mut app, |app| !spawned(app).is_empty());
    let count = |app: &mut App| {
        let w = app.world_mut();
        (
            w.query::<&Terrain>().iter(w).count(),
            w.query::<&Volcano>().iter(w).count(),
            w.query::<&volcano::lava::LavaField>().iter(w).count(),
            w.query::<&volcano::lava::LavaSource>().iter(w).count(),
            w.query::<&volcano::atmosphere::Atmosphere>().iter(w).count(),
            w.query::<&volcano::atmosphere::AirLayer>().iter(w).count(),
        )
    };
    // Terrain, volcano, field, source and atmosphere (its five layers are its children).
    assert_eq!(spawned(&app).len(), 5);
    assert_eq!(count(&mut app), (1, 1, 1, 1, 1, 5));
    let first = spawned(&app);
    let eruption = |app: &mut App| {
        let w = app.world_mut();
        w.query::<(&Volcano, Option<&Eruption>)>().single(w).map(|(_, e)| e.is_some()).unwrap()
    };
    assert!(eruption(&mut app));
    // It runs: slices rise from the vent and the lava flows.
    for _ in 0..50 {
        app.update();
    }
    let w = app.world_mut();
    assert!(w.query::<&PlumeSlice>().iter(w).count() > 0, "no slice after 50 ticks");

    // The file changes (no eruption, the vent 500 m east) and is reloaded: the old entities
    // go, the new file's come, nothing is doubled.
    std::fs::write(dir.join("small.scene.ron"), small_scene("None", 500.0)).unwrap();
    app.world().resource::<AssetServer>().reload("small.scene.ron");
    pump(&mut app, |app| spawned(app) != first);
    app.update();
    assert_eq!(count(&mut app), (1, 1, 1, 1, 1, 5));
    assert!(
        first.iter().all(|&e| app.world().get_entity(e).is_err()),
        "an entity of the first file survived"
    );
    assert!(!eruption(&mut app), "the reloaded scene has no eruption");
    let w = app.world_mut();
    let vent = w
        .query::<&Transform>()
        .iter(w)
        .filter(|t| t.translation.x > 400.0 && t.translation.x < 600.0)
        .count();
    assert!(vent > 0, "the volcano stands at the new vent");
    let w = app.world_mut();
    assert_eq!(
        w.query::<&PlumeSlice>().iter(w).count(),
        0,
        "the old eruption's slices went with its volcano"
    );
}
