//! Eruption styles across domains through `VolcanoSimPlugins`: a Hawaiian volcano's fountain
//! gas reaches the atmosphere over it, and one timeline runs a Plinian phase into an effusive
//! one.

use std::time::Duration;

use bevy::prelude::*;
use volcano::prelude::*;

fn run(app: &mut App, ticks: u64) {
    let target = app.world().resource::<SimTick>().0 + ticks;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
    }
}

#[test]
fn a_hawaiian_fountains_gas_goes_into_the_air_over_it() {
    let mut app = crate::worlds::sim_app(Duration::from_millis(100));
    let terrain = crate::worlds::small_island();
    let (vent, fountain) = hawaiian(20.0, 150.0).unwrap();
    app.world_mut().spawn((Volcano::new(60.0, 2).unwrap(), Transform::default(), vent, fountain));
    app.add_systems(Startup, move |mut commands: Commands| {
        crate::worlds::air_over(&mut commands, &terrain, 32);
        commands.spawn(terrain.clone());
    });
    run(&mut app, 50 * 8);
    let w = app.world_mut();
    let (state, sources) = w.query::<(&LavaFountainState, &AirHeatSources)>().single(w).unwrap();
    assert_eq!(state.error, None);
    let gas = sources.0.iter().find(|s| s.kind == AirHeatKind::Fountain).copied().unwrap();
    let books = *w.query::<&CouplingBudget>().single(w).unwrap();
    eprintln!("fountain {gas:?}; books {books:?}");
    // The weather stepped every second on the fountain's rates: its water (0.4 wt% of 20 m³/s
    // of 2,700 kg/m³ lava, 216 kg/s) for each second, and heat of the order of 10⁹ W.
    assert!((gas.vapour_kg_s - 216.0).abs() < 1e-6, "{gas:?}");
    let seconds = books.vapour_received_kg / gas.vapour_kg_s;
    assert!((4.0..=8.0).contains(&seconds), "{seconds} s of fountain gas");
    assert!(books.heat_received_j > 1e9 * seconds && books.heat_received_j < 1e11 * seconds, "{books:?}");
}

#[test]
fn a_timeline_runs_a_plinian_phase_into_an_effusive_one() {
    let mut app = crate::worlds::sim_app(Duration::from_millis(100));
    app.world_mut().spawn(crate::worlds::small_island());
    let timeline = EruptionTimeline::from_ron(
        "(keys: [(at_s: 0, active: Some(true), lava_rate: Some(0)), (at_s: 2, active: Some(false), \
         lava_rate: Some(0)), (at_s: 4, lava_rate: Some(8))])",
    )
    .unwrap();
    let volcano = app
        .world_mut()
        .spawn((
            Volcano::new(60.0, 2).unwrap(),
            Transform::default(),
            Eruption::plinian(),
            EruptionScript::new(timeline).unwrap(),
            LavaVent::effusive(0.0).unwrap(),
        ))
        .id();
    run(&mut app, 50);
    let w = app.world_mut();
    let slices = w.query_filtered::<(), With<PlumeSlice>>().iter(w).count();
    assert!(slices > 0, "no column in the Plinian phase");
    assert!(w.get::<Eruption>(volcano).unwrap().active);
    assert!(!w.get::<LavaVent>(volcano).unwrap().active);
    run(&mut app, 50 * 2);
    // At 3 s: the column has stopped, the lava ramps up (4 m³/s).
    let w = app.world();
    assert!(!w.get::<Eruption>(volcano).unwrap().active);
    let vent = w.get::<LavaVent>(volcano).unwrap();
    assert!(vent.active && (vent.rate - 4.0).abs() < 0.1, "{vent:?}");
    run(&mut app, 50 * 3);
    let w = app.world();
    let vent = w.get::<LavaVent>(volcano).unwrap();
    assert_eq!(vent.rate, 8.0);
    let status = w.get::<LavaVentStatus>(volcano).unwrap();
    assert_eq!(status.error, None);
    // 4 m³/s → 8 m³/s over 3–4 s, then 8: ≈ 2 + 8 + 8 m³ emitted by 6 s.
    assert!(status.emitted_m3 > 10.0 && status.emitted_m3 < 30.0, "{status:?}");
}
