//! The weather steps once per simulated second whatever fixed rate the game runs at.

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano_atmosphere::{AtmospherePlugin, WeatherStep};
use volcano_core::prelude::*;

/// Weather steps and weather time after `seconds` simulated seconds at `hz`.
fn weather_after(hz: f64, seconds: u64) -> (u64, Duration) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoCorePlugin, AtmospherePlugin::default()));
    // The game's rate, set after the plugins (nothing may override it).
    app.insert_resource(Time::<Fixed>::from_hz(hz));
    let step = app.world().resource::<Time<Fixed>>().timestep();
    app.insert_resource(TimeUpdateStrategy::ManualDuration(step));
    let ticks = (seconds as f64 * hz).round() as u64;
    let mut updates = 0;
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
        updates += 1;
        assert!(updates < 2 * ticks + 10, "the simulation does not tick");
    }
    assert_eq!(app.world().resource::<SimTick>().0, ticks);
    let clock = app.world().resource::<Time<DomainClock<WeatherStep>>>();
    (clock.context().steps_run(), clock.elapsed())
}

#[test]
fn weather_steps_once_per_simulated_second_at_50_and_64_hz() {
    for hz in [50.0, 64.0] {
        let (steps, elapsed) = weather_after(hz, 10);
        assert_eq!(steps, 10, "{hz} Hz: weather steps in 10 s");
        assert_eq!(elapsed, Duration::from_secs(10), "{hz} Hz: weather time after 10 s");
    }
}
