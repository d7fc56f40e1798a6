//! Lava on a game's own ground: `cargo run --example lava_on_your_terrain`.
//!
//! The game builds its terrain from its own heights (here a valley computed in code; a game
//! would read its heightmap or level data), spawns a lava field and a source on it (each placed
//! by its `Transform`), and keeps its own copy of the ground (a stand-in for a physics collider
//! or a navmesh) in step with the lava that freezes: once per simulated second the lava plugin
//! writes the frozen lava into the `Terrain` and sends `TerrainChanged` with the rectangle of
//! height nodes that moved, and the game copies only those nodes. No volcano is needed.

use bevy::prelude::*;

use volcano::prelude::*;

/// Samples per side of the game's ground and their spacing (m): 256 m square.
const N: usize = 257;
const CELL: f64 = 1.0;

/// The game's collision heights, row-major like the terrain (a stand-in for a collider).
#[derive(Resource)]
struct Collider {
    heights: Vec<f32>,
    updates: u32,
}

fn main() -> AppExit {
    App::new()
        .add_plugins((DefaultPlugins, VolcanoPlugins, VolcanoSkyPlugin))
        .add_systems(Startup, setup)
        .add_systems(Update, update_collider)
        .run()
}

/// The valley: 120 m at its head (z = -128 m) falling 0.25 m per metre toward +z, its sides
/// rising 33 m at x = ±128 m, with a rounded channel 40 m wide along x = 0 that guides the flow.
fn valley_height(x: f32, z: f32) -> f32 {
    let channel = 6.0 * (1.0 - (-(x / 20.0).powi(2)).exp());
    120.0 - 0.25 * (z + 128.0) + channel + 0.002 * x * x
}

fn setup(mut commands: Commands) -> Result {
    // The game's ground: a heightfield centred on the origin, its first node at (-128, -128).
    let origin = Vec2::splat(-0.5 * ((N - 1) as f64 * CELL) as f32);
    let heights: Vec<f32> = (0..N * N)
        .map(|k| {
            let p = origin + Vec2::new((k % N) as f32, (k / N) as f32) * CELL as f32;
            valley_height(p.x, p.y)
        })
        .collect();
    let cover = Grid2::new(N, N, CELL, origin, LandCover::Ground)?;
    let terrain = Terrain::new(Grid2::from_vec(N, N, CELL, origin, heights.clone())?, cover, 0.0)?;
    commands.insert_resource(Collider { heights, updates: 0 });
    commands.spawn(terrain);

    // A lava field of 200 × 200 cells of 1 m centred 10 m down the valley, fed 2 m³/s at
    // 1,400 K over a 2 m disc near the valley head.
    commands.spawn((LavaField::square(200, 1.0)?, Transform::from_xyz(0.0, 0.0, 10.0)));
    let vent = LavaSource::new(2.0)?.with_temperature(1_400.0)?.with_radius(2.0)?;
    commands.spawn((vent, Transform::from_xyz(0.0, 0.0, -80.0)));

    commands.spawn((
        DirectionalLight { illuminance: 20_000.0, shadow_maps_enabled: true, ..default() },
        Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::new(-0.5, -0.7, 0.3), Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        // The lava glows: an HDR camera with bloom shows it (`GlowCamera` sets both up).
        GlowCamera,
        VolcanoSkyCamera,
        Transform::from_xyz(60.0, 140.0, -20.0).looking_at(Vec3::new(0.0, 104.0, -70.0), Vec3::Y),
    ));
    Ok(())
}

/// Copies the nodes the frozen lava moved into the game's collider.
fn update_collider(
    mut changed: MessageReader<TerrainChanged>,
    terrains: Query<&Terrain>,
    mut collider: ResMut<Collider>,
) {
    for m in changed.read() {
        let Ok(terrain) = terrains.get(m.terrain) else { continue };
        let (r, heights) = (m.region, terrain.heights());
        let mut frozen = 0.0f64;
        for j in r.j0..r.j0 + r.nj {
            for i in r.i0..r.i0 + r.ni {
                let (new, old) = (heights.get(i, j), &mut collider.heights[j * N + i]);
                frozen += (new - *old) as f64 * CELL * CELL;
                *old = new;
            }
        }
        collider.updates += 1;
        info!(
            "collider update {}: {} × {} nodes from node ({}, {}); {:.1} L of lava froze onto them",
            collider.updates,
            r.ni,
            r.nj,
            r.i0,
            r.j0,
            1_000.0 * frozen
        );
    }
}
