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
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};
use std::time::Duration;

use bevy::app::{PluginGroupBuilder, ScheduleRunnerPlugin};
use bevy::camera::RenderTarget;
use bevy::image::Image;
use bevy::prelude::*;
use bevy::render::RenderPlugin;
use bevy::render::render_resource::TextureFormat;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
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
    pub capture_after_updates: u32,
}

impl HeadlessCapturePlugin {
    /// Updates allowed after the capture request before the app gives up with an error.
    pub const SAFETY_UPDATES: u32 = 600;

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
    }
}

/// Points each new [`VolcanoViewer`] at the capture image (scene code stays the windowed one).
fn retarget_main_camera(add: On<Add, VolcanoViewer>, target: Res<CaptureTarget>, mut commands: Commands) {
    commands.entity(add.entity).insert(RenderTarget::from(target.image.clone()));
}

fn drive_capture(
    mut commands: Commands,
    mut target: ResMut<CaptureTarget>,
    status: Res<CaptureStatus>,
    mut exit: MessageWriter<AppExit>,
) {
    target.updates += 1;
    match &*status {
        CaptureStatus::Waiting if target.updates >= target.after => {
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

/// Reads an 8-bit PNG as `(width, height, RGB bytes)` (grey and alpha are expanded/dropped).
pub fn read_png_rgb(path: impl AsRef<Path>) -> Result<(u32, u32, Vec<u8>), String> {
    let path = path.as_ref();
    let file = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; reader.output_buffer_size().ok_or("PNG too large")?];
    let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    buf.truncate(info.buffer_size());
    let rgb = match info.color_type {
        png::ColorType::Rgb => buf,
        png::ColorType::Rgba => buf.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect(),
        png::ColorType::Grayscale => buf.iter().flat_map(|&g| [g, g, g]).collect(),
        png::ColorType::GrayscaleAlpha => buf.chunks_exact(2).flat_map(|p| [p[0], p[0], p[0]]).collect(),
        png::ColorType::Indexed => return Err("indexed PNG was not expanded".into()),
    };
    Ok((info.width, info.height, rgb))
}

/// Mean RGB of the pixel rectangle `[x0, x1) × [y0, y1)` of a `width`-pixel-wide RGB image.
pub fn rgb_region_mean(rgb: &[u8], width: u32, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for y in y0..y1 {
        for x in x0..x1 {
            let i = ((y * width + x) * 3) as usize;
            for c in 0..3 {
                sum[c] += rgb[i + c] as f64;
            }
        }
    }
    let n = ((x1 - x0) * (y1 - y0)).max(1) as f64;
    sum.map(|s| s / n)
}

/// Mean over the R, G, B channels of each channel's standard deviation across pixels (0–255
/// scale) of an RGB buffer. A one-colour frame gives 0 whatever the colour.
pub fn rgb_stddev(rgb: &[u8]) -> f64 {
    let n = (rgb.len() / 3) as f64;
    if n == 0.0 {
        return 0.0;
    }
    let mut sum = [0f64; 3];
    let mut sq = [0f64; 3];
    for p in rgb.chunks_exact(3) {
        for c in 0..3 {
            let v = p[c] as f64;
            sum[c] += v;
            sq[c] += v * v;
        }
    }
    (0..3).map(|c| (sq[c] / n - (sum[c] / n).powi(2)).max(0.0).sqrt()).sum::<f64>() / 3.0
}

/// [`rgb_stddev`] of a PNG file: a blank-frame check for render tests.
pub fn png_pixel_stddev(path: impl AsRef<Path>) -> Result<f64, String> {
    read_png_rgb(path).map(|(_, _, rgb)| rgb_stddev(&rgb))
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::asset::RenderAssetUsages;
    use bevy::render::render_resource::{Extent3d, TextureDimension};

    #[test]
    fn png_round_trip_and_stddev() {
        let dir = std::env::temp_dir().join(format!("volcano_render_png_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        let (w, h) = (4u32, 2u32);
        // Left half pure blue, right half black: not blank.
        let data: Vec<u8> =
            (0..w * h).flat_map(|i| if i % w < 2 { [0, 0, 255, 255] } else { [0, 0, 0, 255] }).collect();
        let size = Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        let img = Image::new(
            size,
            TextureDimension::D2,
            data,
            TextureFormat::Rgba8UnormSrgb,
            RenderAssetUsages::all(),
        );
        write_png_rgb(&img, &path).unwrap();
        let (rw, rh, rgb) = read_png_rgb(&path).unwrap();
        assert_eq!((rw, rh), (w, h));
        assert_eq!(&rgb[..6], &[0, 0, 255, 0, 0, 255]);
        // Blue channel: half 0, half 255 → σ = 127.5; R and G: 0. Mean of the three: 42.5.
        assert!((png_pixel_stddev(&path).unwrap() - 42.5).abs() < 1e-9);
        // One colour, whichever: zero.
        assert_eq!(rgb_stddev(&[0, 0, 255].repeat(10)), 0.0);
        assert!(png_pixel_stddev(dir.join("missing.png")).is_err());
        let bad = dir.join("no_such_dir").join("x.png");
        assert!(write_png_rgb(&img, &bad).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
