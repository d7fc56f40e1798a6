//! Saving the running volcano and loading it back: `cargo run --example save_and_load`.
//!
//! F5 saves the simulation as it stands, F9 loads the last save: the column and its umbrella,
//! the air and its ash, the deposit and every domain's clock go back to that moment and run
//! on from there exactly as they did the first time. Each save and load is logged.
//!
//! A save is a Bevy `DynamicWorld` (crate `bevy_world_serialization`, at the Bevy version)
//! built as docs/SAVING.md says: the weather step in flight is written back first
//! (`flush_weather`), then entities and resources are copied; the entity references inside
//! them are mapped when the copy is written back. It stays in memory: the grids and model
//! states are reflected as opaque values that cannot be serialised, so it cannot go to a file.
//!
//! A game's world holds more than the volcano (camera, lights, window, the renderer's meshes),
//! so only the simulation is saved: the reflected types of the simulation crates (each
//! domain's clock `Time<DomainClock<…>>` among them), `Transform` and `Name`, on the entities
//! that have such a type. Left out are the renderer's types (`volcano_render`, also markers
//! such as `TerrainHorizon` a game puts on a terrain) and the hierarchy (`ChildOf` and
//! `Children` name the renderer's children): the renderer builds the terrain mesh, clouds and
//! ash fall anew for the loaded entities. Loading despawns the simulation's entities and
//! writes the saved ones in their place, under new entity ids.

use std::any::TypeId;

use bevy::ecs::resource::IsResource;
use bevy::input::common_conditions::input_just_pressed;
use bevy::prelude::*;
use bevy::reflect::TypeRegistry;
use bevy_world_serialization::{DynamicWorld, DynamicWorldBuilder, WorldFilter};
use volcano::atmosphere::flush_weather;
use volcano::prelude::*;

/// The last save, in memory.
#[derive(Resource, Default)]
struct SaveSlot(Option<DynamicWorld>);

fn main() -> AppExit {
    App::new()
        .add_plugins((DefaultPlugins, VolcanoPlugins, VolcanoSkyPlugin))
        .init_resource::<SaveSlot>()
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (save.run_if(input_just_pressed(KeyCode::F5)), load.run_if(input_just_pressed(KeyCode::F9))),
        )
        .run()
}

/// An island, a coupled atmosphere over it, a Plinian volcano and the game's camera.
fn setup(mut commands: Commands) -> Result {
    let terrain = StratovolcanoParams::default().generate()?;
    AtmosphereSpawner::new(&WeatherScenario::builtin("eruption")?)
        .over(&terrain)
        .grid(64)
        .spawn(&mut commands)?;
    commands.spawn((Name::new("Island"), terrain));
    commands.spawn((
        Name::new("Volcano"),
        Volcano::new(100.0, 42)?,
        Eruption::plinian(),
        Transform::default(),
    ));
    commands.spawn((
        Camera3d::default(),
        VolcanoViewer,
        VolcanoSkyCamera,
        Transform::from_xyz(16_000.0, 4_000.0, 22_000.0).looking_at(Vec3::new(0.0, 5_000.0, 0.0), Vec3::Y),
    ));
    info!("F5 saves the volcano, F9 loads the last save");
    Ok(())
}

/// Whether a reflected type is the simulation's: a type of the volcano crates (by its path,
/// which names `Time<DomainClock<…>>` by its argument), not the renderer's or the panels'.
fn is_simulation(path: &str) -> bool {
    path.contains("volcano") && !path.contains("volcano_render") && !path.contains("volcano_egui")
}

/// What a save holds: the simulation's reflected types, `Transform` and `Name`.
fn simulation_filter(registry: &TypeRegistry) -> WorldFilter {
    let filter = WorldFilter::deny_all().allow::<Transform>().allow::<Name>();
    registry
        .iter()
        .filter(|r| is_simulation(r.type_info().type_path()))
        .fold(filter, |f, r| f.allow_by_id(r.type_id()))
}

/// The simulation's entities: those with a saved type besides `Transform` and `Name`. Each
/// resource is an entity too; they are saved as resources, not here.
fn simulation_entities(world: &World, filter: &WorldFilter) -> Vec<Entity> {
    let plain = [TypeId::of::<Transform>(), TypeId::of::<Name>()];
    let simulated = |e: &EntityRef| {
        e.archetype().components().iter().any(|&id| {
            let type_id = world.components().get_info(id).and_then(|info| info.type_id());
            type_id.is_some_and(|t| !plain.contains(&t) && filter.is_allowed_by_id(t))
        })
    };
    world.iter_entities().filter(|e| !e.contains::<IsResource>() && simulated(e)).map(|e| e.id()).collect()
}

/// F5: the simulation into the save slot.
fn save(world: &mut World) {
    // The weather step runs off the main thread: write it back, or the save would miss it.
    flush_weather(world);
    let saved = {
        let registry = world.resource::<AppTypeRegistry>().read();
        let filter = simulation_filter(&registry);
        let entities = simulation_entities(world, &filter);
        DynamicWorldBuilder::from_world(world, &registry)
            .with_component_filter(filter.clone())
            .with_resource_filter(filter)
            .extract_entities(entities.into_iter())
            .extract_resources()
            .build()
    };
    info!(
        "saved at {:.1} s of simulated time: {} entities, {} resources",
        world.resource::<SimControl>().simulated().as_secs_f64(),
        saved.entities.len(),
        saved.resources.len()
    );
    world.resource_mut::<SaveSlot>().0 = Some(saved);
}

/// F9: the simulation as it is now out, the saved one in.
fn load(world: &mut World) {
    let Some(saved) = world.resource_mut::<SaveSlot>().0.take() else {
        info!("nothing saved yet: F5 saves");
        return;
    };
    let now = world.resource::<SimControl>().simulated().as_secs_f64();
    let filter = simulation_filter(&world.resource::<AppTypeRegistry>().read());
    // Despawning a terrain, volcano or atmosphere also despawns its children (the renderer's
    // meshes, the air layers), so some entities of the list are already gone.
    for entity in simulation_entities(world, &filter) {
        if let Ok(e) = world.get_entity_mut(entity) {
            e.despawn();
        }
    }
    // The saved entities get new ids; references between them (slice → volcano, air layer →
    // atmosphere, …) are mapped to those. The saved resources overwrite the current ones.
    match saved.write_to_world(world, &mut Default::default()) {
        Ok(()) => info!(
            "loaded: back from {now:.1} s to {:.1} s, {} entities",
            world.resource::<SimControl>().simulated().as_secs_f64(),
            saved.entities.len()
        ),
        Err(e) => error!("the save could not be loaded: {e}"),
    }
    // Kept, so F9 can go back to the same moment again.
    world.resource_mut::<SaveSlot>().0 = Some(saved);
}
