//! `volcano render`: one scene simulated headless for N base ticks and written as a PNG, with
//! the command line's camera, sun, debug views and hidden layers.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::prelude::*;
use volcano::render::headless::{HeadlessCapturePlugin, headless_default_plugins};
use volcano::scenes::CameraSpec;

use crate::TICK_HZ;

/// What `volcano render` draws and from where, beside the scene's own settings.
pub(crate) struct Views {
    pub plume: volcano::render::PlumeRenderMode,
    pub lava: volcano::render::LavaRenderMode,
    pub camera: Option<CameraSpec>,
    /// Azimuth and elevation (degrees) instead of the scene's.
    pub sun: Option<(f32, f32)>,
    pub bloom: bool,
    /// Layers left out of the frame.
    pub hide: Vec<Hide>,
}

/// `--hide` values: layers a frame can leave out.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Hide {
    /// The atmosphere's lit clouds.
    Clouds,
    /// The ash fall curtain under the umbrella.
    AshFall,
    /// The grey ash deposit on the terrain.
    Deposit,
    /// The column's, umbrella's and currents' ash (billboards and detail spheres).
    Ash,
}

/// Parses `--camera FX,FY,FZ,YAW,PITCH,DISTANCE`.
pub(crate) fn parse_camera(text: &str) -> Result<CameraSpec, String> {
    let v: Vec<f32> = text
        .split(',')
        .map(|t| t.trim().parse::<f32>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let [fx, fy, fz, yaw_deg, pitch_deg, distance] = v[..] else {
        return Err(format!("expected 6 comma-separated numbers, got {}", v.len()));
    };
    Ok(CameraSpec { focus: (fx, fy, fz), yaw_deg, pitch_deg, distance })
}

/// Parses `--sun AZIMUTH,ELEVATION` (degrees; the scene validates the ranges).
pub(crate) fn parse_sun(text: &str) -> Result<(f32, f32), String> {
    let v: Vec<f32> = text
        .split(',')
        .map(|t| t.trim().parse::<f32>().map_err(|e| format!("{t:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let [azimuth, elevation] = v[..] else {
        return Err(format!("expected 2 comma-separated numbers, got {}", v.len()));
    };
    Ok((azimuth, elevation))
}

/// `--plume-view` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PlumeView {
    /// Smoke billboards and detail spheres (the main view).
    Ash,
    /// The main view with the slices as circles.
    AshSlices,
    /// s1 and umbrella spheres as meshes, slices as circles.
    Spheres,
    /// Slices as circles only.
    Slices,
}

impl From<PlumeView> for volcano::render::PlumeRenderMode {
    fn from(v: PlumeView) -> Self {
        use volcano::render::PlumeRenderMode as M;
        match v {
            PlumeView::Ash => M::Ash,
            PlumeView::AshSlices => M::AshWithSlices,
            PlumeView::Spheres => M::DebugSpheres,
            PlumeView::Slices => M::DebugSlices,
        }
    }
}

/// `--lava-view` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LavaView {
    /// Incandescent surface darkened by the crust, lit folds.
    Lit,
    /// Crust thickness in the thesis' debug colours (red < 8 mm, green < 2 cm, blue), folds white.
    Crust,
    /// Lava thickness.
    Thickness,
}

impl From<LavaView> for volcano::render::LavaRenderMode {
    fn from(v: LavaView) -> Self {
        use volcano::render::LavaRenderMode as M;
        match v {
            LavaView::Lit => M::Lit,
            LavaView::Crust => M::DebugCrust,
            LavaView::Thickness => M::DebugThickness,
        }
    }
}

/// One line per air layer: its largest condensed water (g/m³) over the grid and within 3 km
/// of the grid's centre (the vent in the scenes), and its cells above the cloud threshold.
fn cloud_report(
    atmos: &Query<(Entity, &volcano::atmosphere::Atmosphere)>,
    layers: &Query<&volcano::atmosphere::AirLayer>,
) -> Vec<String> {
    let mut out = Vec::new();
    for (entity, atmo) in atmos {
        let Ok(shell) = atmo.state_shell() else { continue };
        let mut mine: Vec<_> = layers.iter().filter(|l| l.atmosphere == entity).collect();
        mine.sort_by_key(|l| l.index);
        for l in mine {
            let w = l.fields.w.data();
            let (mut all, mut near, mut cloudy, mut sum) = (0.0f64, 0.0f64, 0usize, [0.0f64; 3]);
            for (k, &v) in w.iter().enumerate() {
                let (x, y) = shell.grid.centre(k);
                all = all.max(v);
                if x.hypot(y) <= 3_000.0 {
                    near = near.max(v);
                }
                if v >= atmo.params.cloud_threshold {
                    cloudy += 1;
                    sum = [sum[0] + v * x, sum[1] + v * y, sum[2] + v];
                }
            }
            let (cx, cy) = if sum[2] > 0.0 { (sum[0] / sum[2], sum[1] / sum[2]) } else { (0.0, 0.0) };
            out.push(format!(
                "clouds: layer {} at {:.0} m: max condensed water {all:.3} g/m³ ({near:.3} within 3 km of the centre), {cloudy} cells ≥ {} g/m³, their water's centroid at x {cx:.0} m, grid y {cy:.0} m",
                l.index, l.fields.altitude, atmo.params.cloud_threshold
            ));
        }
    }
    out
}

pub(crate) fn render(
    scene: &str,
    ticks: u32,
    out: PathBuf,
    (width, height): (u32, u32),
    min_stddev: f64,
    Views { plume: view, lava: lava_view, camera, sun, bloom, hide }: Views,
    plume_substeps: Option<u32>,
) -> ExitCode {
    if !(16..=8192).contains(&width) || !(16..=8192).contains(&height) {
        eprintln!("error: --width and --height must be in 16..=8192");
        return ExitCode::from(2);
    }
    // The scene, with the camera and sun overrides (validated with the rest of the scene).
    let spec = volcano::scenes::by_name(scene).map(|mut s| {
        if let Some(c) = camera {
            s.camera = c;
        }
        if let Some((azimuth, elevation)) = sun {
            s.sun.azimuth_deg = azimuth;
            s.sun.elevation_deg = elevation;
        }
        s
    });
    let scene = match spec.and_then(VolcanoScenePlugin::new) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
        && let Err(e) = std::fs::create_dir_all(dir)
    {
        eprintln!("error: cannot create {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let _ = std::fs::remove_file(&out);
    let started = std::time::Instant::now();
    // Largest divisor of `ticks` up to 1,500 base ticks (30 s) per update: each update draws a
    // software frame (seconds each with the column's ~10⁶ instances), so a 5-minute run draws
    // ten frames, not sixty; the simulation does not depend on the chunk (frame-rate
    // independence is tested per domain).
    let chunk = (1..=ticks.clamp(1, 1500)).rev().find(|d| ticks.is_multiple_of(*d)).unwrap_or(1);
    let mut app = App::new();
    app.add_plugins(headless_default_plugins())
        .add_plugins(VolcanoSimPlugins)
        .add_plugins(volcano::render::VolcanoRenderPlugins)
        .add_plugins(scene)
        .insert_resource(Time::<Fixed>::from_hz(TICK_HZ))
        .insert_resource(view)
        .insert_resource(lava_view)
        // A still: the ash lit from the last ticked frame's parents, taken up by the first
        // settling frame (a light every tick; a game's default is every third).
        .insert_resource(volcano::plume::AshLightSettings { refresh_ticks: 1, ..default() })
        // Several base ticks per update so long runs do not render thousands of software
        // frames: `chunk` divides `ticks`, so exactly `ticks` ticks are simulated; afterwards
        // time stops while the capture settles.
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20) * chunk))
        .add_systems(Last, move |tick: Res<SimTick>, mut strategy: ResMut<TimeUpdateStrategy>| {
            if tick.0 >= u64::from(ticks) {
                *strategy = TimeUpdateStrategy::ManualDuration(Duration::ZERO);
            }
        })
        .add_plugins(HeadlessCapturePlugin {
            width,
            height,
            out: out.clone(),
            // The first update has zero delta; then ticks/chunk updates; then 3 to settle.
            capture_after_updates: 1 + ticks / chunk + 3,
        });
    // A still shows the clouds and the ash of the last weather step, whatever the worker's
    // timing: both volumes are built in the frame the weather moved.
    app.world_mut().resource_mut::<volcano::render::CloudRenderSettings>().off_thread = false;
    app.world_mut().resource_mut::<volcano::render::AshFallSettings>().off_thread = false;
    for layer in hide {
        let world = app.world_mut();
        match layer {
            Hide::Clouds => world.resource_mut::<volcano::render::CloudRenderSettings>().enabled = false,
            Hide::AshFall => world.resource_mut::<volcano::render::AshFallSettings>().enabled = false,
            Hide::Deposit => world.resource_mut::<volcano::render::DepositTint>().enabled = false,
            Hide::Ash => world.resource_mut::<volcano::plume::PlumeViewSettings>().enabled = false,
        }
    }
    if bloom {
        // The scene's camera opts in to HDR and bloom (no egui here to need LDR).
        app.add_observer(|add: On<Add, volcano::render::VolcanoViewer>, mut commands: Commands| {
            commands.entity(add.entity).insert(volcano::render::GlowCamera);
        });
    }
    app.world_mut().resource_mut::<Time<Virtual>>().set_max_delta(Duration::from_millis(20) * chunk.max(13));
    if let Some(n) = plume_substeps
        && let Err(e) = app
            .world_mut()
            .resource_mut::<Time<DomainClock<volcano::plume::PlumeStep>>>()
            .context_mut()
            .set_cadence(Cadence::Substeps(n))
    {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    // What the rendered clouds are made of: condensed water per layer at the last update.
    let clouds: std::sync::Arc<std::sync::Mutex<Vec<String>>> = Default::default();
    let sink = clouds.clone();
    app.add_systems(
        Last,
        move |atmos: Query<(Entity, &volcano::atmosphere::Atmosphere)>,
              layers: Query<&volcano::atmosphere::AirLayer>| {
            *sink.lock().unwrap() = cloud_report(&atmos, &layers);
        },
    );
    let exit = app.run();
    for line in clouds.lock().unwrap().iter() {
        println!("{line}");
    }
    if !exit.is_success() || !out.exists() {
        eprintln!("error: rendering failed ({exit:?}); is a Vulkan driver installed (mesa-vulkan-drivers)?");
        return ExitCode::FAILURE;
    }
    match frame_stddev(&out) {
        Ok(sd) => {
            println!(
                "wrote {} ({width}×{height}) after {ticks} ticks in {:.1} s; pixel std-dev {sd:.1}",
                out.display(),
                started.elapsed().as_secs_f64()
            );
            if sd < min_stddev {
                eprintln!("error: the frame looks blank (std-dev {sd:.2} < {min_stddev})");
                return ExitCode::FAILURE;
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: wrote an unreadable PNG: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The blank-frame measure of `--min-stddev`: the mean over R, G and B of each channel's
/// standard deviation across the pixels of the PNG at `path` (0–255 scale); a one-colour frame
/// gives 0 whatever the colour.
fn frame_stddev(path: &std::path::Path) -> Result<f64, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; reader.output_buffer_size().ok_or("PNG too large")?];
    let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    let channels = info.color_type.samples();
    let (mut sum, mut sq, mut n) = ([0f64; 3], [0f64; 3], 0f64);
    for p in buf[..info.buffer_size()].chunks_exact(channels) {
        for c in 0..3 {
            // Grey (and grey with alpha) frames count their one value on each channel.
            let v = f64::from(p[if channels < 3 { 0 } else { c }]);
            sum[c] += v;
            sq[c] += v * v;
        }
        n += 1.0;
    }
    if n == 0.0 {
        return Ok(0.0);
    }
    Ok((0..3).map(|c| (sq[c] / n - (sum[c] / n).powi(2)).max(0.0).sqrt()).sum::<f64>() / 3.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Cli, Command};
    use clap::Parser;

    /// A 4 × 2 RGB PNG: left half pure blue, right half `right`.
    fn two_tone_png(name: &str, right: [u8; 3]) -> PathBuf {
        let path = std::env::temp_dir().join(format!("volcano_cli_{}_{name}.png", std::process::id()));
        let rgb: Vec<u8> = (0..8).flat_map(|i| if i % 4 < 2 { [0, 0, 255] } else { right }).collect();
        let mut encoder = png::Encoder::new(std::fs::File::create(&path).unwrap(), 4, 2);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.write_header().unwrap().write_image_data(&rgb).unwrap();
        path
    }

    #[test]
    fn frame_stddev_measures_contrast_whatever_the_colour() {
        // Blue channel half 0, half 255: σ = 127.5; R and G: 0. Mean of the three: 42.5.
        let half = two_tone_png("half", [0, 0, 0]);
        assert!((frame_stddev(&half).unwrap() - 42.5).abs() < 1e-9);
        let blank = two_tone_png("blank", [0, 0, 255]);
        assert_eq!(frame_stddev(&blank).unwrap(), 0.0);
        assert!(frame_stddev(&half.with_file_name("missing.png")).is_err());
        for p in [half, blank] {
            std::fs::remove_file(p).ok();
        }
    }

    #[test]
    fn sun_override_parses_and_rejects_bad_input() {
        let cli = Cli::try_parse_from(["volcano", "render", "--out", "x.png", "--sun", "230,-5"]).unwrap();
        let Command::Render { sun, .. } = cli.command else { panic!("not a render command") };
        assert_eq!(sun, Some((230.0, -5.0)));
        for bad in ["230", "230,28,1", "south,28"] {
            let parsed = Cli::try_parse_from(["volcano", "render", "--out", "x.png", "--sun", bad]);
            assert!(parsed.is_err(), "--sun {bad} was accepted");
        }
    }

    #[test]
    fn hide_takes_a_list_of_layers_and_rejects_unknown_ones() {
        let cli = Cli::try_parse_from(["volcano", "render", "--out", "x.png", "--hide", "ash-fall,clouds"])
            .unwrap();
        let Command::Render { hide, .. } = cli.command else { panic!("not a render command") };
        assert_eq!(hide, vec![Hide::AshFall, Hide::Clouds]);
        let cli = Cli::try_parse_from(["volcano", "render", "--out", "x.png"]).unwrap();
        let Command::Render { hide, .. } = cli.command else { panic!("not a render command") };
        assert!(hide.is_empty());
        assert!(Cli::try_parse_from(["volcano", "render", "--out", "x.png", "--hide", "sky"]).is_err());
    }
}
