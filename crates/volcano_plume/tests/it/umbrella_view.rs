//! The view draws each kilogram of umbrella ash once: an umbrella sphere sheds its ash into
//! the air as it spreads (`Eruption::umbrella_fallout_s`), and the air's ash is drawn by the
//! renderer once coupled, so the sphere is drawn only as dense as the ash it still holds.
//! Drawn at the density it detached with until it expires, it would draw the shed ash twice.

use crate::common;

use std::collections::HashMap;

use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_plume::view::gather_parents;
use volcano_plume::*;

/// Per umbrella sphere id: drawn density over the ash the model says it still holds, and age.
fn drawn_per_kg(app: &mut App) -> HashMap<u64, (f64, f64)> {
    let (_, parents) = gather_parents(app.world_mut());
    let held: HashMap<u64, (f64, f64)> =
        app.world_mut().query::<&Umbrella>().iter(app.world()).map(|u| (u.id, (u.ash, u.age))).collect();
    parents
        .iter()
        .filter(|p| p.umbrella)
        .map(|p| {
            let (ash, age) = held[&p.id];
            (p.id, (p.density as f64 / ash, age))
        })
        .collect()
}

#[test]
fn an_umbrella_sphere_is_drawn_as_dense_as_the_ash_it_still_holds() {
    let mut eruption = Eruption::plinian();
    // A short fallout time, so the spheres lose most of their ash in the test's 30 s.
    eruption.umbrella_fallout_s = 20.0;
    let mut app = common::plume_app(5);
    app.world_mut().spawn(Terrain::flat(33, 10.0, 0.0).unwrap());
    app.world_mut().spawn((Volcano::new(100.0, 11).unwrap(), eruption, Transform::default()));
    common::run(&mut app, 50 * 145);
    let before = drawn_per_kg(&mut app);
    assert!(before.len() > 20, "{} umbrella spheres at 145 s", before.len());
    common::run(&mut app, 50 * 175);
    let after = drawn_per_kg(&mut app);
    let mut compared = 0;
    for (id, (per_kg, age)) in &after {
        let Some((per_kg_before, age_before)) = before.get(id) else { continue };
        // Drawn at the detach density, the ratio would have grown by exp(30 s / 20 s) ≈ 4.5.
        assert!(age - age_before > 29.0, "sphere {id} aged {age_before} → {age} s");
        let change = per_kg / per_kg_before;
        assert!((change - 1.0).abs() < 1e-5, "sphere {id}: drawn density per kg held × {change}");
        compared += 1;
    }
    assert!(compared > 20, "{compared} spheres lived through both gathers");
}
