//! Offscreen rendering without a window or display: Bevy's renderer on any Vulkan adapter
//! (llvmpipe works), the [`crate::VolcanoViewer`] camera retargeted to an image, one screenshot written
//! to a PNG, then the app exits.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use volcano_render::{HeadlessCapturePlugin, VolcanoRenderPlugins, headless_default_plugins};
//!
//! let exit = App::new()
//!     .add_plugins((headless_default_plugins(), VolcanoRenderPlugins))
//!     .add_plugins(HeadlessCapturePlugin::new(640, 480, "frame.png"))
//!     // … the same scene systems as the windowed app …
//!     .run();
//! assert!(exit.is_success());
//! ```

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use bevy::app::{PluginGroupBuilder, ScheduleRunnerPlugin};
use bevy::camera::RenderTarget;
use bevy::image::Image;
use bevy::prelude::*;
use bevy::render::render_resource::{CachedPipelineState, PipelineCache, TextureFormat};
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::render::{Render, RenderApp, RenderPlugin, RenderSystems};
use bevy::window::ExitCondition;
use bevy::winit::WinitPlugin;

use crate::camera::VolcanoViewer;

/// `DefaultPlugins` (as enabled by this crate's features) for rendering without a window: no
/// primary window and no winit, pipelines compiled synchronously (the first frames are
/// complete), and a [`ScheduleRunnerPlugin`] loop so `app.run()` keeps updating until
/// something sends `AppExit`.
pub fn headless_default_plugins() -> PluginGroupBuilder {
    DefaultPlugins
        .build()
        .set(WindowPlugin {
            primary_window: None,
            exit_condition: ExitCondition::DontExit,
            close_when_requested: false,
            ..default()
        })
        .disable::<WinitPlugin>()
        .set(RenderPlugin { synchronous_pipeline_compilation: true, ..default() })
        .add(ScheduleRunnerPlugin::run_loop(Duration::ZERO))
}

/// Renders every [`VolcanoViewer`] camera into a `width × height` sRGB image, saves a screenshot of it to
/// `out` (PNG) after `capture_after_updates` app updates, and exits: `AppExit::Success` once the
/// file is written, an error exit if writing fails or nothing was captured within
/// [`HeadlessCapturePlugin::SAFETY_UPDATES`] further updates.
#[derive(Debug, Clone)]
pub struct HeadlessCapturePlugin {
    /// Image width (pixels).
    pub width: u32,
    /// Image height (pixels).
    pub height: u32,
    /// Output PNG path (parent directories are created).
    pub out: PathBuf,
    /// App updates to run before requesting the screenshot (lets assets load and LUTs settle).
    /// The request also waits until the render world's last frame had every pipeline compiled
    /// (at most [`HeadlessCapturePlugin::SETTLE_UPDATES`] more updates), so a frame drawn while
    /// a shader was still loading is never the one captured. The frame is drawn in the update of
    /// the request; the camera stops drawing while its read-back completes.
    pub capture_after_updates: u32,
}

impl HeadlessCapturePlugin {
    /// Updates allowed after the capture request before the app gives up with an error.
    pub const SAFETY_UPDATES: u32 = 600;
    /// Updates past `capture_after_updates` the capture waits for every render pipeline to
    /// compile (a shader still loading) before it captures anyway, with a warning (a shader
    /// that fails to compile never will).
    pub const SETTLE_UPDATES: u32 = 120;

    /// Capture of `width × height` to `out` after 8 updates.
    pub fn new(width: u32, height: u32, out: impl Into<PathBuf>) -> Self {
        Self { width, height, out: out.into(), capture_after_updates: 8 }
    }
}

/// Progress of the headless capture (inspectable by tests and tools).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Debug)]
pub enum CaptureStatus {
    /// Counting updates before the capture.
    Waiting,
    /// Screenshot requested at this update; waiting for the GPU readback.
    Requested(u32),
    /// The PNG was written to this path.
    Saved(PathBuf),
    /// Capture or writing failed.
    Failed(String),
}

#[derive(Resource, Debug, Clone)]
struct CaptureTarget {
    image: Handle<Image>,
    out: PathBuf,
    after: u32,
    updates: u32,
}

impl Plugin for HeadlessCapturePlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<CaptureStatus>()
            .insert_resource(CaptureStatus::Waiting)
            .add_observer(retarget_main_camera)
            .add_systems(Last, drive_capture);
    }

    fn finish(&self, app: &mut App) {
        // In `finish`, after every plugin's `build`, so the image assets exist whatever the
        // order the plugins were added in.
        let (w, h) = (self.width.max(1), self.height.max(1));
        let image = Image::new_target_texture(w, h, TextureFormat::Rgba8UnormSrgb, None);
        let handle = app.world_mut().resource_mut::<Assets<Image>>().add(image);
        app.insert_resource(CaptureTarget {
            image: handle,
            out: self.out.clone(),
            after: self.capture_after_updates,
            updates: 0,
        });
        let renderer = RendererProgress::default();
        app.insert_resource(renderer.clone());
        if let Some(render_app) = app.get_sub_app_mut(RenderApp) {
            render_app
                .insert_resource(renderer)
                .add_systems(Render, report_pipelines.in_set(RenderSystems::Cleanup));
        }
    }
}

/// What the render world's last frame says about its pipelines, shared with the main world:
/// a frame drawn while a pipeline is still queued, compiling or waiting for its shader lacks
/// whatever that pipeline draws.
#[derive(Resource, Debug, Clone, Default)]
struct RendererProgress(Arc<RendererCounts>);

#[derive(Debug, Default)]
struct RendererCounts {
    /// Frames the render world has run.
    frames: AtomicU32,
    /// Pipelines not ready at the end of the last frame.
    pending: AtomicU32,
}

impl RendererProgress {
    /// At least one frame rendered and every pipeline it knows compiled.
    fn settled(&self) -> bool {
        self.0.frames.load(Ordering::Acquire) > 0 && self.0.pending.load(Ordering::Acquire) == 0
    }
}

/// Counts the pipelines not ready after this frame's compilation (in `RenderSystems::Cleanup`).
fn report_pipelines(cache: Res<PipelineCache>, progress: Res<RendererProgress>) {
    let pending = cache.pipelines().filter(|p| !matches!(p.state, CachedPipelineState::Ok(_))).count();
    progress.0.pending.store(pending as u32, Ordering::Release);
    progress.0.frames.fetch_add(1, Ordering::Release);
}

/// Points each new [`VolcanoViewer`] at the capture image (scene code stays the windowed one).
fn retarget_main_camera(add: On<Add, VolcanoViewer>, target: Res<CaptureTarget>, mut commands: Commands) {
    commands.entity(add.entity).insert(RenderTarget::from(target.image.clone()));
}

fn drive_capture(
    mut commands: Commands,
    mut target: ResMut<CaptureTarget>,
    status: Res<CaptureStatus>,
    renderer: Res<RendererProgress>,
    mut cameras: Query<(&mut Camera, &RenderTarget)>,
    mut exit: MessageWriter<AppExit>,
) {
    target.updates += 1;
    match &*status {
        // The requested frame is drawn and copied; the updates that wait for its read-back
        // need not draw again (on a software renderer a volumetric frame takes seconds).
        CaptureStatus::Requested(at) if target.updates == at + 1 => {
            for (mut camera, render_target) in &mut cameras {
                if matches!(render_target, RenderTarget::Image(t) if t.handle == target.image) {
                    camera.is_active = false;
                }
            }
        }
        CaptureStatus::Waiting
            if target.updates >= target.after
                && (renderer.settled()
                    || target.updates >= target.after + HeadlessCapturePlugin::SETTLE_UPDATES) =>
        {
            if !renderer.settled() {
                warn!(
                    "headless capture: {} pipelines still not compiled {} updates after the requested update; capturing anyway",
                    renderer.0.pending.load(Ordering::Acquire),
                    HeadlessCapturePlugin::SETTLE_UPDATES
                );
            }
            if let Some(dir) = target.out.parent().filter(|d| !d.as_os_str().is_empty())
                && let Err(e) = std::fs::create_dir_all(dir)
            {
                error!("headless capture: cannot create {}: {e}", dir.display());
                commands.insert_resource(CaptureStatus::Failed(e.to_string()));
                exit.write(AppExit::error());
                return;
            }
            let out = target.out.clone();
            commands.spawn(Screenshot::image(target.image.clone())).observe(
                move |captured: On<ScreenshotCaptured>,
                      mut commands: Commands,
                      mut exit: MessageWriter<AppExit>| {
                    match write_png_rgb(&captured.image, &out) {
                        Ok(()) => {
                            info!("headless capture saved to {}", out.display());
                            commands.insert_resource(CaptureStatus::Saved(out.clone()));
                            exit.write(AppExit::Success);
                        }
                        Err(e) => {
                            error!("headless capture: cannot write {}: {e}", out.display());
                            commands.insert_resource(CaptureStatus::Failed(e));
                            exit.write(AppExit::error());
                        }
                    }
                },
            );
            commands.insert_resource(CaptureStatus::Requested(target.updates));
        }
        CaptureStatus::Requested(at) if target.updates > at + HeadlessCapturePlugin::SAFETY_UPDATES => {
            let msg =
                format!("no screenshot {} updates after the request", HeadlessCapturePlugin::SAFETY_UPDATES);
            error!("headless capture: {msg}");
            commands.insert_resource(CaptureStatus::Failed(msg));
            exit.write(AppExit::error());
        }
        _ => {}
    }
}

/// Writes an 8-bit RGBA/BGRA image (what screenshots of sRGB targets are) as an RGB PNG,
/// dropping alpha.
pub fn write_png_rgb(image: &Image, path: &Path) -> Result<(), String> {
    let (w, h) = (image.width(), image.height());
    let data = image.data.as_deref().ok_or("the screenshot has no CPU data")?;
    let swap = match image.texture_descriptor.format {
        TextureFormat::Rgba8UnormSrgb | TextureFormat::Rgba8Unorm => false,
        TextureFormat::Bgra8UnormSrgb | TextureFormat::Bgra8Unorm => true,
        f => return Err(format!("unsupported screenshot format {f:?}")),
    };
    if data.len() != (w * h * 4) as usize {
        return Err(format!("screenshot has {} bytes for {w}×{h} RGBA", data.len()));
    }
    let rgb: Vec<u8> = data
        .chunks_exact(4)
        .flat_map(|p| if swap { [p[2], p[1], p[0]] } else { [p[0], p[1], p[2]] })
        .collect();
    let file = File::create(path).map_err(|e| e.to_string())?;
    let mut encoder = png::Encoder::new(BufWriter::new(file), w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(&rgb).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())
}
