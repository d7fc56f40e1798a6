//! Screenshot of the primary window after a number of frames, then exit: lets a windowed
//! example be checked under `xvfb-run` (set `VOLCANO_SCREENSHOT=out.png`).

use std::path::PathBuf;

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};

/// Takes one screenshot of the primary window after `after_frames` frames, exits 30 frames later.
#[derive(Debug, Clone)]
pub struct WindowScreenshotPlugin {
    /// Output PNG path.
    pub path: PathBuf,
    /// Frames to wait before the screenshot.
    pub after_frames: u32,
}

impl WindowScreenshotPlugin {
    /// From the `VOLCANO_SCREENSHOT` environment variable, if set (capture after 60 frames).
    pub fn from_env() -> Option<Self> {
        std::env::var_os("VOLCANO_SCREENSHOT").map(|p| Self { path: p.into(), after_frames: 60 })
    }
}

impl Plugin for WindowScreenshotPlugin {
    fn build(&self, app: &mut App) {
        let (path, after) = (self.path.clone(), self.after_frames);
        app.add_systems(
            Update,
            move |mut commands: Commands, mut frames: Local<u32>, mut exit: MessageWriter<AppExit>| {
                *frames += 1;
                if *frames == after {
                    commands.spawn(Screenshot::primary_window()).observe(save_to_disk(path.clone()));
                }
                if *frames == after + 30 {
                    exit.write(AppExit::Success);
                }
            },
        );
    }
}
