//! A volcano in someone else's game: `cargo run --example embed_in_game`.
//!
//! Written from `App::new()` up the way a game would: the game's own fixed rate (64 Hz, Bevy's
//! default, stated), camera, sun, ambient light, terrain and egui; `VolcanoPlugins` adds the
//! simulation and its visuals and changes none of those. The game spawns a `Volcano` with an
//! `Eruption`, an atmosphere over it (so the column couples, heats and moistens the air and its
//! ash is carried and settled), a lava patch on the flank with a `LavaZone` around the
//! player's house, and reads gameplay messages (column collapsed, umbrella spreading, lava
//! reached the house) plus the ash in the air at the player, in a system ordered after the
//! volcano's base tick (`SimSystems::End`). The HUD is the game's own egui window.
//!
//! Assets: the terrain is a 16-bit heightmap loaded through the asset server
//! (`HeightmapSource`, here the bundled `embedded://volcano/terrain/stratovolcano.height.png`;
//! a game points it at its own `assets/…height.png`), and the eruption follows a timeline asset
//! (`EruptionTimelineSource`: a Plinian minute, a 30 s weakening, a collapse into pyroclastic
//! flows, the end at 5 minutes). What needs the ground (the volcano, its air, the lava) is
//! spawned when the terrain arrives.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};
use volcano::atmosphere::WeatherScenario;
use volcano::plume::{PlumeCollapsed, UmbrellaSpreading};
use volcano::prelude::*;
use volcano::render::VolcanoViewer;

/// The player stands here (world metres): 6 km east of the vent, downwind of the low layers.
const PLAYER: Vec3 = Vec3::new(6_000.0, 900.0, 0.0);

/// What the game shows in its HUD.
#[derive(Resource, Default)]
struct GameLog {
    lines: Vec<String>,
    ash_at_player: f64,
    umbrella_seen: bool,
}

fn main() -> AppExit {
    let mut app = App::new();
    app.add_plugins(DefaultPlugins)
        // The game's own egui, added before the volcano (after works as well).
        .add_plugins(EguiPlugin::default())
        // The game's fixed rate; the volcano follows it and never changes it.
        .insert_resource(Time::<Fixed>::from_hz(64.0))
        .add_plugins(VolcanoPlugins)
        .init_resource::<GameLog>()
        .add_systems(Startup, setup)
        .add_systems(Update, on_terrain_loaded)
        // Gameplay reads the volcano after its base tick, in the same fixed step.
        .add_systems(FixedUpdate, watch_the_volcano.after(SimSystems::End))
        .add_systems(EguiPrimaryContextPass, hud);
    // `VOLCANO_SCREENSHOT=out.png` (e.g. under xvfb-run) saves a frame and exits: how this
    // example is checked without a display. A game leaves it out.
    if let Some(capture) = volcano::render::WindowScreenshotPlugin::from_env() {
        app.add_plugins(capture);
    }
    app.run()
}

fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    // The game's world: its terrain (a heightmap asset), sun, ambient light and camera.
    commands.spawn((
        Name::new("Island"),
        HeightmapSource(assets.load("embedded://volcano/terrain/stratovolcano.height.png")),
    ));
    commands.spawn((
        DirectionalLight { illuminance: 100_000.0, shadow_maps_enabled: true, ..default() },
        Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::new(-0.6, -0.5, 0.4), Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight { brightness: 800.0, ..default() });
    commands.insert_resource(ClearColor(Color::srgb(0.55, 0.7, 0.9)));
    commands.spawn((
        Camera3d::default(),
        // Full sunlight needs a daylight exposure (Bevy's default suits indoor light).
        bevy::camera::Exposure::SUNLIGHT,
        // The marker tells the volcano which camera its ash billboards face.
        VolcanoViewer,
        Transform::from_xyz(16_000.0, 4_000.0, 22_000.0).looking_at(Vec3::new(0.0, 5_000.0, 0.0), Vec3::Y),
    ));
}

/// Once the heightmap has loaded: the volcano, the air over it and a lava patch on its flank.
fn on_terrain_loaded(
    mut commands: Commands,
    assets: Res<AssetServer>,
    terrains: Query<&Terrain, Added<Terrain>>,
    mut log: ResMut<GameLog>,
) {
    let Some(terrain) = terrains.iter().next() else { return };
    // The volcano: its vent snaps to the terrain under the entity's x/z; its story is a
    // timeline asset.
    match Volcano::new(100.0, 42) {
        Ok(v) => {
            commands.spawn((
                Name::new("Volcano"),
                v,
                Eruption::plinian(),
                EruptionTimelineSource(
                    assets.load("embedded://volcano/timelines/plinian_to_collapse.timeline.ron"),
                ),
                Transform::default(),
            ));
        }
        Err(e) => log.lines.push(format!("no volcano: {e}")),
    }
    // Air over it: the built-in five-layer scenario of the `eruption` scene, over this terrain.
    let air = WeatherScenario::builtin("eruption")
        .and_then(|scenario| AtmosphereSpawner::new(&scenario).over(terrain).spawn(&mut commands));
    if let Err(e) = air {
        log.lines.push(format!("no atmosphere: {e}"));
    }
    // A lava patch on the flank facing the camera (256 × 256 cells of 1 m), fed 3 m³/s near its
    // upslope edge, and a zone around the player's house below it, each placed by its Transform.
    let mut lava = || -> Result<(), ConfigError> {
        let field = LavaField::square(256, 1.0)?;
        commands.spawn((Name::new("Lava field"), field, Transform::from_xyz(1_721.0, 0.0, 2_457.0)));
        let vent = LavaSource::new(3.0)?.with_radius(2.0)?;
        commands.spawn((Name::new("Lava vent"), vent, Transform::from_xyz(1_666.0, 0.0, 2_379.0)));
        let house = LavaZone::new(Vec2::ZERO, 15.0)?;
        commands.spawn((Name::new("Player's house"), house, Transform::from_xyz(1_721.0, 0.0, 2_520.0)));
        Ok(())
    };
    if let Err(e) = lava() {
        log.lines.push(format!("no lava: {e}"));
    }
}

/// Gameplay: messages from the volcano and the ash in the air at the player.
fn watch_the_volcano(
    mut log: ResMut<GameLog>,
    mut collapsed: MessageReader<PlumeCollapsed>,
    mut umbrella: MessageReader<UmbrellaSpreading>,
    mut lava: MessageReader<LavaReached>,
    atmospheres: Query<Entity, With<Atmosphere>>,
    layers: Query<&AirLayer>,
    fixed: Res<Time<Fixed>>,
) {
    // The game's fixed clock (the volcano's own clocks can be paused or sped up apart).
    let t = fixed.elapsed_secs_f64();
    for m in collapsed.read() {
        log.lines.push(format!("{t:.0} s: the column collapsed at {:.0} m", m.position.y));
    }
    for m in umbrella.read() {
        if !log.umbrella_seen {
            log.umbrella_seen = true;
            log.lines.push(format!("{t:.0} s: the umbrella spreads from {:.0} m", m.apex));
        }
    }
    for _ in lava.read() {
        log.lines.push(format!("{t:.0} s: lava reached the house!"));
    }
    log.ash_at_player = atmospheres.iter().map(|a| air_ash_at(layers.iter(), a, PLAYER)).sum();
}

/// The game's own HUD.
fn hud(mut contexts: EguiContexts, log: Res<GameLog>) -> Result {
    egui::Window::new("Game").show(contexts.ctx_mut()?, |ui| {
        ui.label(format!("ash in the air at the player: {:.3} g/m³", log.ash_at_player));
        for line in log.lines.iter().rev().take(8) {
            ui.label(line);
        }
    });
    Ok(())
}
