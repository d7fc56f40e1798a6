//! The plume plugin on a headless app: collapse vs umbrella regimes, messages, mass per slice,
//! and frame-rate independence.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_plume::*;

#[derive(Resource, Default, Debug)]
struct Seen {
    collapsed: usize,
    neutral: usize,
    umbrella: usize,
    apex: f64,
    collapse_heights: Vec<f32>,
}

fn count(
    mut seen: ResMut<Seen>,
    mut c: MessageReader<PlumeCollapsed>,
    mut n: MessageReader<NeutralBuoyancyReached>,
    mut u: MessageReader<UmbrellaSpreading>,
) {
    for m in c.read() {
        seen.collapsed += 1;
        seen.collapse_heights.push(m.position.y);
    }
    seen.neutral += n.read().count();
    for m in u.read() {
        seen.umbrella += 1;
        seen.apex = m.apex;
    }
}

fn app(eruption: Eruption, ticks_per_update: u32) -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, PlumePlugin))
        .insert_resource(Time::<Fixed>::from_hz(volcano_core::units::THESIS_TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20) * ticks_per_update))
        .init_resource::<Seen>()
        .add_systems(FixedUpdate, count.in_set(SimSystems::End));
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    app.world_mut().spawn((Volcano::new(100.0, 11).unwrap(), eruption, Transform::default()));
    app
}

fn run(app: &mut App, ticks: u64) {
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
}

#[test]
fn thesis_preset_collapses_and_emits_at_the_thesis_rate() {
    let mut app = app(Eruption::thesis(), 5);
    run(&mut app, 50 * 45);
    let seen = std::mem::take(&mut *app.world_mut().resource_mut::<Seen>());
    assert!(seen.collapsed > 0, "{seen:?}");
    // Secondary columns (buoyant from the start) rise from the flows and spread; no slice from
    // the vent does.
    let secondary = app.world().resource::<PyroclasticBudget>().secondary_columns;
    assert!(seen.umbrella as u64 <= secondary && seen.neutral as u64 <= secondary, "{seen:?}, {secondary}");
    // One slice every r0 / (2 v0) = 1/3 s from the vent: 135 in 45 s (secondary columns are
    // numbered after them).
    let emitted = app.world_mut().query::<&EmissionState>().single(app.world()).unwrap().emitted;
    assert!((134..=136).contains(&(emitted - secondary)), "{emitted} − {secondary}");
    let live = app.world_mut().query::<&PlumeSlice>().iter(app.world()).count();
    let s1 = app.world_mut().query::<&S1>().iter(app.world()).count();
    assert_eq!(s1, 6 * live, "six s1 spheres per live slice");
    // Every slice collapsed near the single-slice value, 1,935 m above the vent (±5 %).
    assert!(seen.collapse_heights.iter().all(|&y| (y - 1_935.0).abs() < 97.0), "{:?}", seen.collapse_heights);
    // Collapsed slices were removed, and so were those that spread as the umbrella.
    assert_eq!(live as u64 + seen.collapsed as u64 + seen.umbrella as u64, emitted);
}

#[test]
fn plinian_column_spreads_an_umbrella() {
    let mut app = app(Eruption::plinian(), 5);
    run(&mut app, 50 * 140);
    let seen = std::mem::take(&mut *app.world_mut().resource_mut::<Seen>());
    assert!(seen.umbrella > 0 && seen.neutral > 0 && seen.collapsed == 0, "{seen:?}");
    // 20 m/s wind at 12 km lowers the apex a little below the calm 10.2 km.
    assert!(seen.apex > 8_000.0 && seen.apex < 10_200.0, "apex {}", seen.apex);
    let umbrella: Vec<Vec3> = app
        .world_mut()
        .query_filtered::<&Transform, With<Umbrella>>()
        .iter(app.world())
        .map(|t| t.translation)
        .collect();
    assert!(!umbrella.is_empty());
    assert!(umbrella.iter().all(|p| p.is_finite() && p.y > 6_000.0));
    // The wind blows toward +x (model) = world +x: the umbrella's centre has drifted that way.
    let mean_x = umbrella.iter().map(|p| p.x).sum::<f32>() / umbrella.len() as f32;
    let mean_z = umbrella.iter().map(|p| p.z).sum::<f32>() / umbrella.len() as f32;
    assert!(mean_x > 100.0 && mean_x > 5.0 * mean_z.abs(), "umbrella centre ({mean_x}, {mean_z})");
}

/// Under the plinian preset's wind the slices lean over near the apex, so their vortex ring is
/// tilted. An s1 sphere detaching into the umbrella starts where it was on that ring: between
/// two frames (5 ticks, 0.1 s) it moves by no more than its speed allows. (It used to be put
/// back on an untilted ring at the apex altitude, a jump of hundreds of metres.)
#[test]
fn umbrella_spheres_start_where_they_left_the_ring() {
    let mut app = app(Eruption::plinian(), 5);
    let mut last: std::collections::HashMap<Entity, Vec3> = Default::default();
    let (mut detached, mut worst) = (0usize, 0.0f32);
    while app.world().resource::<SimTick>().0 < 50 * 140 && detached < 60 {
        app.update();
        let world = app.world_mut();
        let mut now: std::collections::HashMap<Entity, Vec3> = Default::default();
        for (e, t) in world.query_filtered::<(Entity, &Transform), With<S1>>().iter(world) {
            now.insert(e, t.translation);
        }
        for (e, t, u) in world.query::<(Entity, &Transform, &Umbrella)>().iter(world) {
            now.insert(e, t.translation);
            // Just detached: compare with where the same entity was one frame earlier.
            if u.age < 0.3
                && let Some(before) = last.get(&e)
            {
                worst = worst.max(before.distance(t.translation));
                if u.age <= 0.1 {
                    detached += 1;
                }
            }
        }
        last = now;
    }
    assert!(detached >= 12, "{detached} detachments seen");
    // 0.1 s at the wind (≤ 20 m/s), the slice's speed and the umbrella's v_neutral (< 60 m/s).
    assert!(worst < 15.0, "an umbrella sphere jumped {worst} m at detachment");
}

#[test]
fn plume_is_frame_rate_independent() {
    let state = |tpu| {
        let mut app = app(Eruption::plinian(), tpu);
        run(&mut app, 1_000);
        let mut v: Vec<(u64, [u64; 4])> = app
            .world_mut()
            .query::<&PlumeSlice>()
            .iter(app.world())
            .map(|s| {
                let st = &s.state;
                (
                    s.index,
                    [st.position.z.to_bits(), st.position.x.to_bits(), st.mass.to_bits(), st.r.to_bits()],
                )
            })
            .collect();
        v.sort();
        v
    };
    let (a, b) = (state(1), state(5));
    assert!(a.len() > 50);
    assert_eq!(a, b, "same ticks must give bit-identical slices at 1 and 5 ticks per frame");
}

#[test]
fn invalid_eruption_parameters_are_rejected() {
    let mut p = Eruption::thesis().params;
    p.r0 = -1.0;
    assert!(Eruption::new(p, Default::default()).unwrap_err().to_string().contains("r0"));
}
