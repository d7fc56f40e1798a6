//! A volcano under weather: `cargo run --example weather`.
//!
//! The game generates its island, spawns a Plinian volcano on it and, over the same terrain,
//! the built-in five-layer `eruption` atmosphere with `AtmosphereSpawner` (128 cells a side,
//! 60 one-second model steps run before it appears, so the air has already settled over the
//! terrain). The renderer draws the clouds and the ash falling out of them with nothing more
//! to add, and the column is coupled to the air because its vent lies inside the atmosphere's
//! grid: it reads the layers' wind, heats and moistens them and sheds its ash into them.
//!
//! Every ten weather steps (one a simulated second) the game reads the air at a mountain hut
//! 1.3 km north-east of the vent, under the drifting ash: the temperature, water vapour and
//! cloud water of the layer it stands in, the ash in that air (`air_ash_at`) and the ash
//! fallen on its roof (`PyroclasticQuery::deposit_thickness`), and logs them. Both start after
//! about a minute and a half and grow to grams per cubic metre and centimetres within minutes.
//! Left-drag orbits, right-drag pans, the wheel zooms.

use bevy::prelude::*;
use volcano::atmosphere::atmosphere_fields;
use volcano::prelude::*;

/// The hut (world x, z; m; −z is north): on the flank 1.3 km north-east of the vent.
const HUT: Vec2 = Vec2::new(1_100.0, -700.0);

fn main() -> AppExit {
    App::new()
        // The simulation and its visuals (clouds and ash fall included), and a sun and sky.
        .add_plugins((DefaultPlugins, VolcanoPlugins, VolcanoSkyPlugin))
        .add_systems(Startup, setup)
        // Read after the whole base tick, so a weather step written back this tick is seen.
        .add_systems(FixedUpdate, report_the_air.after(SimSystems::End))
        .run()
}

/// The island, the air over it, the volcano and the game's camera.
fn setup(mut commands: Commands) -> Result {
    // The terrain first, as a value: the atmosphere samples it at its cell centres.
    let terrain = StratovolcanoParams::default().generate()?;
    // The `eruption` scenario: five layers up to 12 km, a west wind turning south-west aloft,
    // on a 25.6 km square centred on the world origin.
    let scenario = WeatherScenario::builtin("eruption")?;
    AtmosphereSpawner::new(&scenario)
        .over(&terrain) // the game's terrain under the grid (else the scenario's own)
        .grid(128) // cells per side, a power of two (else the scenario's)
        .prespin(60) // model steps run before it appears: developed weather from the start
        .spawn(&mut commands)?;
    commands.spawn((Name::new("Island"), terrain));
    // The vent sits on the terrain under the entity's x/z: inside the grid, so it is coupled.
    commands.spawn((
        Name::new("Volcano"),
        Volcano::new(100.0, 42)?,
        Eruption::plinian(),
        Transform::default(),
    ));
    // The game's camera: an orbit camera with `VolcanoViewer`, `VolcanoSkyCamera` and a depth
    // prepass, so the clouds and the ash fall stop at the ground and shade it.
    commands.spawn(camera_bundle(OrbitCamera {
        pitch: 8f32.to_radians(),
        ..OrbitCamera::looking_at(Vec3::new(3_000.0, 4_000.0, 0.0), 32_000.0)
    }));
    Ok(())
}

/// Gameplay: the air and the ash at the hut, read when a weather step has been written
/// back (`WeatherStepped`, once per simulated second), every tenth time.
fn report_the_air(
    mut stepped: MessageReader<WeatherStepped>,
    mut steps: Local<u32>,
    terrains: Query<&Terrain>,
    layers: Query<&AirLayer>,
    deposits: PyroclasticQuery,
    control: Res<SimControl>,
) {
    for m in stepped.read() {
        *steps += 1;
        if !steps.is_multiple_of(10) {
            continue;
        }
        let Some(ground) = terrains.iter().find(|t| t.contains(HUT.x, HUT.y)) else { continue };
        // Head height above the hut's ground.
        let at = Vec3::new(HUT.x, ground.height_at(HUT.x, HUT.y) + 2.0, HUT.y);
        // Ash in the air (g/m³), blended between the layers as the ash fall is drawn.
        let ash = air_ash_at(layers.iter(), m.atmosphere, at);
        // The layer it stands in: the lowest whose slab reaches above head height.
        let stack = atmosphere_fields(layers.iter(), m.atmosphere);
        let Some(air) = stack.iter().find(|l| (at.y as f64) < l.bottom + l.thickness) else { continue };
        let celsius = air.t.sample(HUT, Boundary::Clamp) - 273.15;
        let vapour = air.h.sample(HUT, Boundary::Clamp);
        let cloud = air.w.sample(HUT, Boundary::Clamp);
        // Ash fallen out of the air (and any pyroclastic deposit), in millimetres.
        let roof_mm = 1_000.0 * deposits.deposit_thickness(HUT.x, HUT.y);
        info!(
            "{:.0} s, hut at {:.0} m: {celsius:.1} °C, vapour {vapour:.2} g/m³, cloud water \
             {cloud:.3} g/m³, ash in the air {ash:.4} g/m³, ash on the roof {roof_mm:.2} mm",
            control.simulated().as_secs_f64(),
            at.y
        );
    }
}
