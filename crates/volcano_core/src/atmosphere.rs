//! Vertical atmosphere profiles: temperature, pressure and density by geometric altitude.
//!
//! Two profiles share the [`AtmosphereProfile`] trait:
//! - [`ThesisIsa`]: the formula printed under Table 3.1 of the thesis (a troposphere law
//!   extended upward, no stratosphere). It is undefined above ≈43.5 km, so it is evaluated
//!   only inside [`ThesisIsa::VALID_RANGE`] and clamped outside (never NaN).
//! - [`UsStandard1976`]: the US Standard Atmosphere 1976, seven geopotential layers from
//!   0 to 84.852 km' (86 km geometric), isothermal extrapolation above and the tropospheric
//!   lapse rate extended down to −5 km.

use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};

use crate::units::{EARTH_RADIUS, G0, M_AIR, P_SEA, R_AIR, R_STAR, T_SEA};

/// Air state at one altitude.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
pub struct AirState {
    /// Temperature (K).
    pub temperature: f64,
    /// Pressure (Pa).
    pub pressure: f64,
    /// Density (kg/m³).
    pub density: f64,
}

/// A vertical profile of the ambient air. Implementations must return finite, positive values
/// at every finite altitude (clamping where their law is undefined).
pub trait AtmosphereProfile: Send + Sync {
    /// Air state at geometric altitude `z` metres above sea level.
    fn sample(&self, z: f64) -> AirState;
    /// Temperature (K) at `z`.
    fn temperature(&self, z: f64) -> f64 {
        self.sample(z).temperature
    }
    /// Density (kg/m³) at `z`.
    fn density(&self, z: f64) -> f64 {
        self.sample(z).density
    }
    /// Pressure (Pa) at `z`.
    fn pressure(&self, z: f64) -> f64 {
        self.sample(z).pressure
    }
    /// Absolute humidity (water vapour, g/m³) at `z`. The standard profiles are dry; a profile
    /// sampled from a simulated atmosphere (the coupled volcano) overrides this.
    fn humidity(&self, _z: f64) -> f64 {
        0.0
    }
}

/// Which profile a preset selects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect, Serialize, Deserialize)]
pub enum AtmosphereModel {
    /// The thesis' printed formula (Table 3.1).
    Thesis,
    /// US Standard Atmosphere 1976.
    #[default]
    UsStandard1976,
}

impl AtmosphereModel {
    /// The profile object for this choice.
    pub fn profile(self) -> &'static dyn AtmosphereProfile {
        match self {
            AtmosphereModel::Thesis => &ThesisIsa,
            AtmosphereModel::UsStandard1976 => &UsStandard1976,
        }
    }
}

/// The thesis' "International Standard Atmosphere model" printed under Table 3.1:
/// `ρ_a(z) = 353 (1 − 2.3·10⁻⁵ z)^5.3 / (288 − 6.5·10⁻³ z)`, `T_a(z) = 288 − 6.5·10⁻³ z`,
/// with `z` in metres. The constant 353 is `p_sea / R_air`, so the pressure consistent with
/// it is `p = ρ R_air T`.
///
/// The law has no stratosphere and `(1 − 2.3·10⁻⁵ z)` reaches 0 at 43.48 km, so the profile
/// clamps `z` to [`ThesisIsa::VALID_RANGE`] (−5 km to 40 km) and never returns NaN.
#[derive(Debug, Clone, Copy, Default, PartialEq, Reflect)]
pub struct ThesisIsa;

impl ThesisIsa {
    /// Altitudes (m) where the printed law is evaluated; outside, the nearest bound is used.
    pub const VALID_RANGE: (f64, f64) = (-5_000.0, 40_000.0);
}

impl AtmosphereProfile for ThesisIsa {
    fn sample(&self, z: f64) -> AirState {
        // NaN altitude: treat as sea level rather than propagate.
        let z = if z.is_nan() { 0.0 } else { z.clamp(Self::VALID_RANGE.0, Self::VALID_RANGE.1) };
        let temperature = 288.0 - 6.5e-3 * z;
        let density = 353.0 * (1.0 - 2.3e-5 * z).powf(5.3) / temperature;
        AirState { temperature, pressure: density * R_AIR * temperature, density }
    }
}

/// US Standard Atmosphere 1976 (NOAA/NASA/USAF, 1976), lower 86 km.
///
/// The standard is defined by geopotential altitude `H = r₀ z / (r₀ + z)` (r₀ = 6 356 766 m)
/// with linear temperature segments; pressure follows the hydrostatic law in each segment:
/// `p = p_b (T_b / T)^(g₀ M / (R* L))` for lapse rate `L ≠ 0`, and
/// `p = p_b exp(−g₀ M (H − H_b) / (R* T_b))` for isothermal segments. Density is `p M / (R* T)`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Reflect)]
pub struct UsStandard1976;

/// Geopotential layer bases (m') and lapse rates (K/m') of the 1976 standard.
const LAYERS: [(f64, f64); 7] = [
    (0.0, -6.5e-3),
    (11_000.0, 0.0),
    (20_000.0, 1.0e-3),
    (32_000.0, 2.8e-3),
    (47_000.0, 0.0),
    (51_000.0, -2.8e-3),
    (71_000.0, -2.0e-3),
];
/// Top of the standard's lower atmosphere (geopotential m'), 86 km geometric.
const H_TOP: f64 = 84_852.0;
/// Lowest geopotential altitude evaluated (m').
const H_BOTTOM: f64 = -5_000.0;

impl UsStandard1976 {
    /// Geopotential altitude (m') from geometric altitude (m).
    pub fn geopotential(z: f64) -> f64 {
        EARTH_RADIUS * z / (EARTH_RADIUS + z)
    }

    /// Geometric altitude (m) from geopotential altitude (m').
    pub fn geometric(h: f64) -> f64 {
        EARTH_RADIUS * h / (EARTH_RADIUS - h)
    }

    /// Air state at geopotential altitude `h` (m'), the standard's own table coordinate.
    pub fn sample_geopotential(h: f64) -> AirState {
        let h = if h.is_nan() { 0.0 } else { h.max(H_BOTTOM) };
        let gmr = G0 * M_AIR / R_STAR; // K/m'
        let mut t_b = T_SEA;
        let mut p_b = P_SEA;
        // Walk up the layers, integrating the base pressure of each one.
        for (i, &(h_b, lapse)) in LAYERS.iter().enumerate() {
            let h_next = LAYERS.get(i + 1).map_or(H_TOP, |l| l.0);
            let is_last = i + 1 == LAYERS.len();
            if h <= h_next || is_last {
                let dh = h.min(H_TOP) - h_b;
                let (t, p) = layer_state(t_b, p_b, lapse, dh, gmr);
                let (t, p) = if h > H_TOP {
                    // Isothermal extrapolation above 86 km geometric.
                    (t, p * (-gmr * (h - H_TOP) / t).exp())
                } else {
                    (t, p)
                };
                return AirState { temperature: t, pressure: p, density: p / (R_AIR * t) };
            }
            let (t, p) = layer_state(t_b, p_b, lapse, h_next - h_b, gmr);
            t_b = t;
            p_b = p;
        }
        unreachable!("the last layer always returns")
    }
}

/// Temperature and pressure at `dh` above a layer base with lapse rate `lapse`.
fn layer_state(t_b: f64, p_b: f64, lapse: f64, dh: f64, gmr: f64) -> (f64, f64) {
    if lapse == 0.0 {
        (t_b, p_b * (-gmr * dh / t_b).exp())
    } else {
        let t = t_b + lapse * dh;
        (t, p_b * (t_b / t).powf(gmr / lapse))
    }
}

impl AtmosphereProfile for UsStandard1976 {
    fn sample(&self, z: f64) -> AirState {
        // Very large altitudes would make the geopotential conversion singular; the
        // isothermal extrapolation makes everything above ~1000 km negligible anyway.
        let z = if z.is_nan() { 0.0 } else { z.clamp(-5_000.0, 1_000_000.0) };
        Self::sample_geopotential(Self::geopotential(z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    /// Tabulated values of the 1976 standard at geopotential layer bases
    /// (H m', T K, p Pa, ρ kg/m³).
    const TABLE: [(f64, f64, f64, f64); 7] = [
        (0.0, 288.15, 101_325.0, 1.2250),
        (11_000.0, 216.65, 22_632.1, 0.363_92),
        (20_000.0, 216.65, 5_474.89, 0.088_035),
        (32_000.0, 228.65, 868.019, 0.013_225),
        (47_000.0, 270.65, 110.906, 0.001_427_5),
        (51_000.0, 270.65, 66.9389, 0.000_861_60),
        (71_000.0, 214.65, 3.956_42, 0.000_064_211),
    ];

    #[test]
    fn us_standard_matches_table_within_0_1_percent() {
        for &(h, t, p, rho) in &TABLE {
            // Test through the public geometric interface, converting the table's H.
            let s = UsStandard1976.sample(UsStandard1976::geometric(h));
            assert!(rel(s.temperature, t) < 1e-3, "T at H={h}: {} vs {t}", s.temperature);
            assert!(rel(s.pressure, p) < 1e-3, "p at H={h}: {} vs {p}", s.pressure);
            assert!(rel(s.density, rho) < 1e-3, "rho at H={h}: {} vs {rho}", s.density);
        }
    }

    #[test]
    fn geometric_and_geopotential_are_inverse() {
        for z in [0.0, 11_019.1, 50_000.0, 86_000.0] {
            let h = UsStandard1976::geopotential(z);
            assert!((UsStandard1976::geometric(h) - z).abs() < 1e-6);
        }
        // 86 km geometric is the standard's 84.852 km'.
        assert!((UsStandard1976::geopotential(86_000.0) - 84_852.0).abs() < 1.0);
    }

    #[test]
    fn us_standard_is_monotone_and_finite_everywhere() {
        let mut prev = f64::INFINITY;
        let mut z = -5_000.0;
        while z < 200_000.0 {
            let s = UsStandard1976.sample(z);
            assert!(s.temperature > 0.0 && s.pressure > 0.0 && s.density > 0.0, "z={z}");
            assert!(s.pressure < prev, "pressure must fall with altitude at z={z}");
            prev = s.pressure;
            z += 250.0;
        }
        for z in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1e9, 1e12] {
            let s = UsStandard1976.sample(z);
            assert!(s.temperature.is_finite() && s.pressure.is_finite() && s.density.is_finite());
        }
    }

    #[test]
    fn thesis_formula_matches_its_print_and_never_nans() {
        let s = ThesisIsa.sample(0.0);
        assert!((s.temperature - 288.0).abs() < 1e-12);
        assert!((s.density - 353.0 / 288.0).abs() < 1e-12);
        // 5 km: printed law evaluated by hand.
        let s5 = ThesisIsa.sample(5_000.0);
        let expect = 353.0 * (1.0_f64 - 0.115).powf(5.3) / (288.0 - 32.5);
        assert!((s5.density - expect).abs() < 1e-12);
        let mut z = -100_000.0;
        while z <= 1.0e6 {
            let s = ThesisIsa.sample(z);
            assert!(s.temperature > 0.0 && s.density > 0.0 && s.pressure > 0.0, "z={z}");
            assert!(s.density.is_finite() && s.pressure.is_finite(), "z={z}");
            z += 37.0;
        }
        for z in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 43_478.26, 44_307.7] {
            let s = ThesisIsa.sample(z);
            assert!(s.density.is_finite() && s.density > 0.0, "z={z}");
        }
    }

    #[test]
    fn thesis_and_standard_agree_near_the_ground() {
        // The printed law is a troposphere fit: within 2 % of the standard below 5 km.
        for z in [0.0, 1_000.0, 3_000.0, 5_000.0] {
            assert!(rel(ThesisIsa.density(z), UsStandard1976.density(z)) < 0.02, "z={z}");
        }
    }
}
