//! What several of this crate's app tests share: a headless app with the plume plugins at the
//! thesis' 50 Hz tick, the collapsing-cone world of the pyroclastic tests, and a runner.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_plume::{Eruption, PlumePlugin};

/// A headless app with the core and plume plugins, 50 Hz base ticks, `ticks_per_update` of
/// them per `update`.
pub fn plume_app(ticks_per_update: u32) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20) * ticks_per_update));
    app
}

/// A 12.8 km cone with a shallow crater, so a collapse (≈200 m wide) spills onto the flanks
/// instead of pooling, and `eruption` on a 100 m vent at its top (seed 5).
pub fn spawn_collapsing_cone(app: &mut App, eruption: Eruption) {
    let terrain = StratovolcanoParams {
        resolution: 128,
        cell: 100.0,
        crater_radius: 80.0,
        crater_depth: 10.0,
        ..Default::default()
    }
    .generate()
    .unwrap();
    app.world_mut().spawn(terrain);
    app.world_mut().spawn((Volcano::new(100.0, 5).unwrap(), eruption, Transform::default()));
}

/// Updates until `ticks` base ticks have been simulated.
pub fn run(app: &mut App, ticks: u64) {
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
}
