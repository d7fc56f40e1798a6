//! The smallest game with a volcano: `cargo run --example hello_volcano`.
use bevy::prelude::*;
use volcano::prelude::*;

fn main() -> AppExit {
    App::new()
        // The simulation and its visuals, and (opt-in) a sun and sky for a scene without its own.
        .add_plugins((DefaultPlugins, VolcanoPlugins, VolcanoSkyPlugin))
        .add_systems(Startup, setup)
        .run()
}

/// The world: a terrain, a volcano on it and a camera.
pub fn setup(mut commands: Commands) -> Result {
    // The ground: a procedural stratovolcano (a game can load its own heightmap instead).
    commands.spawn(StratovolcanoParams::default().generate()?);
    // The volcano (vent radius 100 m, seed 42) and what it does: a Plinian eruption. Its vent
    // sits on the terrain under the entity's x/z.
    commands.spawn((Volcano::new(100.0, 42)?, Eruption::plinian(), Transform::default()));
    // The game's camera; `VolcanoViewer` is the one the ash faces, `VolcanoSkyCamera` gets the sky.
    commands.spawn((
        Camera3d::default(),
        VolcanoViewer,
        VolcanoSkyCamera,
        Transform::from_xyz(16_000.0, 4_000.0, 22_000.0).looking_at(Vec3::new(0.0, 5_000.0, 0.0), Vec3::Y),
    ));
    Ok(())
}
