//! A `Terrain` tagged `UnrenderedTerrain` gets no mesh; tagging it later removes its mesh.
//! Headless app without a renderer (mesh and material assets only).

use bevy::prelude::*;
use volcano_core::{StratovolcanoParams, Terrain};
use volcano_render::{TerrainMesh, TerrainRenderPlugin, UnrenderedTerrain};

fn meshes_of(app: &mut App, terrain: Entity) -> usize {
    let world = app.world_mut();
    world
        .query_filtered::<&ChildOf, With<TerrainMesh>>()
        .iter(world)
        .filter(|c| c.parent() == terrain)
        .count()
}

#[test]
fn unrendered_terrains_get_no_mesh() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, bevy::asset::AssetPlugin::default()))
        .init_asset::<Mesh>()
        .init_asset::<StandardMaterial>()
        .add_plugins((volcano_core::VolcanoCorePlugin, TerrainRenderPlugin));
    app.finish();
    app.cleanup();
    let terrain = || -> Terrain {
        StratovolcanoParams { resolution: 17, cell: 500.0, ..Default::default() }.generate().unwrap()
    };
    let hidden = app.world_mut().spawn((terrain(), UnrenderedTerrain)).id();
    let shown = app.world_mut().spawn(terrain()).id();
    for _ in 0..3 {
        app.update();
    }
    assert_eq!(meshes_of(&mut app, hidden), 0, "the tagged terrain got a mesh");
    assert_eq!(meshes_of(&mut app, shown), 1, "the other terrain is still drawn");
    app.world_mut().entity_mut(shown).insert(UnrenderedTerrain);
    app.update();
    app.update();
    assert_eq!(meshes_of(&mut app, shown), 0, "tagging later removes the mesh");
    // An edit of an unrendered terrain does not bring a mesh back.
    app.world_mut().get_mut::<Terrain>(shown).unwrap().heights_mut().map_in_place(|h| h + 1.0);
    app.update();
    assert_eq!(meshes_of(&mut app, shown), 0);
}
