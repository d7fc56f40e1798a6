//! Single-slice runs from the vent: the validation experiment of §3.7.2 and the CLI's
//! `summary.json` / `trajectory.csv`.

use bevy::math::DVec2;
use serde::Serialize;
use volcano_core::error::ConfigError;

use super::params::PlumeParams;
use super::slice::{Phase, Slice, SliceEnv};

/// Outcome of a single slice followed from the vent until it collapses or reaches its apex.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SingleSliceSummary {
    /// "plume" (reached an apex after being buoyant) or "collapse".
    pub regime: &'static str,
    /// Highest altitude above the vent (m).
    pub apex_m: f64,
    /// First altitude where the slice is lighter than the air.
    pub buoyant_from_m: Option<f64>,
    /// Where it becomes as dense as the air again (top of the buoyant rise).
    pub neutral_buoyancy_m: Option<f64>,
    /// Apex of a collapsing slice.
    pub collapse_altitude_m: Option<f64>,
    /// Largest horizontal distance from the vent along the wind (m).
    pub max_downwind_m: f64,
    /// Time from the vent to the end of the run (s).
    pub duration_s: f64,
    /// Mass budget `(initial + entrained − sedimented − mass) / (initial + entrained)`, ≈ 0.
    pub mass_budget_rel_error: f64,
}

/// One trajectory sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TrajectorySample {
    /// Time since emission (s).
    pub t: f64,
    /// Position (m), z above the vent.
    pub x: f64,
    /// Position (m).
    pub y: f64,
    /// Altitude above the vent (m).
    pub z: f64,
    /// Velocity (m/s).
    pub vx: f64,
    /// Velocity (m/s).
    pub vy: f64,
    /// Velocity (m/s).
    pub vz: f64,
    /// Size (m).
    pub r: f64,
    /// Density (kg/m³).
    pub rho: f64,
    /// Temperature (K).
    pub temperature: f64,
    /// Air density at the slice (kg/m³).
    pub rho_air: f64,
}

/// Follows one slice from the vent for at most `max_seconds`, sampling the trajectory every
/// `sample_every` seconds (0 for none).
pub fn run_single_slice(
    p: &PlumeParams,
    max_seconds: f64,
    sample_every: f64,
) -> Result<(SingleSliceSummary, Vec<TrajectorySample>), ConfigError> {
    let air = p.air();
    let wind = |z: f64| p.wind.at(z);
    run_single_slice_in(
        p,
        &SliceEnv { air: &air, vent_altitude: p.vent_altitude, wind: &wind },
        max_seconds,
        sample_every,
    )
}

/// [`run_single_slice`] in a given air and wind (e.g. a coupled column's
/// [`crate::LayeredAmbient`]) instead of the parameters' own.
pub fn run_single_slice_in(
    p: &PlumeParams,
    env: &SliceEnv,
    max_seconds: f64,
    sample_every: f64,
) -> Result<(SingleSliceSummary, Vec<TrajectorySample>), ConfigError> {
    p.validate()?;
    let air = env.air;
    let mut s = Slice::at_vent(p);
    let wind_dir = {
        let w = (env.wind)(1.0e5);
        if w.length() > 0.0 { w.normalize() } else { DVec2::X }
    };
    let mut samples = Vec::new();
    let mut next_sample = 0.0;
    let mut max_downwind: f64 = 0.0;
    let steps = (max_seconds / p.dt).ceil() as u64;
    let sample = |s: &Slice| TrajectorySample {
        t: s.age,
        x: s.position.x,
        y: s.position.y,
        z: s.position.z,
        vx: s.velocity.x,
        vy: s.velocity.y,
        vz: s.velocity.z,
        r: s.r,
        rho: s.density,
        temperature: s.temperature,
        rho_air: air.density(env.vent_altitude + s.position.z),
    };
    for _ in 0..steps {
        if sample_every > 0.0 && s.age + 1e-9 >= next_sample {
            samples.push(sample(&s));
            next_sample += sample_every;
        }
        s.step(p, env, p.dt);
        max_downwind = max_downwind.max(s.position.truncate().dot(wind_dir));
        if matches!(s.phase, Phase::Umbrella | Phase::Collapsed) {
            break;
        }
    }
    if sample_every > 0.0 {
        samples.push(sample(&s));
    }
    let collapsed = s.phase == Phase::Collapsed;
    let summary = SingleSliceSummary {
        regime: if collapsed { "collapse" } else { "plume" },
        apex_m: s.apex,
        buoyant_from_m: s.buoyant_from,
        neutral_buoyancy_m: s.neutral_altitude,
        collapse_altitude_m: collapsed.then_some(s.apex),
        max_downwind_m: max_downwind,
        duration_s: s.age,
        mass_budget_rel_error: (s.initial_mass + s.entrained_mass - s.sedimented_mass - s.mass)
            / (s.initial_mass + s.entrained_mass),
    };
    Ok((summary, samples))
}

/// Smallest ejection speed (m/s) for which a single slice rises as a plume instead of
/// collapsing, by bisection on `v0` in `[lo, hi]` to within `tol`. `None` if the regime does
/// not change over the interval (always plume or always collapse).
pub fn collapse_threshold(p: &PlumeParams, lo: f64, hi: f64, tol: f64) -> Result<Option<f64>, ConfigError> {
    let rises = |v0: f64| -> Result<bool, ConfigError> {
        let q = PlumeParams { v0, ..p.clone() };
        Ok(run_single_slice(&q, 3_600.0, 0.0)?.0.regime == "plume")
    };
    let (mut a, mut b) = (lo, hi);
    if rises(a)? || !rises(b)? {
        return Ok(None);
    }
    while b - a > tol.max(1e-6) {
        let m = 0.5 * (a + b);
        if rises(m)? { b = m } else { a = m }
    }
    Ok(Some(0.5 * (a + b)))
}
