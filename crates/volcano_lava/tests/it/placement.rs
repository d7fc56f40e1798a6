//! Lava placed by its entities' `Transform`s: a field, its source and a zone spawned 20 km
//! away (with the terrain under them) flow exactly as at the origin, shifted; moving a field's
//! entity rebuilds it where it now is.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_lava::*;

#[derive(Resource, Default, Debug)]
struct Reached(Vec<u64>);

fn record(mut seen: ResMut<Reached>, tick: Res<SimTick>, mut r: MessageReader<LavaReached>) {
    seen.0.extend(r.read().map(|_| tick.0));
}

/// What one run gives: the lava thickness and temperature of each cell, the grid's first cell
/// centre, the source's status and the ticks at which the zone was reached.
struct Outcome {
    thickness: Vec<f64>,
    temperature: Vec<f64>,
    origin: Vec2,
    source_active: bool,
    reached: Vec<u64>,
}

/// A 24 × 24 m field of 0.5 m cells on a stratovolcano's flank, fed 0.4 m³/s 6 m upslope of
/// its centre, with a 1 m zone 4 m downslope, everything moved by `shift` through the
/// entities' `Transform`s (the terrain too), run for `ticks` thesis ticks.
fn run_shifted(shift: Vec2, ticks: u64) -> Outcome {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .init_resource::<Reached>()
        .add_systems(FixedUpdate, record.in_set(SimSystems::End));
    let at = |x: f32, z: f32| Transform::from_xyz(x + shift.x, 0.0, z + shift.y);
    let terrain =
        StratovolcanoParams { resolution: 64, cell: 250.0, ..Default::default() }.generate().unwrap();
    app.world_mut().spawn((terrain, at(0.0, 0.0)));
    // On the south flank: downslope is +z.
    let field = app.world_mut().spawn((LavaField::square(48, 0.5).unwrap(), at(0.0, 2_000.0))).id();
    let source = app.world_mut().spawn((LavaSource::new(0.4).unwrap(), at(0.0, 1_994.0))).id();
    app.world_mut().spawn((LavaZone::new(Vec2::ZERO, 1.0).unwrap(), at(0.0, 2_004.0)));
    let target = ticks;
    while app.world().resource::<SimTick>().0 < target {
        app.update();
    }
    let w = app.world();
    assert_eq!(w.get::<LavaFieldStatus>(field), Some(&LavaFieldStatus::Ok));
    let state = w.get::<LavaState>(field).unwrap();
    Outcome {
        thickness: state.flow.thickness().data().to_vec(),
        temperature: state.flow.temperature().data().to_vec(),
        origin: state.flow.thickness().origin(),
        source_active: w.get::<LavaSourceStatus>(source) == Some(&LavaSourceStatus::Active(field)),
        reached: w.resource::<Reached>().0.clone(),
    }
}

#[test]
fn lava_spawned_twenty_km_away_flows_as_at_the_origin_shifted() {
    let ticks = 50 * 20;
    let home = run_shifted(Vec2::ZERO, ticks);
    let shift = Vec2::new(3_000.0, -20_000.0);
    let away = run_shifted(shift, ticks);
    assert!(home.source_active && away.source_active);
    assert_eq!(home.origin, Vec2::new(-11.75, 1_988.25), "the grid is centred on the entity");
    assert_eq!(away.origin, home.origin + shift, "the grid moved with the entity");
    let volume: f64 = home.thickness.iter().sum::<f64>() * 0.25;
    assert!((volume - 0.4 * 20.0).abs() < 0.5, "the source fed the field: {volume:.2} m³");
    assert_eq!(home.thickness, away.thickness, "same lava, cell for cell");
    assert_eq!(home.temperature, away.temperature);
    assert_eq!(home.reached.len(), 1, "the lava ran 4 m downslope into the zone");
    assert_eq!(home.reached, away.reached, "on the same tick");
}

#[test]
fn moving_the_field_entity_rebuilds_it_where_it_now_is() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, LavaPlugin))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)));
    app.world_mut().spawn(Terrain::flat(65, 1.0, 10.0).unwrap());
    let field = app.world_mut().spawn((LavaField::square(16, 1.0).unwrap(), Transform::default())).id();
    app.update();
    let origin = |app: &App| app.world().get::<LavaState>(field).map(|s| s.flow.thickness().origin());
    assert_eq!(origin(&app), Some(Vec2::splat(-7.5)));
    app.world_mut().get_mut::<Transform>(field).unwrap().translation = Vec3::new(10.0, 0.0, -4.0);
    app.update();
    assert_eq!(origin(&app), Some(Vec2::new(2.5, -11.5)));
    assert_eq!(app.world().get::<LavaFieldStatus>(field), Some(&LavaFieldStatus::Ok));
    // Off the terrain (it spans ±32 m): rejected with the reason, not built somewhere else.
    app.world_mut().get_mut::<Transform>(field).unwrap().translation = Vec3::new(40.0, 0.0, 0.0);
    app.update();
    assert!(app.world().get::<LavaState>(field).is_none());
    let status = app.world().get::<LavaFieldStatus>(field).unwrap();
    assert!(
        matches!(status, LavaFieldStatus::Rejected(why) if why.contains("no terrain contains")),
        "{status:?}"
    );
}

#[test]
fn the_short_constructors_validate_what_they_are_given() {
    let s = LavaSource::new(2.0).unwrap();
    assert_eq!((s.position, s.rate, s.temperature, s.radius), (Vec3::ZERO, 2.0, 1473.0, 0.0));
    assert!(LavaSource::new(-1.0).is_err());
    assert!(LavaSource::new(f64::NAN).is_err());
    assert!(s.clone().with_temperature(100.0).is_err(), "below 300 K");
    assert!(s.clone().with_radius(-1.0).is_err());
    assert!(s.clone().at(Vec3::new(0.0, 0.0, f32::INFINITY)).is_err());
    assert_eq!(s.with_radius(3.0).unwrap().radius, 3.0);
    assert!(LavaField::square(0, 1.0).is_err());
    assert!(LavaField::square(16, 0.0).is_err());
    assert_eq!(LavaField::square(16, 1.0).unwrap().placement.centre, Vec2::ZERO);
}
