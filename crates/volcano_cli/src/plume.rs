//! `volcano plume` and `volcano plume-threshold`: the single-slice validation experiment of
//! thesis §3.7.2. Output frame: z up above the vent, x downwind, metres.

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;

use clap::{Args, ValueEnum};
use volcano::core::atmosphere::AtmosphereModel;
use volcano::plume::model::inverse::mer_for_height;
use volcano::plume::model::run::{
    SingleSliceSummary, TrajectorySample, collapse_threshold, run_single_slice,
};
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
    /// The physical column: vent density from the gas fraction, expansion with pressure,
    /// Woods (1988) entrainment; calibrated against Mastin (2009) and Costa (2016).
    Physical,
}

impl PresetArg {
    /// The model's preset of this name.
    pub fn preset(self) -> Preset {
        match self {
            Self::Thesis => Preset::Thesis,
            Self::PlinianShowcase => Preset::PlinianShowcase,
            Self::PyroclasticShowcase => Preset::PyroclasticShowcase,
            Self::Physical => Preset::Physical,
        }
    }
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
    /// Mass eruption rate (kg/s): sizes the vent radius from MER = ρ0 π r0² v0 (with --v0 if
    /// given, else the rule v0 = 40 (MER/1e4)^0.18 m/s, which keeps the column buoyant).
    #[arg(long, allow_negative_numbers = true, conflicts_with = "r0")]
    mer: Option<f64>,
    /// Magmatic gas (water) mass fraction n; sets the vent density of the physical preset.
    #[arg(long, allow_negative_numbers = true)]
    gas_fraction: Option<f64>,
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
    /// The preset with the command-line overrides applied, validated.
    pub fn params(&self) -> Result<PlumeParams, volcano::core::error::ConfigError> {
        let mut p = self.preset.preset().params();
        p.gas_fraction = self.gas_fraction.unwrap_or(p.gas_fraction);
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
        p.validate()?;
        match self.mer {
            Some(mer) => p.with_mer(mer, self.v0),
            None => Ok(p),
        }
    }
}

/// `summary.json` of `volcano plume`: the single-slice summary and the vent.
#[derive(Debug, serde::Serialize)]
struct PlumeSummary {
    #[serde(flatten)]
    run: SingleSliceSummary,
    /// Mass delivered per second by the emitted slices (the thesis preset's is twice the vent
    /// flux ρ0 π r0² v0; the physical preset's is the vent flux).
    mer_kg_s: f64,
    /// Vent density of the mixture (kg/m³).
    vent_density_kg_m3: f64,
    /// Vent radius (m).
    vent_radius_m: f64,
    /// Exit speed (m/s).
    exit_speed_m_s: f64,
    /// Requested top (km above the vent) when the rate was solved for it.
    #[serde(skip_serializing_if = "Option::is_none")]
    target_height_km: Option<f64>,
}

/// `volcano plume`: writes `summary.json` and `trajectory.csv` into `out`; with a target height
/// the mass eruption rate is solved for first (inverse control).
pub fn plume(args: &PlumeArgs, target_height_km: Option<f64>, out: &Path) -> ExitCode {
    let solved = args.params().and_then(|p| match target_height_km {
        Some(km) => mer_for_height(&p, km * 1_000.0).map(|s| s.params),
        None => Ok(p),
    });
    let p = match solved {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let (run, traj) = match run_single_slice(&p, 7_200.0, 0.1) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    // Output frame: x downwind (the wind's direction aloft), whatever the input direction.
    let w = p.wind.at(1.0e5);
    let downwind_deg = if w.length() > 0.0 { w.y.atan2(w.x).to_degrees() } else { 0.0 };
    let summary = PlumeSummary {
        run,
        mer_kg_s: p.mass_eruption_rate(),
        vent_density_kg_m3: p.vent_density(),
        vent_radius_m: p.r0,
        exit_speed_m_s: p.v0,
        target_height_km,
    };
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
    match args.params().and_then(|p| collapse_threshold(&p, 1.0, 1_000.0, 0.01)) {
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
