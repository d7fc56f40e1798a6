//! A lava field placed by its entity's `Transform` is drawn where the simulation has it: its
//! surface mesh (built in world coordinates) and glow lights, children of the entity, cancel
//! the entity's transform. Headless app without a renderer (mesh, material and image assets).

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_core::prelude::*;
use volcano_lava::{LavaField, LavaPlugin, LavaSource, LavaState};
use volcano_render::LavaRenderPlugin;
use volcano_render::lava::LavaSurface;
use volcano_render::lava::light::LavaGlow;

#[test]
fn a_moved_field_is_drawn_where_its_lava_is() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, bevy::asset::AssetPlugin::default()))
        .init_asset::<Mesh>()
        .init_asset::<StandardMaterial>()
        .init_asset::<Image>()
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .add_plugins((VolcanoCorePlugin, LavaPlugin, LavaRenderPlugin));
    app.finish();
    app.cleanup();
    let place = Vec3::new(150.0, 0.0, -80.0);
    app.world_mut().spawn((Terrain::flat(129, 4.0, 10.0).unwrap(), Transform::from_translation(place)));
    let field =
        app.world_mut().spawn((LavaField::square(32, 0.5).unwrap(), Transform::from_translation(place))).id();
    app.world_mut().spawn((LavaSource::new(0.5).unwrap(), Transform::from_translation(place)));
    for _ in 0..20 {
        app.update();
    }
    let world = app.world_mut();
    let state = world.get::<LavaState>(field).expect("the field is built");
    assert_eq!(state.flow.thickness().origin(), place.xz() - Vec2::splat(7.75), "simulated where placed");
    let (surface, surface_at) = world
        .query_filtered::<(&ChildOf, &GlobalTransform), With<LavaSurface>>()
        .single(world)
        .map(|(c, g)| (c.parent(), *g))
        .unwrap();
    assert_eq!(surface, field);
    // World-coordinate vertices drawn with no further offset (not at twice the translation).
    assert!(
        surface_at.translation().abs_diff_eq(Vec3::ZERO, 1e-3),
        "the surface is drawn at {}",
        surface_at.translation()
    );
    let lights: Vec<Vec3> = world
        .query_filtered::<&GlobalTransform, With<LavaGlow>>()
        .iter(world)
        .map(|g| g.translation())
        .collect();
    assert!(!lights.is_empty(), "the lit lava has glow lights");
    for at in lights {
        assert!(at.xz().distance(place.xz()) < 8.0, "a glow light at {at}, the lava around {place}");
    }
}
