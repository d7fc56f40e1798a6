//! A capture that cannot be written ends the app with an error instead of hanging.

use std::path::PathBuf;

use bevy::prelude::*;
use volcano_render::{
    HeadlessCapturePlugin, OrbitCamera, VolcanoRenderPlugins, VolcanoSkyPlugin, camera_bundle,
    headless_default_plugins,
};

#[test]
fn unwritable_output_exits_with_an_error() {
    // The output path is an existing directory: creating the file fails.
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("headless_write_error_is_a_dir");
    std::fs::create_dir_all(&out).unwrap();
    let mut app = App::new();
    app.add_plugins((headless_default_plugins(), VolcanoRenderPlugins, VolcanoSkyPlugin))
        .add_plugins(HeadlessCapturePlugin {
            width: 64,
            height: 48,
            out: out.clone(),
            capture_after_updates: 3,
        })
        .add_systems(Startup, |mut commands: Commands| {
            commands.spawn(camera_bundle(OrbitCamera::default()));
        });
    let exit = app.run();
    assert!(exit.is_error(), "expected an error exit, got {exit:?}");
    // (`App::run` hands the world to the runner, so `CaptureStatus` cannot be read back here.)
}
