//! A volcano written in BSN: the scene of `examples/bsn_volcano.rs`, spawned headless
//! (`MinimalPlugins`, Bevy's asset and scene plugins, `VolcanoSimPlugins`) and run, builds
//! what it says: the terrain where its `Transform` put it, the vent on its summit, a rising
//! column, a lava source feeding its field, an atmosphere with its layers. Invalid values in a
//! template are errors naming them, not panics; asset sources take paths. `cargo test` also
//! builds the example itself.

use std::time::Duration;

use bevy::asset::AssetPlugin;
use bevy::prelude::*;
use bevy::scene::ScenePlugin;
use bevy::time::TimeUpdateStrategy;
use volcano::atmosphere::plugin::AtmosphereGround;
use volcano::lava::LavaState;
use volcano::plume::PlumeAmbient;
use volcano::prelude::*;

#[allow(dead_code, reason = "its `main` opens a window; the test spawns its scene headless")]
#[path = "../../examples/bsn_volcano.rs"]
mod bsn_volcano;

use bsn_volcano::{ISLAND, LAVA, SOURCE};

/// The simulation on `MinimalPlugins` with what `spawn_scene` needs (an `AssetServer`, the
/// scene assets), stepped 100 ms per update.
fn headless_app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, AssetPlugin::default(), ScenePlugin, VolcanoSimPlugins))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)));
    app
}

/// The one entity named `name` (the scene's `#Name`).
fn named(world: &mut World, name: &str) -> Entity {
    let found: Vec<Entity> = world
        .query::<(Entity, &Name)>()
        .iter(world)
        .filter(|(_, n)| n.as_str() == name)
        .map(|(e, _)| e)
        .collect();
    assert_eq!(found.len(), 1, "one entity named {name}: {found:?}");
    found[0]
}

#[test]
fn the_bsn_volcano_runs_headless() {
    let mut app = headless_app();
    app.add_systems(Startup, bsn_volcano::spawn_world);
    // 4 simulated seconds.
    for _ in 0..40 {
        app.update();
    }
    let world = app.world_mut();

    // The terrain: built from its template and moved to its Transform's x/z, summit included.
    let island = named(world, "Island");
    let terrain = world.get::<Terrain>(island).expect("the template built a terrain").clone();
    assert_eq!(terrain.placement(), ISLAND);
    assert_eq!((terrain.heights().nx(), terrain.heights().cell()), (256, 80.0));
    let summit = terrain.height_at(ISLAND.x, ISLAND.y);
    assert!(summit > 2_000.0, "the cone's top is under the island's centre: {summit} m");
    assert!(terrain.contains(0.0, 0.0) && !terrain.contains(-8_000.0, 0.0), "placed, not at the origin");

    // The volcano: its template's values, its vent snapped onto the summit of that terrain.
    let vent_entity = named(world, "Vent");
    assert_eq!(world.get::<Volcano>(vent_entity), Some(&Volcano::new(100.0, 7).unwrap()));
    assert_eq!(world.get::<Eruption>(vent_entity), Some(&Eruption::plinian()));
    assert_eq!(world.get::<OnTerrain>(vent_entity).map(|o| o.0), Some(island));
    let vent = world.get::<VentPosition>(vent_entity).expect("the vent was placed").0;
    assert_eq!((vent.x, vent.z), (ISLAND.x, ISLAND.y));
    assert!((vent.y - summit).abs() < 1e-3, "the vent sits on the summit: {vent}, summit {summit}");

    // The column rises (slice positions are in the plume frame: z up above the vent).
    let slices: Vec<f64> = world
        .query::<&PlumeSlice>()
        .iter(world)
        .filter(|s| s.volcano == vent_entity)
        .map(|s| s.state.position.z)
        .collect();
    assert!(slices.len() > 5, "{} slices after 4 s of eruption", slices.len());
    let top = slices.iter().cloned().fold(0.0, f64::max);
    assert!(top > 100.0, "the column rises: its highest slice is {top:.0} m above the vent");

    // The lava: the field built on the island where the scene put it, fed by the source.
    let field = named(world, "Lava");
    assert_eq!(world.get::<LavaFieldStatus>(field), Some(&LavaFieldStatus::Ok));
    let state = world.get::<LavaState>(field).expect("the field was built");
    let grid = state.flow.thickness();
    let centre = grid.origin() + 0.5 * Vec2::new((grid.nx() - 1) as f32, (grid.ny() - 1) as f32);
    assert_eq!(centre, ISLAND + LAVA, "the grid is centred on the entity's Transform");
    let emitted = state.flow.budget().sources;
    let source = named(world, "Source");
    assert_eq!(world.get::<LavaSourceStatus>(source), Some(&LavaSourceStatus::Active(field)));
    let placed = world.get::<Transform>(source).unwrap().translation;
    assert_eq!((placed.x, placed.z), (ISLAND.x + SOURCE.x, ISLAND.y + SOURCE.y));
    assert!(emitted > 3.0, "the source fed {emitted} m³ in 4 s at 3 m³/s");

    // The atmosphere: built on the scene's entity with the eruption scenario's five layers,
    // over the terrain, and stepping.
    let air = named(world, "Air");
    assert_eq!(world.get::<AtmosphereScenarioStatus>(air), Some(&AtmosphereScenarioStatus::Built));
    let atmosphere = world.get::<Atmosphere>(air).expect("the scenario became an atmosphere");
    assert_eq!(atmosphere.n, 128);
    assert!(atmosphere.time_s >= 1.0, "the weather stepped: {} s", atmosphere.time_s);
    let layers: Vec<usize> = world
        .query::<(&AirLayer, &ChildOf)>()
        .iter(world)
        .filter(|(l, c)| l.atmosphere == air && c.parent() == air)
        .map(|(l, _)| l.index)
        .collect();
    assert_eq!(layers.len(), 5, "the eruption scenario's layers, children of the atmosphere: {layers:?}");
    // The vent lies inside the grid, so the column reads the layers' air.
    assert!(world.get::<PlumeAmbient>(vent_entity).is_some(), "the volcano is coupled");
}

#[test]
fn invalid_template_values_are_errors_not_panics() {
    let mut app = headless_app();
    let world = app.world_mut();

    // `World::spawn_scene` returns the template's error, which names the parameter, and spawns
    // nothing.
    let terrain = bsn! { Terrain::Stratovolcano(StratovolcanoParams { resolution: 64, cell: 0.0 }) };
    let e = world.spawn_scene(terrain).err().expect("a terrain with 0 m cells is an error");
    assert!(e.to_string().contains("terrain not built") && e.to_string().contains("`cell`"), "{e}");
    let flat = bsn! { Terrain::Flat { resolution: 1 } };
    let e = world.spawn_scene(flat).err().expect("a 1-sample terrain is an error");
    assert!(e.to_string().contains("`resolution`"), "{e}");
    // A negative number is written in braces.
    let volcano = bsn! { Volcano { vent_radius: {-5.0} } Transform::from_xyz(0.0, 0.0, 0.0) };
    let e = world.spawn_scene(volcano).err().expect("a negative vent radius is an error");
    assert!(e.to_string().contains("volcano not built") && e.to_string().contains("`vent_radius`"), "{e}");
    assert_eq!(world.query::<&Terrain>().iter(world).count(), 0);
    assert_eq!(world.query::<&Volcano>().iter(world).count(), 0);

    // Through `Commands` the error is logged and the app runs on.
    app.add_systems(Startup, |mut commands: Commands| {
        commands.spawn_scene(bsn! { Volcano::new(-1.0, 3) });
        commands.spawn_scene(bsn! { #Air AtmosphereScenario { scenario: "monsoon" } });
    });
    for _ in 0..3 {
        app.update();
    }
    let world = app.world_mut();
    assert_eq!(world.query::<&Volcano>().iter(world).count(), 0);
    // An unknown scenario is rejected with the names that exist, and no layer is spawned.
    let air = named(world, "Air");
    let Some(AtmosphereScenarioStatus::Rejected(why)) = world.get::<AtmosphereScenarioStatus>(air) else {
        panic!("not rejected: {:?}", world.get::<AtmosphereScenarioStatus>(air));
    };
    assert!(why.contains("monsoon") && why.contains("eruption"), "{why}");
    assert!(world.get::<Atmosphere>(air).is_none());
    assert_eq!(world.query::<&AirLayer>().iter(world).count(), 0);
}

#[test]
fn a_scenario_atmosphere_waits_for_the_terrain_under_the_origin() {
    let mut app = headless_app();
    let air = bsn! { AtmosphereScenario { grid: {Some(32)} } };
    let air = app.world_mut().spawn_scene(air).expect("a valid scenario").id();
    for _ in 0..2 {
        app.update();
    }
    let status = app.world().get::<AtmosphereScenarioStatus>(air);
    assert_eq!(status, Some(&AtmosphereScenarioStatus::WaitingForTerrain));
    assert!(app.world().get::<Atmosphere>(air).is_none());
    // A flat plain at 300 m under the origin arrives: the atmosphere is built over it.
    let plain = bsn! { Terrain::Flat { resolution: 64, cell: 500.0, altitude: 300.0 } };
    app.world_mut().spawn_scene(plain).expect("a valid flat terrain");
    for _ in 0..2 {
        app.update();
    }
    let world = app.world_mut();
    assert_eq!(world.get::<AtmosphereScenarioStatus>(air), Some(&AtmosphereScenarioStatus::Built));
    assert_eq!(world.get::<Atmosphere>(air).map(|a| a.n), Some(32));
    let ground = &world.get::<AtmosphereGround>(air).unwrap().0;
    assert!(ground.height.data().iter().all(|h| (*h - 300.0).abs() < 1e-3), "sampled from the plain");
    assert_eq!(world.query::<&AirLayer>().iter(world).filter(|l| l.atmosphere == air).count(), 5);
}

#[test]
fn asset_sources_take_their_paths_in_bsn() {
    let mut app = headless_app();
    app.add_plugins(VolcanoAssetPlugin);
    let world = app.world_mut();
    // The `*Source` components' templates hold the path; the asset server loads it at spawn.
    let map = bsn! {
        HeightmapSource("embedded://volcano/terrain/stratovolcano.height.png")
        Transform::from_xyz(ISLAND.x, 0.0, ISLAND.y)
    };
    let island = world.spawn_scene(map).expect("a heightmap path").id();
    let vent = bsn! {
        Volcano::new(100.0, 3)
        Eruption
        EruptionTimelineSource("embedded://volcano/timelines/plinian_to_collapse.timeline.ron")
        Transform::from_xyz(ISLAND.x, 0.0, ISLAND.y)
    };
    let vent = world.spawn_scene(vent).expect("a timeline path").id();
    // Loads run on the IO pool: update until both are applied, for at most 10 s.
    let start = std::time::Instant::now();
    while app.world().get::<Terrain>(island).is_none() || app.world().get::<EruptionScript>(vent).is_none() {
        assert!(start.elapsed() < Duration::from_secs(10), "timed out waiting for the asset server");
        app.update();
        std::thread::sleep(Duration::from_millis(2));
    }
    for _ in 0..3 {
        app.update();
    }
    let world = app.world();
    let terrain = world.get::<Terrain>(island).unwrap();
    assert_eq!((terrain.heights().nx(), terrain.placement()), (257, ISLAND), "the bundled map, placed");
    // The timeline's first key switched the default (thesis) eruption to the Plinian showcase.
    assert_eq!(world.get::<Eruption>(vent).unwrap().params.v0, 200.0);
    let y = world.get::<VentPosition>(vent).expect("the vent was placed").0.y;
    assert!((y - terrain.height_at(ISLAND.x, ISLAND.y)).abs() < 1e-3 && y > 2_000.0, "on the summit: {y}");
}
