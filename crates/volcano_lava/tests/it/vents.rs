//! A volcano's own lava through the plugin: a `LavaVent` on a `Volcano` feeds a runout on the
//! terrain it stands on; the frozen lava goes into that terrain; zones, fronts and the
//! vent's status follow the flow.

use std::time::Duration;

use bevy::ecs::message::Messages;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_core::terrain::TerrainChanged;
use volcano_lava::scenario::terrains::runout_valley;
use volcano_lava::*;

fn run(app: &mut App, ticks: u64) {
    let target = app.world().resource::<SimTick>().0 + ticks;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
    }
}

fn count<M: Message>(app: &App) -> usize {
    app.world().resource::<Messages<M>>().iter_current_update_messages().count()
}

#[test]
fn a_vent_on_a_volcano_runs_lava_down_its_terrain_and_into_it() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ));
    // A 1.3 × 2.6 km valley of 20 m nodes at 6°, a gully along it.
    let terrain = runout_valley((64, 128, 20.0), 6.0, 800.0, (6.0, 120.0), false).unwrap();
    let top = terrain.heights().origin();
    let vent_xz = Vec2::new(top.x + 0.5 * 63.0 * 20.0, top.y + 80.0);
    let terrain = app.world_mut().spawn(terrain).id();
    let volcano = app
        .world_mut()
        .spawn((Volcano::new(50.0, 1).unwrap(), Transform::from_xyz(vent_xz.x, 0.0, vent_xz.y)))
        .id();
    app.world_mut().entity_mut(volcano).insert(LavaVent::effusive(8.0).unwrap());
    // A zone 60 m down the gully.
    let zone =
        app.world_mut().spawn(LavaZone::new(Vec2::new(vent_xz.x, vent_xz.y + 60.0), 10.0).unwrap()).id();
    let (mut opened, mut fronts, mut reached, mut changed) = (0, 0, 0, 0);
    // Two simulated minutes at 50 Hz, the messages of every update counted.
    let target = app.world().resource::<SimTick>().0 + 6000;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
        opened += count::<LavaVentOpened>(&app);
        fronts += count::<LavaFlowFront>(&app);
        reached += count::<LavaReached>(&app);
        changed += count::<TerrainChanged>(&app);
    }
    let w = app.world();
    let status = w.get::<LavaVentStatus>(volcano).unwrap();
    assert_eq!(status.error, None);
    assert!((status.emitted_m3 - 8.0 * 120.0).abs() < 1.0, "{status:?}");
    assert!(status.runout_m > 70.0 && !status.stopped, "{status:?}");
    let front = status.front.unwrap();
    assert!(front.y > vent_xz.y + 60.0, "the front runs downslope: {front} from {vent_xz}");
    assert_eq!(opened, 1);
    assert!(fronts >= 5, "{fronts} front messages");
    assert_eq!(reached, 1);
    assert!(w.get::<LavaZone>(zone).unwrap().reached);
    // Mass: fed = liquid + frozen (+ outflow); the terrain holds exactly the frozen lava.
    let lava = w.get::<TerrainLava>(terrain).expect("the plugin put the runout on the terrain");
    let b = *lava.runout.budget();
    assert!(b.error_rel(lava.runout.lava_volume()) < 1e-12, "{b:?}");
    assert!(b.solidified > 0.0, "{b:?}");
    let t = w.get::<Terrain>(terrain).unwrap();
    assert!((t.added_volume() - b.solidified).abs() <= 1e-9 * b.solidified, "{} vs {b:?}", t.added_volume());
    assert!(changed > 0, "TerrainChanged for the frozen margins");
    // `LavaQuery` probes the vent lava: hot and thick at the vent, nothing far off the flow.
    let probe = |app: &mut App, at: Vec2| {
        let mut state = bevy::ecs::system::SystemState::<LavaQuery>::new(app.world_mut());
        state.get(app.world()).unwrap().at(at)
    };
    let at_vent = probe(&mut app, vent_xz).expect("lava at the vent");
    assert!(at_vent.thickness > 0.05 && at_vent.temperature > 1300.0, "{at_vent:?}");
    assert_eq!(at_vent.field, terrain);
    assert!(at_vent.surface_temperature < at_vent.temperature && at_vent.crust > 0.0, "{at_vent:?}");
    let down = probe(&mut app, vent_xz + Vec2::new(0.0, 40.0)).expect("lava 40 m down the gully");
    assert!(down.surface_speed > 0.01, "{down:?}");
    let off = probe(&mut app, vent_xz + Vec2::new(500.0, 0.0));
    assert!(off.is_none_or(|p| p.thickness == 0.0), "{off:?}");
    let w = app.world();
    let lava = w.get::<TerrainLava>(terrain).unwrap();
    let (frozen, time) = (b.solidified, lava.runout.time());
    // The vent stops: the lava it left keeps flowing, cooling and freezing.
    app.world_mut().get_mut::<LavaVent>(volcano).unwrap().active = false;
    run(&mut app, 3000);
    let w = app.world();
    let lava = w.get::<TerrainLava>(terrain).unwrap();
    let b = *lava.runout.budget();
    assert!((lava.runout.time() - time - 60.0).abs() < 0.1, "{} then {}", time, lava.runout.time());
    assert!(b.solidified > frozen, "{b:?}");
    assert!((w.get::<LavaVentStatus>(volcano).unwrap().emitted_m3 - 8.0 * 120.0).abs() < 1.0);
}

#[test]
fn a_bad_vent_says_why_and_emits_nothing() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ));
    app.world_mut().spawn(runout_valley((32, 32, 20.0), 6.0, 300.0, (0.0, 0.0), false).unwrap());
    let bad = LavaVent { rate: f64::NAN, ..Default::default() };
    let volcano = app.world_mut().spawn((Volcano::default(), Transform::default(), bad)).id();
    // A volcano with no terrain under it.
    let off = app
        .world_mut()
        .spawn((Volcano::default(), Transform::from_xyz(1e5, 0.0, 0.0), LavaVent::default()))
        .id();
    run(&mut app, 100);
    let w = app.world();
    let s = w.get::<LavaVentStatus>(volcano).unwrap();
    assert!(s.error.as_deref().is_some_and(|e| e.contains("rate")), "{s:?}");
    assert_eq!(s.emitted_m3, 0.0);
    let s = w.get::<LavaVentStatus>(off).unwrap();
    assert!(s.error.is_some() && s.emitted_m3 == 0.0, "{s:?}");
    assert!(LavaVent::effusive(-1.0).is_err());
}

/// A step that would take more than `substep_budget` cell-substeps is shortened: the lava clock
/// falls behind the scaled game clock by what was not simulated, the vent emits for the time
/// that was, and the books close; with the default budget it never acts here.
#[test]
fn a_tight_substep_budget_slows_the_lava_clock_and_keeps_the_books() {
    let run = |budget: u64| {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
            .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
            .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
            .insert_resource(VentLavaSettings {
                time_scale: 60.0,
                substep_budget: budget,
                ..Default::default()
            });
        let terrain = runout_valley((64, 128, 20.0), 6.0, 800.0, (6.0, 120.0), false).unwrap();
        let top = terrain.heights().origin();
        let terrain = app.world_mut().spawn(terrain).id();
        let volcano = app
            .world_mut()
            .spawn((
                Volcano::new(50.0, 1).unwrap(),
                Transform::from_xyz(top.x + 630.0, 0.0, top.y + 80.0),
                LavaVent::effusive(8.0).unwrap(),
            ))
            .id();
        run(&mut app, 50 * 10);
        let w = app.world();
        let lava = w.get::<TerrainLava>(terrain).unwrap().clone();
        let emitted = w.get::<LavaVentStatus>(volcano).unwrap().emitted_m3;
        (lava, emitted)
    };
    let (free, free_emitted) = run(VentLavaSettings::default().substep_budget);
    let (tight, tight_emitted) = run(10_000);
    eprintln!(
        "default budget: {:.0} s simulated, {:.1} s behind; 10⁴: {:.0} s simulated, {:.1} s behind",
        free.runout.time(),
        free.behind_s,
        tight.runout.time(),
        tight.behind_s
    );
    assert_eq!(free.behind_s, 0.0);
    assert!(tight.behind_s > 1.0, "the budget never acted: {}", tight.behind_s);
    // Simulated + behind = the scaled game clock (the runout starts a tick after the vent).
    assert!((tight.runout.time() + tight.behind_s - free.runout.time()).abs() < 1e-6);
    for (lava, emitted) in [(&free, free_emitted), (&tight, tight_emitted)] {
        assert!((emitted - 8.0 * lava.runout.time()).abs() < 1e-6 * emitted, "{emitted} m³");
        assert!(lava.runout.budget().error_rel(lava.runout.lava_volume()) < 1e-12);
    }
    assert!(tight_emitted < free_emitted);
}
