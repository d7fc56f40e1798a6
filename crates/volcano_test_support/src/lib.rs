//! What the workspace's render tests share: a headless app that captures one frame
//! ([`capture_app`], [`run_and_read`]), PNG read-back and frame statistics. Not published: the
//! crates' integration tests take it as a dev-dependency.
#![forbid(unsafe_code)]

mod png_read;

use std::path::{Path, PathBuf};

use bevy::app::PluginGroupBuilder;
use bevy::prelude::*;
use volcano_core::VolcanoCorePlugin;
use volcano_render::{HeadlessCapturePlugin, VolcanoRenderPlugins, VolcanoSkyPlugin};

pub use png_read::{luminance, png_pixel_stddev, read_png_rgb, rgb_region_mean, rgb_stddev};

/// `name` in `dir` (an integration test passes `env!("CARGO_TARGET_TMPDIR")`, Cargo's scratch
/// directory, kept so the frame can be looked at), with any frame of an earlier run removed.
pub fn out_path(dir: &str, name: &str) -> PathBuf {
    let out = PathBuf::from(dir).join(name);
    let _ = std::fs::remove_file(&out);
    out
}

/// An app with `headless` (`volcano_render::headless_default_plugins()`, possibly trimmed), the
/// core, render and sky plugins, capturing a `width × height` frame to `out` after `updates`
/// updates and once every render pipeline has compiled (4 updates suffice for a still scene;
/// a scene that simulates asks for as many as it needs).
pub fn capture_app(headless: PluginGroupBuilder, width: u32, height: u32, out: &Path, updates: u32) -> App {
    let mut app = App::new();
    app.add_plugins(headless)
        .add_plugins((VolcanoCorePlugin, VolcanoRenderPlugins, VolcanoSkyPlugin))
        .add_plugins(HeadlessCapturePlugin {
            width,
            height,
            out: out.to_path_buf(),
            capture_after_updates: updates,
        });
    app
}

/// Runs `app` to its end, checks that it exited successfully and returns the frame written to
/// `out` (width, height, RGB).
pub fn run_and_read(mut app: App, out: &Path) -> (u32, u32, Vec<u8>) {
    let exit = app.run();
    assert!(exit.is_success(), "app exited with {exit:?}");
    read_png_rgb(out).expect("PNG written")
}
