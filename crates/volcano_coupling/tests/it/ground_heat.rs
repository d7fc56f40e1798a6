//! Heat and vapour from the ground (a sea entry's laze, a fountain's gas) through the ECS: an
//! `AirHeatSources` over an atmosphere heats and wets its layers by exactly what it gives, and
//! its steam condenses where the plume spreads.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_atmosphere::{
    AirLayer, AtmospherePlugin, GridSpec, WeatherScenario, WeatherStep, spawn_scenario,
};
use volcano_core::prelude::*;
use volcano_coupling::{CouplingBudget, CouplingPlugin};
use volcano_plume::PlumePlugin;

/// Still air over flat ground at sea level, dry but for a layer near saturation at 3 km: 40 km,
/// 32 cells, 1 s weather steps.
fn still_air() -> WeatherScenario {
    let text = "Scenario(name: \"still\", grid: 32, extent_m: 40000.0, dt: 1.0, steps: 1, start_hour: 12.0, \
         day_of_year: 172.0, latitude_deg: 0.0, profile: Thesis, terrain: Flat(height_m: 0.0, cover: Ground), \
         layers: [(altitude_m: 500.0), (altitude_m: 1500.0), (altitude_m: 3000.0, relative_humidity: (base: 0.995)), (altitude_m: 5000.0), \
         (altitude_m: 8000.0)])";
    ron::from_str(text).expect("valid scenario")
}

/// A sea entry's laze: 2·10¹⁰ W and `steam` kg/s at the world origin.
fn laze(steam: f64) -> AirHeatSources {
    AirHeatSources(vec![AirHeatSource {
        at: Vec3::ZERO,
        heat_w: 2e10,
        vapour_kg_s: steam,
        radius_m: 200.0,
        kind: AirHeatKind::SeaEntry,
    }])
}

/// Runs a minute of weather with `sources`; returns the books, the layers (by index) and the
/// weather seconds run.
fn run(sources: AirHeatSources) -> (CouplingBudget, Vec<AirLayer>, f64) {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        VolcanoCorePlugin,
        PlumePlugin,
        AtmospherePlugin::default(),
        CouplingPlugin,
    ))
    .insert_resource(Time::<Fixed>::from_hz(50.0))
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)));
    app.world_mut().spawn(Terrain::flat(65, 200.0, 0.0).unwrap());
    app.world_mut().spawn(sources);
    app.add_systems(Startup, |mut commands: Commands| {
        spawn_scenario(&mut commands, &still_air(), None).unwrap();
    });
    while app.world().resource::<SimTick>().0 < 50 * 60 {
        app.update();
    }
    let world = app.world_mut();
    let steps = world.resource::<Time<DomainClock<WeatherStep>>>().context().steps_run();
    let budget = *world.query::<&CouplingBudget>().single(world).unwrap();
    let mut layers: Vec<AirLayer> = world.query::<&AirLayer>().iter(world).cloned().collect();
    layers.sort_by_key(|l| l.index);
    (budget, layers, steps as f64)
}

#[test]
fn a_laze_plume_gives_the_air_its_heat_and_steam_and_the_steam_condenses_aloft() {
    let (books, layers, seconds) = run(laze(7_000.0));
    assert!(seconds >= 55.0, "{seconds} weather steps");
    // The books: every second of the source, to rounding (the transfer before each step gives
    // that step's seconds; the last one may still be in flight).
    let given = books.vapour_received_kg / 7_000.0;
    assert!((given - seconds).abs() <= 1.0 + 1e-9, "{given} s of steam for {seconds} weather steps");
    assert!((books.heat_received_j / 2e10 - given).abs() < 1e-9 * given);
    assert_eq!((books.heat_outflow_j, books.vapour_outflow_kg), (0.0, 0.0));
    // 2·10¹⁰ W in this profile rises ≈ 3 km and spreads at ≈ 2.3 km (layer 2, at 99.5 % relative
    // humidity): the steam (≈ 0.04 g/m³ a minute in 1.25 km cells) condenses there, over the
    // source; none far away, traces at most in the dry layers (exchanged with the wet one).
    let grid = GridSpec::new(32, 1_250.0).unwrap();
    let (near, far): (Vec<f64>, Vec<f64>) = layers
        .iter()
        .map(|l| {
            let mut near: f64 = 0.0;
            let mut far: f64 = 0.0;
            for (k, &w) in l.fields.w.data().iter().enumerate() {
                let (x, z) = grid.centre(k);
                if x.hypot(z) < 2_500.0 {
                    near = near.max(w);
                } else if x.hypot(z) > 10_000.0 {
                    far = far.max(w);
                }
            }
            (near, far)
        })
        .unzip();
    eprintln!("condensed water (g/m³), max near / far per layer: {near:?} / {far:?}");
    assert!(near[2] > 0.0, "no cloud where the laze spreads: {near:?}");
    assert!(far.iter().all(|&w| w == 0.0), "{far:?}");
    let elsewhere = [near[0], near[1], near[3], near[4]].into_iter().fold(0.0, f64::max);
    assert!(near[2] > 100.0 * elsewhere, "{near:?}");
    // Heat alone (no steam) makes no cloud: it warms the air it rises through.
    let (_, dry, _) = run(laze(0.0));
    assert!(dry.iter().all(|l| l.fields.w.data().iter().all(|&w| w == 0.0)));
    // 27 % of 2·10¹⁰ W in four 1.25 km × 1.5 km cells of layer 1 is ≈ 2·10⁻³ K/s before the air
    // relaxes and mixes: tenths of a kelvin at most, and only over the source.
    let excess = |near: bool| {
        let l = &dry[1].fields;
        (0..grid.cells())
            .filter(|&k| (grid.centre(k).0.hypot(grid.centre(k).1) < 2_500.0) == near)
            .map(|k| l.t.data()[k] - l.t_ref)
            .fold(f32::MIN, f32::max)
    };
    assert!(
        excess(true) > 0.02 && excess(false) < 0.005,
        "{} K over the source, {} K elsewhere",
        excess(true),
        excess(false)
    );
}
