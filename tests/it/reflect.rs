//! Reflection: every component and resource of the volcano crates that a
//! running eruption scene knows (spawned, or named by one of its systems) is registered with
//! `ReflectComponent` or `ReflectResource`, so scenes, the remote protocol and inspectors can
//! read and write it. One exception: `AtmosphereWork`, a weather step in flight (a task
//! handle, not state: join it before saving).

use std::time::Duration;

use bevy::ecs::reflect::{ReflectComponent, ReflectResource};
use bevy::prelude::*;
use volcano::prelude::*;

#[test]
fn every_volcano_component_and_resource_is_reflected() {
    let mut app = crate::worlds::sim_app(Duration::from_millis(100));
    app.add_plugins(VolcanoScenePlugin::builtin("eruption").unwrap().headless());
    for _ in 0..20 {
        app.update();
    }
    let world = app.world();
    let registry = world.resource::<AppTypeRegistry>().read();
    let mut missing = Vec::new();
    let mut seen = 0;
    for info in world.components().iter_registered() {
        let name = info.name().to_string();
        if !name.starts_with("volcano") || name.ends_with("::AtmosphereWork") {
            continue;
        }
        seen += 1;
        let Some(type_id) = info.type_id() else { continue };
        let reflected = registry
            .get(type_id)
            .is_some_and(|r| r.data::<ReflectComponent>().is_some() || r.data::<ReflectResource>().is_some());
        if !reflected {
            missing.push(name);
        }
    }
    missing.sort();
    assert!(seen > 30, "only {seen} volcano types found: the scene did not run");
    assert!(missing.is_empty(), "{} of {seen} not reflected:\n{}", missing.len(), missing.join("\n"));
}
