//! The view of a running pyroclastic flow carries ash clouds over its currents
//! (`volcano_plume::view::current_clouds`): after 14 s of the collapsing cone,
//! the gathered parents hold clouds above the particles, swollen at the fronts, the same on
//! every gather and at every frame rate, and none when the settings turn them off.

use crate::common;

use bevy::prelude::*;
use volcano_plume::view::{CLOUD_ID_BIT, CurrentCloudSettings, ParentSphere, gather_parents};
use volcano_plume::*;

use common::run;

fn flowing(ticks_per_update: u32) -> App {
    let mut app = common::plume_app(ticks_per_update);
    common::spawn_collapsing_cone(&mut app, Eruption::pyroclastic());
    run(&mut app, 50 * 14);
    app
}

fn split(parents: &[ParentSphere]) -> (Vec<ParentSphere>, Vec<ParentSphere>) {
    parents.iter().partition(|p| p.cloud)
}

#[test]
fn currents_carry_clouds_that_swell_at_their_fronts() {
    let mut app = flowing(5);
    let (_, parents) = gather_parents(app.world_mut());
    let (clouds, others) = split(&parents);
    let flows: Vec<&ParentSphere> = others.iter().filter(|p| p.flow).collect();
    assert!(flows.len() > 100, "{} flow particles after 14 s", flows.len());
    // About one cloud per `every` particles (by a hash of the id).
    let every = CurrentCloudSettings::default().every as usize;
    let expected = flows.len() / every;
    assert!(
        clouds.len() > expected * 7 / 10 && clouds.len() < expected * 13 / 10,
        "{} clouds for {} particles",
        clouds.len(),
        flows.len()
    );
    // Each sits above its own particle (same id but the cloud bit), larger than it.
    for c in &clouds {
        assert!(!c.flow && !c.umbrella && c.center.is_finite() && c.radius.is_finite());
        let p = flows.iter().find(|p| p.id == c.id & !CLOUD_ID_BIT).expect("a cloud's particle");
        assert!(c.center.y > p.center.y, "cloud {c:?} under its particle {p:?}");
        assert!(c.radius >= p.radius, "cloud {c:?} smaller than its particle {p:?}");
    }
    // The clouds of the outermost particles (the heads) are larger than the median cloud.
    let dist = |c: &ParentSphere| Vec2::new(c.center.x, c.center.z).length();
    let mut by_dist = clouds.clone();
    by_dist.sort_by(|a, b| dist(a).total_cmp(&dist(b)));
    let mut radii: Vec<f32> = clouds.iter().map(|c| c.radius).collect();
    radii.sort_by(f32::total_cmp);
    let median = radii[radii.len() / 2];
    let outer = &by_dist[by_dist.len() * 19 / 20..];
    let outer_mean = outer.iter().map(|c| c.radius).sum::<f32>() / outer.len() as f32;
    assert!(outer_mean > 1.3 * median, "heads {outer_mean} m vs median cloud {median} m");
    // Gathering again gives the same list.
    assert_eq!(gather_parents(app.world_mut()).1, parents);
}

#[test]
fn clouds_are_frame_rate_independent_and_can_be_turned_off() {
    let mut a = flowing(1);
    let mut b = flowing(7);
    let (pa, pb) = (gather_parents(a.world_mut()).1, gather_parents(b.world_mut()).1);
    assert!(pa.iter().any(|p| p.cloud));
    assert_eq!(pa, pb);
    // Off: the same model spheres, no cloud.
    a.insert_resource(CurrentCloudSettings { enabled: false, ..default() });
    let off = gather_parents(a.world_mut()).1;
    assert!(!off.is_empty() && off.iter().all(|p| !p.cloud));
    assert_eq!(off, split(&pa).1);
}
