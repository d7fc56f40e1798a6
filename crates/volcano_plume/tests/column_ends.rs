//! A running column is drawn with rounded ends (`volcano_plume::view::column_ends`, issue 18
//! item 1): the gathered parents hold one cap ahead of the leading slice and one behind the
//! newest, the same at every frame rate, and none when the settings turn them off.

mod common;

use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_plume::view::{CAP_ID_BIT, ColumnEndSettings, ParentSphere, gather_parents};
use volcano_plume::*;

fn erupting(ticks_per_update: u32) -> App {
    let mut app = common::plume_app(ticks_per_update);
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    app.world_mut().spawn((Volcano::new(100.0, 11).unwrap(), Eruption::plinian(), Transform::default()));
    // 28 s: a whole number of updates at 1, 5 and 7 ticks each.
    common::run(&mut app, 50 * 28);
    app
}

fn is_cap(p: &ParentSphere) -> bool {
    p.id & CAP_ID_BIT != 0
}

#[test]
fn a_rising_column_has_a_dome_ahead_of_its_front_and_a_cap_at_its_vent() {
    let mut app = erupting(5);
    let (_, parents) = gather_parents(app.world_mut());
    let caps: Vec<&ParentSphere> = parents.iter().filter(|p| is_cap(p)).collect();
    let slices: Vec<(u64, Vec3, f64)> = app
        .world_mut()
        .query::<(&PlumeSlice, &Transform)>()
        .iter(app.world())
        .map(|(s, t)| (s.index, t.translation, s.state.r))
        .collect();
    assert!(slices.len() > 50, "{} slices after 28 s", slices.len());
    assert_eq!(caps.len(), 2, "one continuous column: {caps:?}");
    let front = caps.iter().find(|c| c.id & 0xff == 0).expect("a front cap");
    let tail = caps.iter().find(|c| c.id & 0xff == 1).expect("a tail cap");
    // The front caps the oldest slice, above every slice; the tail the newest, at the vent.
    let oldest = slices.iter().min_by_key(|s| s.0).unwrap();
    let newest = slices.iter().max_by_key(|s| s.0).unwrap();
    assert_eq!((front.id & !CAP_ID_BIT) >> 8, oldest.0);
    assert_eq!((tail.id & !CAP_ID_BIT) >> 8, newest.0);
    let top = slices.iter().map(|s| s.1.y).fold(f32::MIN, f32::max);
    assert!(front.center.y > top, "front cap at {} m under the top slice at {top} m", front.center.y);
    assert!(
        tail.center.y < newest.1.y + 1.0,
        "tail cap at {} m, newest slice at {} m",
        tail.center.y,
        newest.1.y
    );
    // Sized from its slice.
    assert!((front.radius as f64 - 0.7 * oldest.2).abs() < 1e-3 * oldest.2, "{front:?} for r = {}", oldest.2);
}

#[test]
fn ends_are_frame_rate_independent_and_can_be_turned_off() {
    let mut a = erupting(1);
    let mut b = erupting(7);
    let (pa, pb) = (gather_parents(a.world_mut()).1, gather_parents(b.world_mut()).1);
    assert!(pa.iter().any(is_cap));
    assert_eq!(pa, pb);
    a.insert_resource(ColumnEndSettings { enabled: false, ..default() });
    let off = gather_parents(a.world_mut()).1;
    assert!(!off.is_empty() && !off.iter().any(is_cap));
    assert_eq!(off, pa.into_iter().filter(|p| !is_cap(p)).collect::<Vec<_>>());
}
