//! The small worlds several of these tests build: terrains, the weather over them, lava on a
//! flank and a collapsing eruption.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::lava::Placement;
use volcano::prelude::*;

/// A headless simulation at the thesis' 50 Hz, each update `frame` long (20 ms: one base tick
/// per update).
pub fn sim_app(frame: Duration) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins))
        .insert_resource(Time::<Fixed>::from_hz(volcano::core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(frame));
    app
}

/// A 12.8 km cone with a shallow crater, so a collapse spills onto the flanks.
pub fn collapsing_cone() -> Terrain {
    StratovolcanoParams { resolution: 128, cell: 100.0, crater_radius: 80.0, crater_depth: 10.0, ..default() }
        .generate()
        .unwrap()
}

/// A 12.8 km island of 65 × 65 nodes (cheap to step on).
pub fn small_island() -> Terrain {
    StratovolcanoParams { resolution: 65, cell: 200.0, ..default() }.generate().unwrap()
}

/// The `eruption` scenario's five-layer atmosphere over `terrain`, `grid` cells a side.
pub fn air_over(commands: &mut Commands, terrain: &Terrain, grid: usize) {
    AtmosphereSpawner::new(&WeatherScenario::builtin("eruption").unwrap())
        .over(terrain)
        .grid(grid)
        .spawn(commands)
        .unwrap();
}

/// A lava field at `placement` fed `rate` m³/s at `source` (world x, z) on `terrain`'s surface.
pub fn lava(commands: &mut Commands, terrain: &Terrain, placement: Placement, source: Vec2, rate: f64) {
    let y = terrain.height_at(source.x, source.y);
    commands.spawn(LavaField::new(placement, LavaParams::default()).unwrap());
    commands.spawn(LavaSource::new(rate).unwrap().at(Vec3::new(source.x, y, source.y)).unwrap());
}

/// The weather over `terrain` (16 cells a side) and a 32 × 32 lava field of 2 m cells fed
/// `rate` m³/s, downslope of world (1,500, 0) on the island's flank; returns that source.
pub fn air_and_flank_lava(commands: &mut Commands, terrain: &Terrain, rate: f64) -> Vec2 {
    air_over(commands, terrain, 16);
    let source = Vec2::new(1_500.0, 0.0);
    let placement = Placement::downslope_of(terrain, source, 32, 2.0).unwrap();
    lava(commands, terrain, placement, source, rate);
    source
}

/// A pyroclastic eruption, erupting from the start.
pub fn collapsing_eruption() -> Eruption {
    let mut eruption = Eruption::pyroclastic();
    eruption.active = true;
    eruption
}
