//! `volcano`: the headless runner. Renders scenes to PNG without a display or GPU (Mesa's
//! llvmpipe through Vulkan), lists the scene registry, and runs the plume's single-slice
//! validation experiment.

mod bench;
mod domains;
mod eruption;
mod export;
mod plots;
mod plume;
mod ply;
mod pyroclastic;
mod render;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use clap::{Parser, Subcommand};
use volcano::prelude::*;
use volcano::scenes::CameraSpec;

use render::{Hide, LavaView, PlumeView, Views, parse_camera, parse_sun};

#[derive(Parser, Debug)]
#[command(name = "volcano", version, about = "Headless runner for the volcano plugin set")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate a scene for N base ticks (the thesis' 50 Hz) and write one rendered frame as PNG.
    Render {
        /// Scene name from the registry (see `volcano scenes`).
        #[arg(long, default_value = "eruption")]
        scene: String,
        /// Base ticks to simulate before the frame is taken.
        #[arg(long, default_value_t = 10)]
        ticks: u32,
        /// Output PNG path.
        #[arg(long)]
        out: PathBuf,
        /// Image width in pixels.
        #[arg(long, default_value_t = 960)]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 540)]
        height: u32,
        /// Fail (exit 1) if the frame's pixel standard deviation is below this: a blank check.
        #[arg(long, default_value_t = 0.0)]
        min_stddev: f64,
        /// How the eruption column is drawn: the main view or a debug view.
        #[arg(long, value_enum, default_value_t = PlumeView::Ash)]
        plume_view: PlumeView,
        /// How lava is drawn: incandescent, or a debug view.
        #[arg(long, value_enum, default_value_t = LavaView::Lit)]
        lava_view: LavaView,
        /// Camera instead of the scene's: `FX,FY,FZ,YAW,PITCH,DISTANCE` (focus in world metres,
        /// angles in degrees), e.g. a close-up of a lava patch.
        #[arg(long, value_parser = parse_camera, allow_hyphen_values = true)]
        camera: Option<CameraSpec>,
        /// Sun instead of the scene's: `AZIMUTH,ELEVATION` in degrees (azimuth clockwise from
        /// north), the scene's illuminance kept; e.g. side light on a front-lit column.
        #[arg(long, value_parser = parse_sun, allow_hyphen_values = true)]
        sun: Option<(f32, f32)>,
        /// Plume substeps per base tick instead of the thesis' 0.002 s steps (10 at 50 Hz):
        /// e.g. 2 (0.01 s steps, as `volcano eruption` uses) makes minutes-long renders ~5×
        /// cheaper; the column's apex moves by metres (docs/ARCHITECTURE.md §3.4).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100))]
        plume_substeps: Option<u32>,
        /// HDR with bloom on the camera (`GlowCamera`), so hot lava glows past its edges;
        /// `--bloom false` renders LDR like the interactive scenes.
        #[arg(long, default_value_t = true, action = clap::ArgAction::Set)]
        bloom: bool,
        /// Layers left out of the frame (comma-separated), to see what each one draws, e.g.
        /// `--hide ash-fall` to tell the ash curtain from the clouds behind it.
        #[arg(long, value_enum, value_delimiter = ',')]
        hide: Vec<Hide>,
    },
    /// Run a scene's whole simulation headless (no rendering), one base tick per update, and
    /// write DIR/bench.json: main-thread ms per base tick (p50, p99, max), weather ticks beside
    /// the others, and each domain's mean ms per tick.
    Bench {
        /// Scene name from the registry.
        #[arg(long, default_value = "eruption")]
        scene: String,
        /// Base ticks timed.
        #[arg(long, default_value_t = 3000)]
        ticks: u64,
        /// Simulated seconds timed instead of `--ticks` (50 ticks each).
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..=20_000))]
        seconds: Option<u64>,
        /// Base ticks run first and not timed (e.g. until the umbrella has formed).
        #[arg(long, default_value_t = 0)]
        warmup_ticks: u64,
        /// Quality level (`VolcanoQuality`); without it the crates' defaults (= high).
        #[arg(long, value_enum)]
        quality: Option<Quality>,
        /// Soak report: every S simulated seconds, a row of entity count, resident memory and
        /// tick p50/p99/max in DIR/soak.csv (and bench.json).
        #[arg(long, value_name = "S", value_parser = clap::value_parser!(u64).range(1..=3600))]
        report_every: Option<u64>,
        /// Pace the timed ticks at 50 Hz of wall time, as a game runs them, instead of back to
        /// back (the weather step then has a wall second to finish, as in a game).
        #[arg(long)]
        realtime: bool,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// List the scenes of the registry.
    Scenes,
    /// Follow one plume slice from the vent (thesis §3.7.2): writes DIR/summary.json and
    /// DIR/trajectory.csv (z up above the vent, x downwind, metres).
    ///
    /// With `--export DIR --frames N` instead: run the eruption and write one binary PLY per
    /// frame (x, y, z, radius, density of every sphere, all scales; y up) for offline renderers.
    Plume {
        #[command(flatten)]
        params: plume::PlumeArgs,
        /// Output directory of the single-slice run.
        #[arg(long, required_unless_present = "export")]
        out: Option<PathBuf>,
        /// Solve for the mass eruption rate whose column tops out this high above the vent
        /// (km; inverse control, bisection on the single-slice model); written to summary.json.
        #[arg(long, conflicts_with = "mer")]
        target_height_km: Option<f64>,
        /// Export PLY frames to this directory instead.
        #[arg(long)]
        export: Option<PathBuf>,
        /// Number of PLY frames.
        #[arg(long, default_value_t = 1)]
        frames: u32,
        /// Simulated seconds between frames.
        #[arg(long, default_value_t = 0.04)]
        frame_seconds: f64,
        /// Simulated seconds before the first frame.
        #[arg(long, default_value_t = 0.0)]
        start_seconds: f64,
    },
    /// Fig 3.5 A/B/C as PNG: density vs altitude, altitude vs vertical speed for v0 =
    /// 150/175/200/250 m/s, trajectories for winds of 15/45/105 m/s at 12 km.
    PlumePlots {
        #[command(flatten)]
        params: plume::PlumeArgs,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Ejection speed below which the column collapses (bisection on v0), as JSON.
    PlumeThreshold {
        #[command(flatten)]
        params: plume::PlumeArgs,
    },
    /// Pahoehoe lava scenario (thesis ch. 5, Fig 5.10 terrains, incline, spread): writes
    /// DIR/summary.json and PNG maps (thickness, crust, velocity, folds).
    Lava(domains::LavaArgs),
    /// Layered atmosphere scenario (thesis §4.2): writes DIR/summary.json and a PNG map of
    /// every field of every layer.
    Atmosphere(domains::AtmosphereArgs),
    /// The coupled volcano (thesis §4.3): a Plinian column from the `eruption` scene's volcano
    /// under a layered atmosphere; writes DIR/summary.json (apex, ash books and bearings, cloud
    /// cover near and far, vent-layer warming) and PNG maps of ash, temperature and condensed
    /// water at the layer the plume reaches.
    Eruption {
        /// Which atmosphere.
        #[arg(long, value_enum)]
        scenario: eruption::EruptionScenario,
        /// Simulated seconds.
        #[arg(long, default_value_t = 600.0, allow_negative_numbers = true)]
        seconds: f64,
        /// Atmosphere cells per side (power of two) over the 25.6 km domain.
        #[arg(long, default_value_t = 64)]
        grid: usize,
        /// Column preset (the `eruption` scene's is `plinian_showcase`).
        #[arg(long, value_enum, default_value_t = plume::PresetArg::PlinianShowcase)]
        preset: plume::PresetArg,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Run a built-in scene headless and write frames for an offline renderer
    /// (docs/EXPORT.md): OpenVDB volumes (`ash`, `temperature`, `cloud`, `ash_fall`,
    /// `air_temperature`; world metres, y up), glTF meshes of the lava and the terrain, and a
    /// JSON of time, camera and sun per frame.
    Export {
        /// Built-in scene (`volcano scenes` lists them).
        #[arg(long, default_value = "eruption")]
        scene: String,
        /// Base ticks (50 Hz) run before the first frame.
        #[arg(long)]
        ticks: u64,
        /// Frames to write.
        #[arg(long, default_value_t = 1)]
        frames: u32,
        /// Base ticks between frames.
        #[arg(long, default_value_t = 50)]
        every: u64,
        /// Voxel edge of `ash` and `temperature` (m).
        #[arg(long, default_value_t = 50.0, allow_negative_numbers = true)]
        ash_voxel: f64,
        /// Voxel edge of `cloud`, `ash_fall` and `air_temperature` (m).
        #[arg(long, default_value_t = 250.0, allow_negative_numbers = true)]
        air_voxel: f64,
        /// Most active voxels in one grid.
        #[arg(long, default_value_t = 60_000_000)]
        max_voxels: u64,
        /// Splat only the s1 and umbrella spheres, not their s2/s3 detail.
        #[arg(long)]
        no_detail: bool,
        /// Quality level.
        #[arg(long, value_enum)]
        quality: Option<Quality>,
        /// Also write `frame_NNNN.expect.json` for `tools/check_vdb.py`.
        #[arg(long)]
        expect: bool,
        /// Camera written with the frames instead of the scene's:
        /// `FX,FY,FZ,YAW,PITCH,DISTANCE` (focus in world metres, angles in degrees).
        #[arg(long, value_parser = parse_camera, allow_hyphen_values = true)]
        camera: Option<CameraSpec>,
        /// Sun instead of the scene's: `AZIMUTH,ELEVATION` in degrees (the scene's illuminance).
        #[arg(long, value_parser = parse_sun, allow_hyphen_values = true)]
        sun: Option<(f32, f32)>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Run a collapsing eruption on the `pyroclastic_flow` scene's terrain (thesis §3.6):
    /// writes DIR/summary.json (particles, runout, secondary columns, mass budget) and
    /// DIR/deposit.png (top view: terrain, deposit, particle tracks).
    Pyroclastic {
        #[command(flatten)]
        params: plume::PlumeArgs,
        /// Simulated seconds.
        #[arg(long, default_value_t = 120.0, allow_negative_numbers = true)]
        seconds: f64,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Scenes => {
            for name in volcano::scenes::names() {
                match volcano::scenes::by_name(name) {
                    Ok(s) => println!("{name}\t{}", s.description),
                    Err(e) => println!("{name}\t(invalid: {e})"),
                }
            }
            ExitCode::SUCCESS
        }
        Command::Plume { params, out, target_height_km, export, frames, frame_seconds, start_seconds } => {
            match (export, out) {
                (Some(dir), _) => {
                    with_params(&params, |p| ply::export(p, &dir, frames, frame_seconds, start_seconds))
                }
                (None, Some(out)) => plume::plume(&params, target_height_km, &out),
                (None, None) => ExitCode::from(2),
            }
        }
        Command::PlumeThreshold { params } => plume::threshold(&params),
        Command::PlumePlots { params, out } => with_params(&params, |p| plots::plume_plots(p, &out)),
        Command::Lava(args) => domains::lava(&args),
        Command::Atmosphere(args) => domains::atmosphere(&args),
        Command::Pyroclastic { params, seconds, out } => {
            with_params(&params, |p| pyroclastic::run(p, seconds, &out))
        }
        Command::Bench { scene, ticks, seconds, warmup_ticks, quality, report_every, realtime, out } => {
            let per_s = TICK_HZ as u64;
            let opts = bench::BenchOptions {
                scene,
                ticks: seconds.map_or(ticks, |s| s * per_s),
                warmup: warmup_ticks,
                quality: quality.map(Quality::level),
                report_every_ticks: report_every.map_or(0, |s| s * per_s),
                realtime,
            };
            bench::run(&opts, &out)
        }
        Command::Export {
            scene,
            ticks,
            frames,
            every,
            ash_voxel,
            air_voxel,
            max_voxels,
            no_detail,
            quality,
            expect,
            camera,
            sun,
            out,
        } => export::run(&export::ExportArgs {
            scene,
            ticks,
            frames,
            every,
            quality: quality.map(Quality::level),
            settings: volcano::export::ExportSettings {
                ash_voxel_m: ash_voxel,
                air_voxel_m: air_voxel,
                max_voxels,
                detail_spheres: !no_detail,
                ..Default::default()
            },
            expect,
            camera,
            sun,
            out,
        }),
        Command::Eruption { scenario, seconds, grid, preset, out } => {
            eruption::run(scenario, seconds, grid, preset.preset(), &out)
        }
        Command::Render {
            scene,
            ticks,
            out,
            width,
            height,
            min_stddev,
            plume_view,
            lava_view,
            camera,
            sun,
            plume_substeps,
            bloom,
            hide,
        } => {
            let lava = volcano::render::LavaRenderMode::from(lava_view);
            let views = Views { plume: plume_view.into(), lava, camera, sun, bloom, hide };
            render::render(&scene, ticks, out, (width, height), min_stddev, views, plume_substeps)
        }
    }
}

/// Runs `f` with the command line's plume parameters, or exits 2 with the error.
fn with_params(
    args: &plume::PlumeArgs,
    f: impl FnOnce(&volcano::plume::PlumeParams) -> ExitCode,
) -> ExitCode {
    match args.params() {
        Ok(p) => f(&p),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// `--quality` values.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
enum Quality {
    Low,
    Medium,
    High,
    Ultra,
}

impl Quality {
    fn level(self) -> VolcanoQuality {
        match self {
            Quality::Low => VolcanoQuality::Low,
            Quality::Medium => VolcanoQuality::Medium,
            Quality::High => VolcanoQuality::High,
            Quality::Ultra => VolcanoQuality::Ultra,
        }
    }
}

/// The CLI runs at the thesis' fixed rate (the plugins follow whatever rate a game sets).
pub(crate) const TICK_HZ: f64 = volcano::core::units::THESIS_TICK_HZ;

/// A headless simulation app (no rendering) advancing 5 base ticks (50 Hz) per update, for the
/// runs that only need numbers (`pyroclastic`, `eruption`).
pub(crate) fn sim_app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins))
        .insert_resource(Time::<Fixed>::from_hz(TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)));
    app
}
