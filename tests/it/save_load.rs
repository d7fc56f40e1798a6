//! Saving a running eruption: the world of the `eruption` scene (column,
//! coupled five-layer atmosphere, lava patch on the flank) is copied into a `DynamicWorld`
//! (Bevy 0.19's `DynamicScene`) after 2 simulated seconds, written into a fresh app that has
//! only the plugins, and both apps then run the same ticks: slices, spheres, air layers, lava
//! and deposits must agree bit for bit. The weather step in flight is written back first
//! (`flush_weather`), in the world that is saved and therefore in both.
//!
//! Each of these faults makes it fail: entity references not mapped (the copied slices lose
//! their volcano and are removed), the domain clocks not reflected (the copy's weather steps at
//! other ticks), the lava field's build key holding the saved world's terrain entity (the copy
//! rebuilds its lava from scratch), and the atmosphere's pipeline component missing from the
//! copy (its weather never steps).

use bevy::prelude::*;
use bevy_world_serialization::{DynamicWorld, DynamicWorldBuilder};
use volcano::plume::{DepositMap, S1};
use volcano::prelude::*;

fn app() -> App {
    crate::worlds::sim_app(std::time::Duration::from_millis(20))
}

/// Every entity and resource of `world`, copied as docs/SAVING.md shows.
fn save(world: &World) -> DynamicWorld {
    let registry = world.resource::<AppTypeRegistry>().read();
    let entities: Vec<Entity> = world.iter_entities().map(|e| e.id()).collect();
    DynamicWorldBuilder::from_world(world, &registry)
        .extract_entities(entities.into_iter())
        .extract_resources()
        .build()
}

/// Everything the simulation holds that the test compares, as text (`Debug` prints every
/// float in full, so equal text is equal bits), each kind sorted by a stable key.
fn state(app: &mut App) -> Vec<String> {
    let w = app.world_mut();
    let mut out = Vec::new();
    let mut slices: Vec<(u64, String)> = w
        .query::<&PlumeSlice>()
        .iter(w)
        .map(|s| (s.index, format!("{:?} {}", s.state, s.ash_pending)))
        .collect();
    slices.sort_by_key(|s| s.0);
    out.extend(slices.into_iter().map(|s| s.1));
    let mut spheres: Vec<(u64, String)> =
        w.query::<&S1>().iter(w).map(|s| (s.id, format!("{:?} {}", s.sphere, s.spin))).collect();
    spheres.sort_by_key(|s| s.0);
    out.extend(spheres.into_iter().map(|s| s.1));
    let mut layers: Vec<(usize, String)> = w
        .query::<&volcano::atmosphere::AirLayer>()
        .iter(w)
        .map(|l| {
            (
                l.index,
                format!(
                    "{:?} {:?} {:?} {:?}",
                    l.fields.t.data(),
                    l.fields.h.data(),
                    l.fields.w.data(),
                    l.fields.ash.data()
                ),
            )
        })
        .collect();
    layers.sort_by_key(|l| l.0);
    out.extend(layers.into_iter().map(|l| l.1));
    for lava in w.query::<&volcano::lava::LavaState>().iter(w) {
        out.push(format!("{:?} {:?}", lava.flow.thickness().data(), lava.flow.budget()));
    }
    for deposit in w.query::<&DepositMap>().iter(w) {
        out.push(format!("{deposit:?}"));
    }
    out
}

#[test]
fn a_saved_eruption_continues_bit_for_bit() {
    let mut a = app();
    a.add_plugins(VolcanoScenePlugin::builtin("eruption").unwrap().headless());
    // 2 s: the column is rising, two weather steps have run, the lava is flowing.
    for _ in 0..100 {
        a.update();
    }
    volcano::atmosphere::flush_weather(a.world_mut());
    let saved = save(a.world());
    let mut b = app();
    b.update();
    let mut map = Default::default();
    saved.write_to_world(b.world_mut(), &mut map).unwrap();
    let before = state(&mut a);
    assert!(before.len() > 50, "only {} items: the scene did not run", before.len());
    assert_eq!(before, state(&mut b), "the copy holds the same state");
    for tick in 0..100 {
        a.update();
        b.update();
        if tick % 25 == 24 {
            let (sa, sb) = (state(&mut a), state(&mut b));
            let first = sa.iter().zip(&sb).position(|(x, y)| x != y);
            assert!(
                sa == sb,
                "tick {tick} after the copy: {} vs {} items, first difference at {first:?}",
                sa.len(),
                sb.len()
            );
        }
    }
}

/// Entity ids held inside the coupling's ash inbox (ash released since the last weather step,
/// with the volcano it came from) and in a lava source's status (the field it feeds) are
/// mapped like every other reference when a saved world is written into another one, where
/// the same ids mean other entities.
#[test]
fn references_in_the_ash_inbox_and_lava_sources_are_mapped() {
    use volcano::coupling::plugin::AshInbox;
    use volcano::lava::LavaSourceStatus;
    use volcano::plume::AshReleased;
    let mut a = app();
    a.update();
    let world = a.world_mut();
    let volcano = world.spawn(Name::new("volcano")).id();
    let field = world.spawn(Name::new("field")).id();
    let source = world.spawn((Name::new("source"), LavaSourceStatus::Active(field))).id();
    world.resource_mut::<AshInbox>().0.push(AshReleased { volcano, position: Vec3::ONE, mass: 2.0 });
    let saved = {
        let registry = world.resource::<AppTypeRegistry>().read();
        DynamicWorldBuilder::from_world(world, &registry)
            .extract_entities([volcano, field, source].into_iter())
            .extract_resources()
            .build()
    };
    let mut b = app();
    b.update();
    // Occupy the ids the saved entities had, so a reference left unmapped points elsewhere.
    for _ in 0..8 {
        b.world_mut().spawn(Name::new("the game's own"));
    }
    let mut map = Default::default();
    saved.write_to_world(b.world_mut(), &mut map).unwrap();
    let world = b.world_mut();
    let inbox = &world.resource::<AshInbox>().0;
    assert_eq!(inbox.len(), 1);
    assert_eq!(inbox[0].volcano, map[&volcano], "the inbox names the copied volcano");
    assert_eq!(world.get::<Name>(inbox[0].volcano).map(|n| n.as_str()), Some("volcano"));
    let status = world.get::<LavaSourceStatus>(map[&source]).unwrap();
    assert_eq!(*status, LavaSourceStatus::Active(map[&field]), "the source feeds the copied field");
}

/// A volcano's own lava (`LavaVent` → `TerrainLava` on the terrain, the vents' front tracks)
/// and its fountain (`LavaFountainState`: clots in flight and their random stream; the air heat
/// source) are saved with the world and continue bit for bit.
#[test]
fn saved_vent_lava_continues_bit_for_bit() {
    let spawn = |app: &mut App| {
        let terrain =
            volcano::lava::scenario::terrains::runout_valley((48, 96, 20.0), 6.0, 800.0, (6.0, 120.0), false)
                .unwrap();
        let top = terrain.heights().origin();
        app.world_mut().spawn(terrain);
        let at = Transform::from_xyz(top.x + 470.0, 0.0, top.y + 80.0);
        let (vent, fountain) = hawaiian(8.0, 60.0).unwrap();
        app.world_mut().spawn((Volcano::new(50.0, 1).unwrap(), at, vent, fountain));
    };
    let lava = |app: &mut App| -> Vec<String> {
        let w = app.world_mut();
        let mut out: Vec<String> = w
            .query::<&TerrainLava>()
            .iter(w)
            .map(|l| format!("{:?} {:?}", l.runout.tiles(), l.runout.budget()))
            .collect();
        out.extend(w.query::<&LavaVentStatus>().iter(w).map(|s| format!("{s:?}")));
        out.extend(
            w.query::<(&LavaFountainState, &AirHeatSources)>().iter(w).map(|(f, s)| format!("{f:?} {s:?}")),
        );
        out
    };
    let mut a = app();
    spawn(&mut a);
    for _ in 0..300 {
        a.update();
    }
    let saved = save(a.world());
    let mut b = app();
    b.update();
    saved.write_to_world(b.world_mut(), &mut Default::default()).unwrap();
    let before = lava(&mut a);
    assert!(before.len() == 3 && before[0].len() > 10_000, "the vent lava did not run: {before:?}");
    assert!(before[2].contains("Clot {"), "no clots in flight: {}", &before[2][..200.min(before[2].len())]);
    assert_eq!(before, lava(&mut b), "the copy holds the same vent lava");
    for _ in 0..100 {
        a.update();
        b.update();
    }
    assert_eq!(lava(&mut a), lava(&mut b), "both continue alike");
}
