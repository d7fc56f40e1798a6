//! Hawaiian fountains and sea entries through the plugin: a `LavaFountain` over a lava vent
//! throws clots as high as its exit speed says and gives the air its heat and magmatic water;
//! lava reaching the sea gives the air the steam its quench heat boils.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_lava::scenario::terrains::runout_valley;
use volcano_lava::vents::SEA_STEAM_ENTHALPY;
use volcano_lava::*;

fn app(terrain: Terrain, time_scale: f64) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(VentLavaSettings {
            time_scale,
            runout: RunoutSettings { refine: 2, ..Default::default() },
            ..Default::default()
        });
    app.world_mut().spawn(terrain);
    app
}

fn run(app: &mut App, ticks: u64) {
    let target = app.world().resource::<SimTick>().0 + ticks;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
    }
}

fn fountain_sources(app: &App, volcano: Entity) -> Vec<AirHeatSource> {
    app.world().get::<AirHeatSources>(volcano).map(|s| s.0.clone()).unwrap_or_default()
}

#[test]
fn a_fountain_over_a_vent_throws_clots_its_height_and_heats_the_air() {
    let terrain = runout_valley((64, 64, 20.0), 4.0, 500.0, (0.0, 0.0), false).unwrap();
    let mut app = app(terrain, 1.0);
    let volcano = app
        .world_mut()
        .spawn((
            Volcano::new(50.0, 3).unwrap(),
            Transform::from_xyz(0.0, 0.0, -200.0),
            LavaVent::effusive(10.0).unwrap(),
            LavaFountain::with_height(80.0).unwrap(),
            // A game's own source on the same entity is kept.
            AirHeatSources(vec![AirHeatSource {
                at: Vec3::new(500.0, 0.0, 0.0),
                heat_w: 1e6,
                vapour_kg_s: 0.0,
                radius_m: 5.0,
                kind: AirHeatKind::SeaEntry,
            }]),
        ))
        .id();
    let mut top: f32 = 0.0;
    for _ in 0..50 * 12 {
        app.update();
        let w = app.world();
        let ground = w.get::<VentPosition>(volcano).unwrap().0.y;
        let state = w.get::<LavaFountainState>(volcano).unwrap();
        assert_eq!(state.error, None);
        if let Some(f) = &state.fountain {
            top = f.clots().iter().map(|c| c.position.y as f32 - ground).fold(top, f32::max);
        }
    }
    // Clots thrown at the exit speed for 80 m through sea-level air top out there (the fastest
    // leave in a 6° cone); the vent is at ≈ 480 m, where the air is 4.5 % thinner and drags
    // less: a metre or two higher.
    assert!(top > 76.0 && top <= 82.0, "fountain top {top} m");
    let state = app.world().get::<LavaFountainState>(volcano).unwrap();
    let clots = state.fountain.as_ref().unwrap().clots().len();
    assert!(clots > 500, "{clots} clots in flight");
    let sources = fountain_sources(&app, volcano);
    assert_eq!(sources.len(), 2, "{sources:?}");
    let gas = sources.iter().find(|s| s.kind == AirHeatKind::Fountain).unwrap();
    eprintln!("fountain top {top:.1} m, {clots} clots in flight, air source {gas:?}");
    let kg_s = 10.0 * VentLavaSettings::default().params.density;
    assert!((gas.vapour_kg_s / (0.004 * kg_s) - 1.0).abs() < 1e-9, "{gas:?}");
    // Heat: the water's sensible heat (108 kg/s over ≈ 1,165 K: 2.5·10⁸ W) and the clots'
    // radiation (27 t/s of 20 cm clots cooling ≈ 24 K in flight: 7.7·10⁸ W); 1.0·10⁹ W in all.
    assert!(gas.heat_w > 5e8 && gas.heat_w < 2e9, "{gas:?}");
    // Stopped, the fountain's last clots fall and its source goes cold.
    app.world_mut().get_mut::<LavaVent>(volcano).unwrap().active = false;
    run(&mut app, 50 * 12);
    let state = app.world().get::<LavaFountainState>(volcano).unwrap();
    assert_eq!(state.fountain.as_ref().unwrap().clots().len(), 0);
    let gas = *fountain_sources(&app, volcano).iter().find(|s| s.kind == AirHeatKind::Fountain).unwrap();
    assert_eq!((gas.heat_w, gas.vapour_kg_s), (0.0, 0.0));
    // A fountain with no vent says why.
    let lone = app.world_mut().spawn((Volcano::new(50.0, 4).unwrap(), LavaFountain::default())).id();
    run(&mut app, 2);
    let e = app.world().get::<LavaFountainState>(lone).unwrap().error.clone();
    assert!(e.is_some_and(|e| e.contains("LavaVent")));
}

#[test]
fn lava_entering_the_sea_gives_the_air_the_steam_it_boils() {
    // A 6° slope reaching the sea 300 m below the vent.
    let terrain = runout_valley((32, 64, 20.0), 6.0, 36.0, (3.0, 60.0), true).unwrap();
    let top = terrain.heights().origin();
    let mut app = app(terrain, 60.0);
    let terrain = app.world_mut().query_filtered::<Entity, With<Terrain>>().single(app.world()).unwrap();
    app.world_mut().spawn((
        Volcano::new(50.0, 5).unwrap(),
        Transform::from_xyz(0.0, 0.0, top.y + 40.0),
        LavaVent::effusive(10.0).unwrap(),
    ));
    let mut steam: Vec<AirHeatSource> = Vec::new();
    for _ in 0..40 {
        run(&mut app, 50);
        steam = app.world().get::<AirHeatSources>(terrain).map(|s| s.0.clone()).unwrap_or_default();
        if !steam.is_empty() {
            break;
        }
    }
    let lava = app.world().get::<TerrainLava>(terrain).unwrap();
    let step = lava.last_step;
    assert!(step.quenched > 0.0, "no lava reached the sea: {step:?}");
    let laze = steam.first().expect("a sea entry source on the terrain");
    eprintln!("sea entry: {laze:?}, last step {step:?}");
    assert_eq!(laze.kind, AirHeatKind::SeaEntry);
    assert!(laze.at.y >= 0.0 && laze.at.z > top.y + 250.0, "{laze:?}");
    assert!((laze.vapour_kg_s * SEA_STEAM_ENTHALPY / laze.heat_w - 1.0).abs() < 1e-12);
    // The quench heat of lava at 10 m³/s is at most ρ Q (c_p ΔT + L) ≈ 4·10¹⁰ W.
    assert!(laze.heat_w > 1e7 && laze.heat_w < 5e10, "{laze:?}");
}
