//! What a game reads from its volcano: `cargo run --example gameplay`.
//!
//! The player (the red ball; the arrow keys walk it, the ground carries it) stands on the flank
//! of a volcano whose column collapses into pyroclastic flows, in air that carries its ash, below
//! a lava flow heading for the player's house. Each fixed step, after the volcano's base tick
//! (`SimSystems::End`), the game reads:
//! - messages: `PlumeCollapsed`, `PyroclasticFlowStarted`, `LavaReached` (the house's zone);
//! - queries at the player: the ash in the air (`air_ash_at`), whether a flow is on them and the
//!   deposit under their feet (`PyroclasticQuery`), the lava there (`LavaQuery`).
//!
//! The HUD is the game's own egui window.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};

use volcano::prelude::*;

/// The player; it walks on the ground at `SPEED` m/s.
#[derive(Component)]
struct Player;
const SPEED: f32 = 60.0;

/// What the HUD shows.
#[derive(Resource, Default)]
struct Hud {
    ash: f64,
    in_flow: bool,
    deposit: f64,
    lava: Option<LavaProbe>,
    log: Vec<String>,
}

fn main() -> AppExit {
    App::new()
        .add_plugins((DefaultPlugins, EguiPlugin::default(), VolcanoPlugins, VolcanoSkyPlugin))
        .init_resource::<Hud>()
        .add_systems(Startup, setup)
        .add_systems(Update, walk)
        .add_systems(FixedUpdate, (messages, at_the_player).after(SimSystems::End))
        .add_systems(EguiPrimaryContextPass, hud)
        .run()
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) -> Result {
    let terrain = StratovolcanoParams::default().generate()?;
    // Air over the volcano's terrain (the built-in five-layer `eruption` weather), so the
    // column's ash is carried and falls.
    AtmosphereSpawner::new(&WeatherScenario::builtin("eruption")?).over(&terrain).spawn(&mut commands)?;
    commands.spawn(terrain);
    // A column too heavy to rise: it collapses into pyroclastic flows down the flanks.
    commands.spawn((Volcano::new(100.0, 7)?, Eruption::pyroclastic(), Transform::default()));
    // A lava flow on the south flank, 256 m of 1 m cells, fed 3 m³/s near its upslope edge; the
    // player's house is a 15 m zone below it. Each is placed by its Transform.
    commands.spawn((LavaField::square(256, 1.0)?, Transform::from_xyz(1_721.0, 0.0, 2_457.0)));
    commands.spawn((LavaSource::new(3.0)?.with_radius(2.0)?, Transform::from_xyz(1_666.0, 0.0, 2_379.0)));
    commands.spawn((LavaZone::new(Vec2::ZERO, 15.0)?, Transform::from_xyz(1_721.0, 0.0, 2_520.0)));
    commands.spawn((
        Player,
        Mesh3d(meshes.add(Sphere::new(12.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.9, 0.1, 0.1))),
        Transform::from_xyz(1_750.0, 0.0, 2_600.0),
    ));
    commands.spawn((
        Camera3d::default(),
        VolcanoViewer,
        VolcanoSkyCamera,
        Transform::from_xyz(2_600.0, 1_800.0, 4_200.0).looking_at(Vec3::new(900.0, 900.0, 1_500.0), Vec3::Y),
    ));
    Ok(())
}

/// Arrow keys walk the player; the terrain's height keeps it on the ground (deposit and frozen
/// lava included).
fn walk(
    keys: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    terrains: Query<&Terrain>,
    mut player: Single<&mut Transform, With<Player>>,
) {
    let dir = |k: KeyCode| if keys.pressed(k) { 1.0 } else { 0.0 };
    let step = Vec2::new(
        dir(KeyCode::ArrowRight) - dir(KeyCode::ArrowLeft),
        dir(KeyCode::ArrowDown) - dir(KeyCode::ArrowUp),
    );
    let at = player.translation.xz() + step * SPEED * time.delta_secs();
    if let Some(t) = terrains.iter().find(|t| t.contains(at.x, at.y)) {
        player.translation = Vec3::new(at.x, t.height_at(at.x, at.y) + 12.0, at.y);
    }
}

/// The volcano's messages, in the same fixed step as its base tick.
fn messages(
    time: Res<Time<Fixed>>,
    mut hud: ResMut<Hud>,
    mut collapsed: MessageReader<PlumeCollapsed>,
    mut flows: MessageReader<PyroclasticFlowStarted>,
    mut lava: MessageReader<LavaReached>,
) {
    let t = time.elapsed_secs();
    if let Some(m) = collapsed.read().last() {
        hud.log.push(format!("{t:.0} s: the column collapsed at {:.0} m", m.position.y));
    }
    if let Some(m) = flows.read().last() {
        hud.log.push(format!("{t:.0} s: a pyroclastic flow of {:.1e} kg starts", m.mass));
    }
    for _ in lava.read() {
        hud.log.push(format!("{t:.0} s: lava reached the house!"));
    }
}

/// What is at the player: ash in the air, a flow, the deposit, lava.
fn at_the_player(
    mut hud: ResMut<Hud>,
    player: Single<&Transform, With<Player>>,
    atmospheres: Query<Entity, With<Atmosphere>>,
    layers: Query<&AirLayer>,
    flows: PyroclasticQuery,
    lava: LavaQuery,
) {
    let p = player.translation;
    hud.ash = atmospheres.iter().map(|a| air_ash_at(layers.iter(), a, p)).sum();
    hud.in_flow = flows.in_flow(p, 12.0);
    hud.deposit = flows.deposit_thickness(p.x, p.z);
    hud.lava = lava.at(p.xz()).filter(|l| l.thickness > 0.0);
}

fn hud(mut contexts: EguiContexts, hud: Res<Hud>) -> Result {
    egui::Window::new("Player").show(contexts.ctx_mut()?, |ui| {
        ui.label(format!("ash in the air: {:.3} g/m³", hud.ash));
        ui.label(format!("deposit underfoot: {:.2} m", hud.deposit));
        ui.label(if hud.in_flow { "IN A PYROCLASTIC FLOW" } else { "no flow here" });
        match &hud.lava {
            Some(l) => ui.label(format!("LAVA: {:.2} m at {:.0} K", l.thickness, l.surface_temperature)),
            None => ui.label("no lava here"),
        };
        for line in hud.log.iter().rev().take(6) {
            ui.label(line);
        }
    });
    Ok(())
}
