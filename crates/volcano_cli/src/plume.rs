//! `volcano plume` and `volcano plume-threshold`: the single-slice validation experiment of
//! thesis §3.7.2. Output frame: z up above the vent, x downwind, metres.

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use volcano::core::atmosphere::AtmosphereModel;
use volcano::plume::model::run::{TrajectorySample, collapse_threshold, run_single_slice};
use volcano::plume::{PlumeParams, Preset, WindProfile};

/// Preset names on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum PresetArg {
    /// Thesis Table 3.1 as written (v0 = 150 m/s, contraction on, printed ISA law).
    Thesis,
    /// Table 3.1 at v0 = 200 m/s with a light wind: Plinian column (Fig 3.4).
    #[value(name = "plinian_showcase")]
    PlinianShowcase,
    /// Table 3.1 at v0 = 70 m/s: collapsing column (Fig 3.6).
    #[value(name = "pyroclastic_showcase")]
    PyroclasticShowcase,
}

/// Atmosphere names on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum AtmosphereArg {
    /// The thesis' printed ISA formula.
    Thesis,
    /// US Standard Atmosphere 1976.
    Ussa76,
}

/// on / off switch.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Switch {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

/// Parameters shared by `plume` and `plume-threshold`.
#[derive(Args, Debug)]
pub struct PlumeArgs {
    /// Parameter preset.
    #[arg(long, value_enum, default_value = "thesis")]
    preset: PresetArg,
    /// Ejection speed v0 (m/s).
    #[arg(long, allow_negative_numbers = true)]
    v0: Option<f64>,
    /// Vent radius r0 (m).
    #[arg(long, allow_negative_numbers = true)]
    r0: Option<f64>,
    /// Initial density rho0 (kg/m³).
    #[arg(long, allow_negative_numbers = true)]
    rho0: Option<f64>,
    /// Initial temperature T0 (K).
    #[arg(long, allow_negative_numbers = true)]
    t0: Option<f64>,
    /// Vent altitude above sea level (m).
    #[arg(long, allow_negative_numbers = true)]
    vent_altitude: Option<f64>,
    /// Wind speed at and above 12 km (m/s), linear from 0 at the vent (§3.7.2).
    #[arg(long, allow_negative_numbers = true)]
    wind_max: Option<f64>,
    /// Direction the wind blows toward, degrees counter-clockwise from +x.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    wind_direction: f64,
    /// Contraction on mixing (V' = V T'/T).
    #[arg(long, value_enum)]
    contraction: Option<Switch>,
    /// Ambient atmosphere.
    #[arg(long, value_enum)]
    atmosphere: Option<AtmosphereArg>,
}

impl PlumeArgs {
    /// The preset with the command-line overrides applied.
    pub fn params(&self) -> PlumeParams {
        let mut p = match self.preset {
            PresetArg::Thesis => Preset::Thesis.params(),
            PresetArg::PlinianShowcase => Preset::PlinianShowcase.params(),
            PresetArg::PyroclasticShowcase => Preset::PyroclasticShowcase.params(),
        };
        p.v0 = self.v0.unwrap_or(p.v0);
        p.r0 = self.r0.unwrap_or(p.r0);
        p.rho0 = self.rho0.unwrap_or(p.rho0);
        p.t0 = self.t0.unwrap_or(p.t0);
        p.vent_altitude = self.vent_altitude.unwrap_or(p.vent_altitude);
        if let Some(w) = self.wind_max {
            p.wind = WindProfile::Linear { max: w, top: 12_000.0, direction_deg: self.wind_direction };
        } else if let WindProfile::Linear { direction_deg, .. } = &mut p.wind {
            *direction_deg = self.wind_direction;
        }
        if let Some(c) = self.contraction {
            p.contraction = matches!(c, Switch::On);
        }
        if let Some(a) = self.atmosphere {
            p.atmosphere = match a {
                AtmosphereArg::Thesis => AtmosphereModel::Thesis,
                AtmosphereArg::Ussa76 => AtmosphereModel::UsStandard1976,
            };
        }
        p
    }
}

/// `volcano plume`: writes `summary.json` and `trajectory.csv` into `out`.
pub fn plume(args: &PlumeArgs, out: &Path) -> ExitCode {
    let p = args.params();
    let (summary, traj) = match run_single_slice(&p, 3_600.0, 0.1) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    // Output frame: x downwind (the wind's direction aloft), whatever the input direction.
    let w = p.wind.at(1.0e5);
    let downwind_deg = if w.length() > 0.0 { w.y.atan2(w.x).to_degrees() } else { 0.0 };
    if let Err(e) = write_outputs(out, &summary, &traj, downwind_deg) {
        eprintln!("error: cannot write to {}: {e}", out.display());
        return ExitCode::FAILURE;
    }
    println!("{}", serde_json::to_string(&summary).unwrap_or_default());
    ExitCode::SUCCESS
}

fn write_outputs(
    out: &Path,
    summary: &impl serde::Serialize,
    traj: &[TrajectorySample],
    wind_direction_deg: f64,
) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    std::fs::write(out.join("summary.json"), serde_json::to_string_pretty(summary)? + "\n")?;
    // Rotate the horizontal frame so x points downwind.
    let (s, c) = (-wind_direction_deg.to_radians()).sin_cos();
    let rot = |x: f64, y: f64| (c * x - s * y, s * x + c * y);
    let mut f = std::io::BufWriter::new(std::fs::File::create(out.join("trajectory.csv"))?);
    writeln!(f, "t,x,y,z,vx,vy,vz,r,rho,T,rho_air")?;
    for t in traj {
        let (x, y) = rot(t.x, t.y);
        let (vx, vy) = rot(t.vx, t.vy);
        writeln!(
            f,
            "{:.3},{x:.3},{y:.3},{:.3},{vx:.4},{vy:.4},{:.4},{:.4},{:.6},{:.3},{:.6}",
            t.t, t.z, t.vz, t.r, t.rho, t.temperature, t.rho_air
        )?;
    }
    f.flush()
}

/// `volcano plume-threshold`: the collapse threshold on v0 by bisection, as JSON.
pub fn threshold(args: &PlumeArgs) -> ExitCode {
    match collapse_threshold(&args.params(), 1.0, 1_000.0, 0.01) {
        Ok(t) => {
            println!("{}", serde_json::json!({ "threshold_m_s": t }));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
