//! Inverse control: the mass eruption rate that gives a requested column height, by bisection
//! on the single-slice model (which predicts the column's top, `model::column`).

use serde::Serialize;
use volcano_core::error::{ConfigError, in_range};

use super::params::PlumeParams;
use super::run::run_single_slice_in;
use super::slice::SliceEnv;

/// Range of mass eruption rates searched (kg/s).
pub const MER_RANGE: (f64, f64) = (1e2, 1e10);

/// Relative height tolerance of the bisection (the forward run lands within it).
pub const HEIGHT_TOLERANCE: f64 = 0.01;

/// A solved eruption rate.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MerSolution {
    /// Mass eruption rate (kg/s).
    pub mer_kg_s: f64,
    /// Top of the column of the solved parameters (m above the vent).
    pub top_m: f64,
    /// Parameters with the vent sized for the rate ([`PlumeParams::with_mer`]).
    #[serde(skip)]
    pub params: PlumeParams,
    /// Single-slice runs made.
    pub runs: u32,
}

/// Top of the column (m) for a rate, `None` if it collapses.
fn top(base: &PlumeParams, mer: f64, env: &SliceEnv) -> Result<Option<(f64, PlumeParams)>, ConfigError> {
    let p = base.with_mer(mer, None)?;
    let (s, _) = run_single_slice_in(&p, env, 7_200.0, 0.0)?;
    Ok((s.regime == "plume").then_some((s.apex_m, p)))
}

/// The mass eruption rate in [`MER_RANGE`] whose column (the vent sized by
/// [`PlumeParams::with_mer`] with its default exit speed) tops out at `target_m` above the vent
/// under `base`'s atmosphere and wind, to within [`HEIGHT_TOLERANCE`]. Bisection on log MER;
/// the height grows with the rate. Errors (never panics) when the target is out of reach: below
/// the lowest rate's top, above the highest's, or where the column collapses.
pub fn mer_for_height(base: &PlumeParams, target_m: f64) -> Result<MerSolution, ConfigError> {
    let air = base.air();
    let wind = |z: f64| base.wind.at(z);
    mer_for_height_in(base, target_m, &SliceEnv { air: &air, vent_altitude: base.vent_altitude, wind: &wind })
}

/// [`mer_for_height`] in a given air and wind (e.g. a coupled column's
/// [`crate::LayeredAmbient`] around the vent) instead of the parameters' own.
pub fn mer_for_height_in(
    base: &PlumeParams,
    target_m: f64,
    env: &SliceEnv,
) -> Result<MerSolution, ConfigError> {
    in_range("target height (m)", target_m, 1.0, 100_000.0)?;
    base.validate()?;
    let unreachable =
        |reason: String| ConfigError::InvalidParameter { name: "target height (m)", value: target_m, reason };
    let (mut lo, mut hi) = (MER_RANGE.0.ln(), MER_RANGE.1.ln());
    let mut runs = 2;
    let bottom = top(base, lo.exp(), env)?;
    let Some((h_hi, p_hi)) = top(base, hi.exp(), env)? else {
        return Err(unreachable(format!("the column of {:.0e} kg/s collapses", MER_RANGE.1)));
    };
    if target_m > h_hi {
        return Err(unreachable(format!("above the {h_hi:.0} m top of {:.0e} kg/s", MER_RANGE.1)));
    }
    if let Some((h_lo, _)) = bottom
        && target_m < h_lo
    {
        return Err(unreachable(format!("below the {h_lo:.0} m top of {:.0e} kg/s", MER_RANGE.0)));
    }
    let mut best = (h_hi, p_hi, hi.exp());
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        runs += 1;
        match top(base, mid.exp(), env)? {
            // A collapsing column is too weak: more mass.
            None => lo = mid,
            Some((h, p)) => {
                if (h - target_m).abs() < (best.0 - target_m).abs() {
                    best = (h, p, mid.exp());
                }
                if (h - target_m).abs() <= HEIGHT_TOLERANCE * target_m {
                    break;
                }
                if h < target_m { lo = mid } else { hi = mid }
            }
        }
    }
    if (best.0 - target_m).abs() > HEIGHT_TOLERANCE * target_m {
        return Err(unreachable(format!("closest top {:.0} m (the height is not monotonic there)", best.0)));
    }
    Ok(MerSolution { mer_kg_s: best.2, top_m: best.0, params: best.1, runs })
}
