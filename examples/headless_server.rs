//! A volcano on a game server, with no window and no GPU:
//! `cargo run --example headless_server -- 120` (simulated seconds; default 60).
//!
//! `MinimalPlugins` + `VolcanoSimPlugins`: the whole simulation (plume, pyroclastic flows, lava,
//! atmosphere, coupling) without the render stack. The server prints the volcano's gameplay
//! messages as they come, and every ten simulated seconds how many slices the column has and
//! how high it stands. It steps the fixed clock by 1/50 s per update as fast as the CPU allows
//! (`TimeUpdateStrategy::ManualDuration`); a real server keeps Bevy's real-time clock instead.

use std::time::Duration;

use bevy::app::ScheduleRunnerPlugin;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::prelude::*;

/// Simulated seconds to run before exiting.
#[derive(Resource)]
struct RunFor(f64);

fn main() -> AppExit {
    let seconds = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(60.0);
    App::new()
        .add_plugins(MinimalPlugins.set(ScheduleRunnerPlugin::run_loop(Duration::ZERO)))
        .add_plugins(VolcanoSimPlugins)
        .insert_resource(Time::<Fixed>::from_hz(50.0))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)))
        .insert_resource(RunFor(seconds))
        .add_systems(Startup, setup)
        .add_systems(FixedUpdate, (print_messages, status).after(SimSystems::End))
        .run()
}

fn setup(mut commands: Commands) -> Result {
    commands.spawn(StratovolcanoParams::default().generate()?);
    // A column heavy enough to collapse: pyroclastic flows, then secondary columns.
    commands.spawn((
        Name::new("Volcano"),
        Volcano::new(100.0, 7)?,
        Eruption::pyroclastic(),
        Transform::default(),
    ));
    Ok(())
}

fn print_messages(
    time: Res<Time<Fixed>>,
    mut buoyant: MessageReader<NeutralBuoyancyReached>,
    mut umbrella: MessageReader<UmbrellaSpreading>,
    mut collapsed: MessageReader<PlumeCollapsed>,
    mut flows: MessageReader<PyroclasticFlowStarted>,
    mut secondary: MessageReader<SecondaryColumnFormed>,
) {
    let t = time.elapsed_secs_f64();
    // The first of each kind per tick is enough for a log.
    if let Some(m) = buoyant.read().last() {
        println!("{t:6.1} s  neutral buoyancy at {:.0} m above the vent ({:.0} m/s)", m.altitude, m.speed);
    }
    if let Some(m) = umbrella.read().last() {
        println!("{t:6.1} s  umbrella spreading from {:.0} m (neutral {:.0} m)", m.apex, m.neutral);
    }
    if let Some(m) = collapsed.read().last() {
        println!("{t:6.1} s  column collapsed at {:.0} m, {:.2e} kg", m.position.y, m.mass);
    }
    for m in flows.read() {
        println!("{t:6.1} s  pyroclastic flow: {} particles, {:.2e} kg", m.particles, m.mass);
    }
    for m in secondary.read() {
        println!("{t:6.1} s  secondary column lifts off at {:.0} m", m.position.y);
    }
}

fn status(
    time: Res<Time<Fixed>>,
    run_for: Res<RunFor>,
    slices: Query<&PlumeSlice>,
    vents: Query<&VentPosition>,
    mut exit: MessageWriter<AppExit>,
) {
    let t = time.elapsed_secs_f64();
    let tick = time.timestep().as_secs_f64();
    if (t / 10.0).fract() < tick / 10.0 {
        let top = slices.iter().map(|s| s.state.position.z).fold(0.0, f64::max);
        let vent = vents.iter().next().map_or(0.0, |v| v.0.y);
        println!(
            "{t:6.1} s  {} slices, column top {:.0} m above sea level",
            slices.iter().count(),
            vent as f64 + top
        );
    }
    if t >= run_for.0 {
        exit.write(AppExit::Success);
    }
}
