//! Three volcanoes on three islands, each placed by its entities' `Transform`s:
//! `cargo run --example many_volcanoes`.
//!
//! Each island is a procedural stratovolcano (20 km across) spawned at its own translation;
//! its volcano is spawned at the same x/z and its vent lands on that island's summit. The
//! three eruptions (a Plinian column, a collapsing column with pyroclastic flows, the
//! physical column of the measured eruptions) share nothing but the clock; the game tells
//! their messages apart by the `volcano` entity they carry.

use bevy::prelude::*;
use volcano::prelude::*;

/// Where the islands stand (world x, z; m) and what their volcanoes do.
const ISLANDS: [(f32, f32, &str); 3] =
    [(-22_000.0, 0.0, "Plinian"), (0.0, -8_000.0, "collapsing"), (22_000.0, 0.0, "physical")];

fn main() -> AppExit {
    App::new()
        .add_plugins((DefaultPlugins, VolcanoPlugins, VolcanoSkyPlugin))
        .add_systems(Startup, setup)
        .add_systems(FixedUpdate, report.after(SimSystems::End))
        .run()
}

fn setup(mut commands: Commands) -> Result {
    for (i, (x, z, kind)) in ISLANDS.into_iter().enumerate() {
        let island = StratovolcanoParams { resolution: 256, cell: 80.0, seed: 7 + i as u32, ..default() };
        commands.spawn((
            Name::new(format!("Island {i}")),
            island.generate()?,
            Transform::from_xyz(x, 0.0, z),
        ));
        let eruption = match kind {
            "Plinian" => Eruption::plinian(),
            "collapsing" => Eruption::pyroclastic(),
            _ => Eruption::physical(),
        };
        commands.spawn((
            Name::new(format!("{kind} volcano")),
            Volcano::new(100.0, 40 + i as u64)?,
            eruption,
            Transform::from_xyz(x, 0.0, z),
        ));
    }
    commands.spawn((
        Camera3d::default(),
        VolcanoViewer,
        VolcanoSkyCamera,
        Transform::from_xyz(0.0, 9_000.0, 60_000.0).looking_at(Vec3::new(0.0, 6_000.0, 0.0), Vec3::Y),
    ));
    Ok(())
}

/// Which volcano did what: each message names its volcano entity.
fn report(
    names: Query<&Name>,
    mut umbrella: MessageReader<UmbrellaSpreading>,
    mut collapsed: MessageReader<PlumeCollapsed>,
    mut seen: Local<Vec<Entity>>,
) {
    let name = |e: Entity| names.get(e).map_or("?".to_string(), |n| n.to_string());
    for m in umbrella.read() {
        if !seen.contains(&m.volcano) {
            seen.push(m.volcano);
            info!("{}: the umbrella spreads from {:.0} m above the vent", name(m.volcano), m.apex);
        }
    }
    if let Some(m) = collapsed.read().last() {
        info!("{}: the column collapsed at {:.0} m", name(m.volcano), m.position.y);
    }
}
