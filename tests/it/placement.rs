//! A volcano goes where the game puts it: the terrain and the volcano placed 20 km from the
//! origin by their entities' `Transform`s erupt exactly as at the origin, shifted.

use std::time::Duration;

use bevy::prelude::*;
use volcano::prelude::*;

const AWAY: Vec3 = Vec3::new(0.0, 0.0, -20_000.0);

/// `VolcanoSimPlugins` on `MinimalPlugins`, the procedural stratovolcano and a Plinian volcano
/// on its summit, both at `at`, after `updates` updates of one 20 ms base tick.
fn erupt(at: Vec3, updates: u32) -> App {
    let mut app = crate::worlds::sim_app(Duration::from_millis(20));
    let terrain =
        StratovolcanoParams { resolution: 128, cell: 300.0, ..Default::default() }.generate().unwrap();
    app.world_mut().spawn((terrain, Transform::from_translation(at)));
    app.world_mut().spawn((
        Volcano::new(100.0, 11).unwrap(),
        Eruption::plinian(),
        Transform::from_translation(at),
    ));
    for _ in 0..updates {
        app.update();
    }
    app
}

fn slices(app: &mut App) -> Vec<PlumeSlice> {
    let world = app.world_mut();
    let mut s: Vec<PlumeSlice> = world.query::<&PlumeSlice>().iter(world).cloned().collect();
    s.sort_by_key(|s| s.index);
    s
}

#[test]
fn an_eruption_20_km_away_is_the_one_at_the_origin_shifted() {
    let (mut home, mut away) = (erupt(Vec3::ZERO, 250), erupt(AWAY, 250));
    let vent = |app: &mut App| {
        let w = app.world_mut();
        w.query::<&VentPosition>().single(w).unwrap().0
    };
    let (v0, v1) = (vent(&mut home), vent(&mut away));
    assert!(v0.y > 2_000.0, "the vent is on the summit: {v0}");
    assert_eq!(v1, v0 + AWAY, "the vent sits on the moved terrain's summit");

    let (s0, s1) = (slices(&mut home), slices(&mut away));
    assert!(s0.len() > 10, "{} slices after 5 s", s0.len());
    assert_eq!(s0.len(), s1.len());
    for (a, b) in s0.iter().zip(&s1) {
        assert_eq!(a.index, b.index);
        assert_eq!(b.vent, a.vent + AWAY);
        // The column's state is in the vent's frame: the same to the bit.
        assert_eq!(a.state, b.state, "slice {}", a.index);
    }
    // Where the slices are drawn: the same, shifted (f32 world positions 20 km out round to
    // 2 mm).
    let world_positions = |app: &mut App| {
        let w = app.world_mut();
        let mut p: Vec<(u64, Vec3)> =
            w.query::<(&PlumeSlice, &Transform)>().iter(w).map(|(s, t)| (s.index, t.translation)).collect();
        p.sort_by_key(|(i, _)| *i);
        p
    };
    for ((i, a), (_, b)) in world_positions(&mut home).into_iter().zip(world_positions(&mut away)) {
        assert!((b - AWAY - a).length() < 0.01, "slice {i}: {a} at home, {b} away");
    }
}

#[test]
fn a_terrain_moved_after_spawning_carries_its_volcano() {
    let mut app = erupt(Vec3::ZERO, 5);
    let w = app.world_mut();
    let (terrain, _) = w.query::<(Entity, &Terrain)>().single(w).unwrap();
    let (volcano, _) = w.query::<(Entity, &Volcano)>().single(w).unwrap();
    let summit = w.query::<&VentPosition>().single(w).unwrap().0;
    w.get_mut::<Transform>(terrain).unwrap().translation = AWAY;
    w.get_mut::<Transform>(volcano).unwrap().translation = AWAY;
    app.update();
    let w = app.world_mut();
    assert_eq!(w.get::<VentPosition>(volcano).unwrap().0, summit + AWAY);
    assert_eq!(w.get::<Terrain>(terrain).unwrap().placement(), AWAY.xz());
}
