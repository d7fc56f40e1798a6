//! Moist standard air for stand-alone runs (`PlumeParams::relative_humidity`): a standard
//! profile with water vapour at a fixed relative humidity. The coupled column reads the
//! simulated atmosphere's moisture instead (`model::ambient`).

use volcano_core::atmosphere::{AirState, AtmosphereModel, AtmosphereProfile};
use volcano_core::units::{R_AIR, R_VAPOUR};

/// Saturation vapour pressure over liquid water (Pa) at `t` K (Bolton 1980, eq 10).
pub fn saturation_vapour_pressure(t: f64) -> f64 {
    611.2 * (17.67 * (t - 273.15) / (t - 29.65)).exp()
}

/// A standard profile at a relative humidity (0 gives the profile itself, bit for bit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HumidAir {
    /// The dry profile (temperature and pressure).
    pub base: AtmosphereModel,
    /// Relative humidity, 0–1.
    pub relative_humidity: f64,
}

impl HumidAir {
    /// Vapour partial pressure (Pa) at `t`, never more than a tenth of the pressure `p`.
    fn vapour_pressure(&self, t: f64, p: f64) -> f64 {
        (self.relative_humidity.clamp(0.0, 1.0) * saturation_vapour_pressure(t)).min(0.1 * p)
    }
}

impl AtmosphereProfile for HumidAir {
    /// Density of moist air, dry part plus vapour: `(p − e)/(R_a T) + e/(R_v T)`.
    fn sample(&self, z: f64) -> AirState {
        let a = self.base.profile().sample(z);
        if self.relative_humidity <= 0.0 {
            return a;
        }
        let e = self.vapour_pressure(a.temperature, a.pressure);
        let density = (a.pressure - e) / (R_AIR * a.temperature) + e / (R_VAPOUR * a.temperature);
        AirState { density, ..a }
    }

    fn humidity(&self, z: f64) -> f64 {
        if self.relative_humidity <= 0.0 {
            return 0.0;
        }
        let a = self.base.profile().sample(z);
        1e3 * self.vapour_pressure(a.temperature, a.pressure) / (R_VAPOUR * a.temperature)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moist_air_is_lighter_and_holds_the_textbook_vapour() {
        // 15 °C saturated: 1,705 Pa, 12.8 g/m³ (psychrometric tables).
        assert!((saturation_vapour_pressure(288.15) - 1_705.0).abs() < 10.0);
        let dry = HumidAir { base: AtmosphereModel::UsStandard1976, relative_humidity: 0.0 };
        let wet = HumidAir { relative_humidity: 1.0, ..dry };
        assert!((wet.humidity(0.0) - 12.8).abs() < 0.2, "{}", wet.humidity(0.0));
        assert!(wet.density(0.0) < dry.density(0.0) - 0.005);
        assert_eq!(dry.sample(3_000.0), AtmosphereModel::UsStandard1976.profile().sample(3_000.0));
    }
}
