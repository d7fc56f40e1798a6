//! A game's headless use: `VolcanoSimPlugins` on `MinimalPlugins`, the registry's scene, fixed
//! ticks, deterministic state.

use std::time::Duration;

use bevy::prelude::*;
use volcano::prelude::*;

fn headless_app(ticks_per_update: u32) -> App {
    let spec = volcano::scenes::by_name("eruption").unwrap();
    let terrain = spec.terrain.build().unwrap();
    let (volcano, transform) = spec.volcano.build().unwrap();
    let mut app = crate::worlds::sim_app(Duration::from_millis(20) * ticks_per_update);
    app.world_mut().spawn(terrain);
    app.world_mut().spawn((volcano, transform));
    app
}

#[test]
fn scene_steps_headless_and_the_vent_sits_on_the_terrain() {
    let mut app = headless_app(2);
    for _ in 0..51 {
        app.update();
    }
    assert_eq!(
        app.world().resource::<SimTick>().0,
        100,
        "2 base ticks per update after the zero first update"
    );
    let mut q = app.world_mut().query::<(&VentPosition, &Volcano)>();
    let (vent, volcano) = q.single(app.world()).map(|(v, vol)| (*v, vol.clone())).unwrap();
    let mut t = app.world_mut().query::<&Terrain>();
    let terrain = t.single(app.world()).unwrap();
    assert!((vent.0.y - terrain.height_at(0.0, 0.0)).abs() < 1e-3);
    // The eruption scene's vent is in the summit crater: above the plain, below the rim.
    assert!(vent.0.y > 2_000.0 && vent.0.y < terrain.height_range().1, "vent at {}", vent.0.y);
    assert_eq!(volcano.seed(), 7);
}

#[test]
fn a_malformed_preset_is_an_error_not_a_panic() {
    assert!(VolcanoSpec::from_ron("(vent: (0.0, 0.0), vent_radius: \"big\")").is_err());
    assert!(VolcanoScenePlugin::builtin("missing").is_err());
    let e = Volcano::new(f32::NAN, 0).unwrap_err();
    assert!(e.to_string().contains("vent_radius"));
}
