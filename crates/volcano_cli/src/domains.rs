//! `volcano lava` and `volcano atmosphere`: thin wrappers over the domain crates' scenario
//! runners (`volcano_lava::scenario`, `volcano_atmosphere::model::run`), writing
//! `DIR/summary.json` and the PNG maps.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use volcano_atmosphere::view::{MapField, field_values, png_bytes};
use volcano_lava::scenario::{LavaScenario, ScenarioConfig, ScenarioKind};

/// Options of `volcano lava`.
#[derive(clap::Args, Debug)]
pub struct LavaArgs {
    /// obstacle | split | canyon | slope | incline | spread | effusive (a vent's flow over a
    /// 10 km valley, run until it stops or `--seconds`).
    #[arg(long, default_value = "obstacle")]
    scenario: String,
    /// Simulated seconds (default per scenario).
    #[arg(long, allow_negative_numbers = true)]
    seconds: Option<f64>,
    /// Constant viscosity (Pa·s) instead of the VFT law.
    #[arg(long, allow_negative_numbers = true)]
    viscosity: Option<f64>,
    /// Constant viscosity and no cooling.
    #[arg(long)]
    isothermal: bool,
    /// `spread`: released volume (m³).
    #[arg(long, allow_negative_numbers = true)]
    volume: Option<f64>,
    /// `spread`: radius of the released cylinder (m).
    #[arg(long, allow_negative_numbers = true)]
    initial_radius: Option<f64>,
    /// Source rate: m³/s (point source), m³/s per metre of width for `incline`.
    #[arg(long, allow_negative_numbers = true)]
    rate: Option<f64>,
    /// Slope (degrees; `incline` ≤ 10).
    #[arg(long, allow_negative_numbers = true)]
    slope_deg: Option<f64>,
    /// Cells per side.
    #[arg(long)]
    grid: Option<usize>,
    /// Cell size (m); `effusive`: the terrain's node spacing.
    #[arg(long, allow_negative_numbers = true)]
    cell: Option<f64>,
    /// `effusive`: lava cells per terrain node side (default 4: 5 m cells on 20 m nodes).
    #[arg(long)]
    refine: Option<u32>,
    /// `effusive`: the ground reaches sea level this far (m) downslope of the vent.
    #[arg(long, allow_negative_numbers = true)]
    sea_at: Option<f64>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

fn write_summary(dir: &Path, json: &str) -> ExitCode {
    if let Err(e) = std::fs::create_dir_all(dir).and_then(|_| std::fs::write(dir.join("summary.json"), json))
    {
        eprintln!("error: cannot write {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    println!("{json}");
    ExitCode::SUCCESS
}

/// Runs a lava scenario.
pub fn lava(a: &LavaArgs) -> ExitCode {
    if a.scenario == "effusive" {
        return effusive(a);
    }
    let kind: ScenarioKind = match a.scenario.parse() {
        Ok(k) => k,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let mut c = ScenarioConfig::new(kind);
    c.seconds = a.seconds.unwrap_or(c.seconds);
    c.viscosity = a.viscosity.or(c.viscosity);
    c.isothermal = a.isothermal;
    c.volume = a.volume.unwrap_or(c.volume);
    c.initial_radius = a.initial_radius.unwrap_or(c.initial_radius);
    c.rate = a.rate.unwrap_or(c.rate);
    c.slope_deg = a.slope_deg.unwrap_or(c.slope_deg);
    c.grid = a.grid.unwrap_or(c.grid);
    c.cell = a.cell.unwrap_or(c.cell);
    let mut s = match LavaScenario::build(&c) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    s.run_until(c.seconds);
    let json = serde_json::to_string_pretty(&s.summary()).unwrap_or_default();
    if let Err(e) = volcano_lava::view::write_maps(&s.field, &s.surface, &s.folds, &a.out) {
        eprintln!("error: {e}");
        return ExitCode::FAILURE;
    }
    write_summary(&a.out, &json)
}

/// Runs the effusive scenario (`volcano_lava::scenario::effusive`): only its summary.
fn effusive(a: &LavaArgs) -> ExitCode {
    use volcano_lava::scenario::effusive::{EffusiveConfig, run_effusive};
    let unused = [
        ("--viscosity", a.viscosity.is_some()),
        ("--isothermal", a.isothermal),
        ("--volume", a.volume.is_some()),
        ("--initial-radius", a.initial_radius.is_some()),
        ("--grid", a.grid.is_some()),
    ];
    if let Some((flag, _)) = unused.iter().find(|(_, set)| *set) {
        eprintln!("error: {flag} is not an option of the effusive scenario");
        return ExitCode::from(2);
    }
    let d = EffusiveConfig::default();
    let c = EffusiveConfig {
        rate: a.rate.unwrap_or(d.rate),
        seconds: a.seconds.unwrap_or(d.seconds),
        slope_deg: a.slope_deg.unwrap_or(d.slope_deg),
        node: a.cell.unwrap_or(d.node),
        refine: a.refine.unwrap_or(d.refine),
        sea_at_m: a.sea_at,
        ..d
    };
    let tty = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let summary = run_effusive(&c, |t| {
        if tty {
            eprint!("\r{:.0} / {:.0} s simulated", t, c.seconds);
        }
    });
    if tty {
        eprintln!();
    }
    match summary {
        Ok(s) => write_summary(&a.out, &serde_json::to_string_pretty(&s).unwrap_or_default()),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}

/// Options of `volcano atmosphere`.
#[derive(clap::Args, Debug)]
pub struct AtmosphereArgs {
    /// convection | island | sea-breeze | orographic | mixed.
    #[arg(long, default_value = "convection")]
    scenario: String,
    /// Steps (default per scenario).
    #[arg(long)]
    steps: Option<u32>,
    /// Step (s).
    #[arg(long, allow_negative_numbers = true)]
    dt: Option<f64>,
    /// Cells per side (a power of two).
    #[arg(long)]
    grid: Option<usize>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
}

/// Runs an atmosphere scenario; maps of every field of every layer as `layerK_FIELD.png`.
pub fn atmosphere(a: &AtmosphereArgs) -> ExitCode {
    let scenario = match volcano_atmosphere::WeatherScenario::builtin(&a.scenario) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let run = match volcano_atmosphere::model::run::run(&scenario, a.steps, a.dt, a.grid) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Err(e) = std::fs::create_dir_all(&a.out) {
        eprintln!("error: cannot create {}: {e}", a.out.display());
        return ExitCode::FAILURE;
    }
    let n = run.state.grid.n;
    for (k, layer) in run.state.layers.iter().enumerate() {
        for field in MapField::ALL {
            let name = format!("layer{k}_{field:?}.png").to_lowercase();
            match png_bytes(&field_values(layer, field), n) {
                Ok((bytes, _)) => {
                    if let Err(e) = std::fs::write(a.out.join(&name), bytes) {
                        eprintln!("error: cannot write {name}: {e}");
                        return ExitCode::FAILURE;
                    }
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::FAILURE;
                }
            }
        }
    }
    write_summary(&a.out, &serde_json::to_string_pretty(&run.summary).unwrap_or_default())
}
