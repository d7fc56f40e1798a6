//! A game that owns its camera, sun, ambient light, fog and fixed rate adds `VolcanoPlugins`:
//! the volcano must leave all of them alone and step at the game's `Time<Fixed>` (64 Hz here,
//! Bevy's default, not the thesis' 50 Hz).

use std::time::Duration;

use bevy::camera::Exposure;
use bevy::light::{GlobalAmbientLight, Skybox, VolumetricFog};
use bevy::pbr::{AtmosphereSettings, DistanceFog, FogFalloff};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::prelude::*;
use volcano::render::{
    CloudRenderPlugin, DepositRenderPlugin, LavaRenderPlugin, OrbitCameraPlugin, PlumeRenderPlugin,
    TerrainRenderPlugin, VolcanoSkyPlugin, VolcanoViewer, headless_default_plugins,
};

const TICKS: u64 = 200;
/// 1/64 s in nanoseconds (exact).
const STEP_NS: u64 = 15_625_000;

fn host_fog() -> DistanceFog {
    DistanceFog {
        color: Color::srgb(0.1, 0.2, 0.3),
        falloff: FogFalloff::Linear { start: 10.0, end: 900.0 },
        ..default()
    }
}

fn host_ambient() -> GlobalAmbientLight {
    GlobalAmbientLight { color: Color::srgb(1.0, 0.0, 0.0), brightness: 123.0, ..default() }
}

#[test]
fn the_volcano_leaves_the_games_camera_sun_ambient_fog_and_rate_alone() {
    let mut app = App::new();
    // The game's rate, set before the plugins (they must not override it).
    app.insert_resource(Time::<Fixed>::from_hz(64.0))
        .add_plugins(headless_default_plugins())
        .add_plugins(VolcanoPlugins)
        .insert_resource(host_ambient())
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_nanos(STEP_NS)));
    let sun_transform = Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y);
    let sun = app
        .world_mut()
        .spawn((
            DirectionalLight { illuminance: 1234.0, shadow_maps_enabled: false, ..default() },
            sun_transform,
        ))
        .id();
    let camera = app
        .world_mut()
        .spawn((
            Camera3d::default(),
            // The viewer marker says the ash faces this camera; it must not bring the sky.
            VolcanoViewer,
            Exposure { ev100: 9.5 },
            host_fog(),
            Transform::from_xyz(0.0, 5_000.0, 20_000.0),
        ))
        .id();
    let terrain = StratovolcanoParams { resolution: 33, cell: 300.0, ..default() }.generate().unwrap();
    app.world_mut().spawn(terrain);
    app.world_mut().spawn((Volcano::default(), Eruption::plinian(), Transform::default()));

    while app.plugins_state() == bevy::app::PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    let mut updates = 0;
    while app.world().resource::<SimTick>().0 < TICKS {
        app.update();
        updates += 1;
        assert!(updates < 10 * TICKS, "the simulation does not tick");
    }

    let w = app.world();
    assert_eq!(w.resource::<SimTick>().0, TICKS, "one base tick per fixed update");
    assert_eq!(w.resource::<Time<Fixed>>().timestep(), Duration::from_nanos(STEP_NS), "the game's rate");
    let plume = w.resource::<Time<volcano::core::DomainClock<volcano::plume::PlumeStep>>>();
    assert_eq!(plume.elapsed(), Duration::from_nanos(TICKS * STEP_NS), "200 × 1/64 s of plume time");

    let ambient = w.resource::<GlobalAmbientLight>();
    assert_eq!((ambient.color, ambient.brightness), (host_ambient().color, host_ambient().brightness));
    let cam = w.entity(camera);
    assert_eq!(cam.get::<Exposure>().map(|e| e.ev100), Some(9.5), "exposure");
    let fog = cam.get::<DistanceFog>().expect("the game's fog is still there");
    assert_eq!(
        (fog.color, format!("{:?}", fog.falloff)),
        (host_fog().color, format!("{:?}", host_fog().falloff))
    );
    assert!(!cam.contains::<Skybox>(), "a skybox was added");
    assert!(!cam.contains::<AtmosphereSettings>(), "atmosphere settings were added");
    assert!(!cam.contains::<VolumetricFog>(), "volumetric fog was added");
    let mut lights = app.world_mut().query::<(Entity, &DirectionalLight, &Transform)>();
    let lights: Vec<_> = lights.iter(app.world()).collect();
    assert_eq!(lights.len(), 1, "a second sun was spawned");
    let (e, light, t) = lights[0];
    assert_eq!(e, sun);
    assert_eq!(
        (light.illuminance, light.color, *t),
        (1234.0, Color::WHITE, sun_transform),
        "the sun changed"
    );
}

#[test]
fn each_render_plugin_can_be_disabled_and_the_sky_and_panels_are_opt_in() {
    fn check<T: Plugin>() {
        let group = VolcanoPlugins.build();
        assert!(group.enabled::<T>(), "{} is a member", std::any::type_name::<T>());
        assert!(!group.disable::<T>().enabled::<T>());
    }
    check::<TerrainRenderPlugin>();
    check::<OrbitCameraPlugin>();
    check::<PlumeRenderPlugin>();
    check::<DepositRenderPlugin>();
    check::<LavaRenderPlugin>();
    check::<CloudRenderPlugin>();
    let group = VolcanoPlugins.build();
    assert!(!group.contains::<VolcanoSkyPlugin>(), "the sky is opt-in");
    assert!(!group.contains::<volcano_egui::VolcanoPanelPlugin>(), "the panels are opt-in");
    assert!(!group.contains::<bevy_egui::EguiPlugin>());
}
