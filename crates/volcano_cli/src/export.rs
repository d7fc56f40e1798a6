//! `volcano export`: runs a built-in scene headless and writes frames an offline renderer
//! opens (docs/EXPORT.md): per frame `frame_NNNN.vdb` (OpenVDB grids `ash`, `temperature`,
//! `cloud`, `ash_fall`, `air_temperature`; world metres, y up), `frame_NNNN.glb` (lava
//! surfaces and fold ropes, when the scene has lava) and `frame_NNNN.json` (time, camera,
//! sun, grids), and once `terrain.glb`, each written under a temporary name and renamed when
//! complete; `--expect` adds `frame_NNNN.expect.json` for `tools/check_vdb.py` (the check
//! with OpenVDB itself). One frame is held in memory at a time.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::export::vdb::{FloatGrid, expectation};
use volcano::export::{
    ExportSettings, FrameView, capture_frame, capture_terrain, frame_paths, write_frame, write_terrain,
};
use volcano::prelude::*;

/// What `volcano export` was asked for.
#[derive(Debug, Clone)]
pub struct ExportArgs {
    /// Built-in scene.
    pub scene: String,
    /// Base ticks run before the first frame.
    pub ticks: u64,
    /// Frames to write.
    pub frames: u32,
    /// Base ticks between frames.
    pub every: u64,
    /// Quality level, if any.
    pub quality: Option<VolcanoQuality>,
    /// Voxel sizes and budget.
    pub settings: ExportSettings,
    /// Also write the expectation `tools/check_vdb.py` reads.
    pub expect: bool,
    /// Camera instead of the scene's.
    pub camera: Option<volcano::scenes::CameraSpec>,
    /// Sun azimuth and elevation (degrees) instead of the scene's.
    pub sun: Option<(f32, f32)>,
    /// Output folder.
    pub out: PathBuf,
}

/// Most base ticks one export runs (a simulated day at 50 Hz).
const MAX_TICKS: u64 = 24 * 3_600 * 50;

/// Checks the arguments before anything runs: a clear error for each.
fn check(args: &ExportArgs) -> Result<VolcanoScenePlugin, String> {
    if args.frames == 0 {
        return Err("--frames must be at least 1".into());
    }
    if args.every == 0 && args.frames > 1 {
        return Err("--every must be at least 1 base tick when --frames is more than 1".into());
    }
    let last = args.every.checked_mul(args.frames as u64 - 1).and_then(|t| t.checked_add(args.ticks));
    if last.is_none_or(|t| t > MAX_TICKS) {
        return Err(format!("--ticks + --every × (--frames − 1) must be at most {MAX_TICKS} base ticks"));
    }
    args.settings.validate().map_err(|e| e.to_string())?;
    VolcanoScenePlugin::builtin(&args.scene).map(VolcanoScenePlugin::headless).map_err(|e| e.to_string())
}

/// Runs the export; prints one progress line per frame on stderr.
pub fn run(args: &ExportArgs) -> ExitCode {
    let plugin = match check(args) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Err(e) = std::fs::create_dir_all(&args.out) {
        eprintln!("error: cannot create {}: {e}", args.out.display());
        return ExitCode::FAILURE;
    }
    let mut spec = plugin.spec().clone();
    if let Some(c) = args.camera {
        spec.camera = c;
    }
    if let Some((azimuth_deg, elevation_deg)) = args.sun {
        spec.sun = volcano::scenes::SunSpec { azimuth_deg, elevation_deg, ..spec.sun };
    }
    let view = FrameView::of_scene(&spec);
    let mut app = App::new();
    if let Some(q) = args.quality {
        app.insert_resource(q);
    }
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins, plugin))
        .insert_resource(Time::<Fixed>::from_hz(crate::TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / crate::TICK_HZ)));
    let started = Instant::now();
    let last_tick = args.ticks + args.every * (args.frames as u64 - 1);
    let mut bar = Progress::new(last_tick);
    for frame in 0..args.frames {
        let target = args.ticks + args.every * frame as u64;
        while let Some(tick) =
            app.world().get_resource::<SimTick>().map_or(Some(0), |t| (t.0 < target).then_some(t.0))
        {
            bar.show(tick, frame, args.frames, started);
            app.update();
        }
        let captured = match capture_frame(app.world_mut(), &args.settings, view) {
            Ok(f) => f,
            Err(e) => {
                eprintln!("error: frame {frame}: {e}");
                return ExitCode::FAILURE;
            }
        };
        if let Err(e) = write_frame(&args.out, frame, &captured) {
            eprintln!("error: frame {frame}: {e}");
            return ExitCode::FAILURE;
        }
        // The terrain once, with the first frame (lava that froze into it shows in the frames'
        // lava surfaces).
        if frame == 0 {
            let written = capture_terrain(app.world_mut(), &args.settings)
                .and_then(|t| t.map(|t| write_terrain(&args.out, &t)).transpose());
            if let Err(e) = written {
                eprintln!("error: terrain: {e}");
                return ExitCode::FAILURE;
            }
        }
        if args.expect
            && let Err(e) = write_expectation(&args.out, frame, &captured.grids)
        {
            eprintln!("error: frame {frame}: {e}");
            return ExitCode::FAILURE;
        }
        let (vdb, _) = frame_paths(&args.out, frame);
        let mb = std::fs::metadata(&vdb).map_or(0.0, |m| m.len() as f64 / 1e6);
        let grids: Vec<String> =
            captured.info.grids.iter().map(|g| format!("{} {}", g.name, g.active_voxels)).collect();
        bar.clear();
        eprintln!(
            "frame {}/{}: t = {:.0} s, {} spheres, active voxels: {}; {} ({mb:.1} MB), {:.1} s elapsed",
            frame + 1,
            args.frames,
            captured.info.time_s,
            captured.info.spheres,
            grids.join(", "),
            vdb.display(),
            started.elapsed().as_secs_f64()
        );
    }
    ExitCode::SUCCESS
}

/// A one-line bar on a terminal's stderr while the scene runs between frames (nothing when
/// stderr is a file or a pipe: the per-frame lines are the log there).
struct Progress {
    last_tick: u64,
    on: bool,
    shown: Option<Instant>,
}

impl Progress {
    fn new(last_tick: u64) -> Self {
        use std::io::IsTerminal;
        Self { last_tick: last_tick.max(1), on: std::io::stderr().is_terminal(), shown: None }
    }

    /// Redraws at most five times a second: ticks done of the last frame's, frames written.
    fn show(&mut self, tick: u64, frame: u32, frames: u32, started: Instant) {
        if !self.on || self.shown.is_some_and(|t| t.elapsed() < Duration::from_millis(200)) {
            return;
        }
        self.shown = Some(Instant::now());
        let done = tick as f64 / self.last_tick as f64;
        let width = 30;
        let filled = ((done * width as f64) as usize).min(width);
        eprint!(
            "\r[{}{}] {:>3.0} %  tick {tick}/{}  frames written {frame}/{frames}  {:.0} s ",
            "#".repeat(filled),
            "-".repeat(width - filled),
            100.0 * done,
            self.last_tick,
            started.elapsed().as_secs_f64()
        );
    }

    fn clear(&mut self) {
        if self.on && self.shown.take().is_some() {
            eprint!("\r{}\r", " ".repeat(90));
        }
    }
}

/// `frame_NNNN.expect.json`: what `tools/check_vdb.py` compares the `.vdb` with.
fn write_expectation(dir: &Path, frame: u32, grids: &[FloatGrid]) -> Result<(), String> {
    let refs: Vec<&FloatGrid> = grids.iter().collect();
    let path = dir.join(format!("frame_{frame:04}.expect.json"));
    let text = expectation(&refs, 5_000).to_string();
    volcano::export::atomic::write_atomically::<volcano::export::ExportError>(&path, |w| {
        use std::io::Write;
        w.write_all(text.as_bytes()).map_err(|e| volcano::export::vdb::VdbError::Io(e).into())
    })
    .map_err(|e| e.to_string())
}
