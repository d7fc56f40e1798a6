//! A volcano written in Bevy's scene notation (BSN): `cargo run --example bsn_volcano`.
//!
//! One `bsn_list!` holds the simulated world: a procedural stratovolcano placed by its
//! `Transform` 3 km east and 2 km north of the origin, the volcano whose vent snaps onto its
//! summit with a Plinian eruption, a lava field on the flank fed by one source, and the
//! five-layer `eruption` atmosphere, built over the terrain (its grid is centred on the origin,
//! so the vent lies inside it and the column couples to the air). A terrain and a volcano have
//! no plain default value, so BSN builds them from their templates (`TerrainTemplate`,
//! `VolcanoTemplate`) when the scene spawns, and a bad value is an error naming it, logged,
//! not a panic; the other components are patched over their defaults. The camera is the
//! game's, outside the scene. `tests/it/bsn.rs` runs this scene headless.
use bevy::prelude::*;
use volcano::lava::Placement;
use volcano::prelude::*;

/// Where the island lies: world x/z of its summit (3 km east, 2 km north of the origin).
pub const ISLAND: Vec2 = Vec2::new(3_000.0, -2_000.0);
/// Centre of the lava field, from the summit: on the flank 3 km down, about 1.1 km up.
pub const LAVA: Vec2 = Vec2::new(1_721.0, 2_457.0);
/// The lava source, from the summit: near the field's upslope edge.
pub const SOURCE: Vec2 = Vec2::new(1_666.0, 2_379.0);

fn main() -> AppExit {
    App::new()
        // The simulation and its visuals (`bsn` is on in the default features, so `bsn!` is
        // in Bevy's prelude), and a sun and sky for a world without its own.
        .add_plugins((DefaultPlugins, VolcanoPlugins, VolcanoSkyPlugin))
        .add_systems(Startup, (spawn_world, spawn_camera))
        .run()
}

/// Spawns [`volcano_world`]. A template that fails (a value out of range) is logged with its
/// parameter's name, and the scene's later entities are not spawned.
pub fn spawn_world(mut commands: Commands) {
    commands.spawn_scene_list(volcano_world());
}

/// The world as a scene list: one entity per line, named with `#Name`.
pub fn volcano_world() -> impl SceneList {
    bsn_list![
        (
            // Built from `TerrainTemplate::Stratovolcano` at spawn: the fields patch the
            // generator's defaults (a 2.5 km cone on a 20 km square), here at 80 m cells.
            #Island
            Terrain::Stratovolcano(StratovolcanoParams { resolution: 256, cell: 80.0, seed: 7 })
            // Only x and z place a terrain; its heights are altitudes above sea level.
            Transform::from_xyz(ISLAND.x, 0.0, ISLAND.y)
        ),
        (
            // `VolcanoTemplate` checks the vent radius when the scene spawns; the vent sits on
            // the terrain under the entity's x/z.
            #Vent
            Volcano { vent_radius: 100.0, seed: 7 }
            Eruption::plinian()
            Transform::from_xyz(ISLAND.x, 0.0, ISLAND.y)
        ),
        (
            // 256² cells of 1 m resampled from the terrain, centred on the entity; what freezes
            // is written back. Lava is placed by its `Transform` x and z, like the terrain.
            #Lava
            LavaField { placement: Placement { centre: {Vec2::ZERO}, nx: 256, ny: 256, cell: 1.0 }, seed: 7 }
            Transform::from_xyz(ISLAND.x + LAVA.x, 0.0, ISLAND.y + LAVA.y)
        ),
        (
            #Source
            LavaSource { rate: 3.0, radius: 2.0 }
            Transform::from_xyz(ISLAND.x + SOURCE.x, 0.0, ISLAND.y + SOURCE.y)
        ),
        (
            // Becomes an `Atmosphere` with its `AirLayer` children at the first tick, over the
            // terrain under the origin; the weather steps once per simulated second.
            #Air
            AtmosphereScenario { scenario: "eruption" }
        ),
    ]
}

/// The game's camera, outside the scene: an orbit camera on the column above the island.
fn spawn_camera(mut commands: Commands) {
    commands.spawn(camera_bundle(OrbitCamera {
        focus: Vec3::new(ISLAND.x, 5_000.0, ISLAND.y),
        distance: 30_000.0,
        ..default()
    }));
}
