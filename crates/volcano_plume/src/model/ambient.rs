//! The ambient air a coupled column sees (thesis §4.3.3, "from the atmosphere to the plume"):
//! per air layer, the mean temperature, moisture and wind around the column at that layer's
//! altitude; between layers the values are interpolated linearly in altitude, giving the
//! profile and the wind every slice reads instead of a standard atmosphere and an imposed wind.
//!
//! Outside the layers' altitude range the base profile's shape is kept: the temperature is the
//! base profile's, shifted by its offset at the nearest layer, and the wind and moisture are
//! the nearest layer's. Pressure is the base profile's (the layers carry no pressure
//! deviation large enough to matter for the column); density follows the gas law with the
//! virtual temperature `T (1 + 0.608 q)` (q the specific humidity), so moist air is lighter.

use bevy::math::DVec2;
use bevy::reflect::Reflect;
use volcano_core::atmosphere::{AirState, AtmosphereModel, AtmosphereProfile};
use volcano_core::error::{ConfigError, finite, in_range};
use volcano_core::units::R_AIR;

/// The air around the column at one layer's altitude.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct AmbientLevel {
    /// Altitude above sea level (m).
    pub altitude: f64,
    /// Temperature (K).
    pub temperature: f64,
    /// Absolute humidity, water vapour (g/m³).
    pub humidity: f64,
    /// Horizontal wind in the plume frame (x east, y north; m/s).
    pub wind: DVec2,
}

/// A vertical profile built from layer means, over a base profile for what lies outside.
#[derive(Debug, Clone, PartialEq, Reflect)]
pub struct LayeredAmbient {
    /// Profile used for pressure everywhere and for the temperature's shape outside the levels.
    pub base: AtmosphereModel,
    levels: Vec<AmbientLevel>,
}

impl LayeredAmbient {
    /// Checks the levels (finite, positive temperature, non-negative humidity, strictly
    /// increasing altitude, at least one).
    pub fn new(base: AtmosphereModel, levels: Vec<AmbientLevel>) -> Result<Self, ConfigError> {
        if levels.is_empty() {
            return Err(ConfigError::InvalidParameter {
                name: "ambient levels",
                value: 0.0,
                reason: "need at least one level".into(),
            });
        }
        let mut prev = f64::NEG_INFINITY;
        for l in &levels {
            finite("ambient altitude", l.altitude)?;
            if l.altitude <= prev {
                return Err(ConfigError::InvalidParameter {
                    name: "ambient altitude",
                    value: l.altitude,
                    reason: "levels must be sorted by strictly increasing altitude".into(),
                });
            }
            prev = l.altitude;
            in_range("ambient temperature", l.temperature, 100.0, 5_000.0)?;
            in_range("ambient humidity", l.humidity, 0.0, 1_000.0)?;
            finite("ambient wind x", l.wind.x)?;
            finite("ambient wind y", l.wind.y)?;
        }
        Ok(Self { base, levels })
    }

    /// The levels, lowest first.
    pub fn levels(&self) -> &[AmbientLevel] {
        &self.levels
    }

    /// The two levels around `z` and the weight of the upper one; `None` below or above.
    fn bracket(&self, z: f64) -> Bracket {
        let l = &self.levels;
        if z <= l[0].altitude {
            return Bracket::Below;
        }
        // The first level above `z` (levels are strictly increasing: a binary search).
        match l.partition_point(|v| v.altitude <= z) {
            // 0 only for a NaN `z` (it failed the test above): treated as above the top level.
            i if i == l.len() || i == 0 => Bracket::Above,
            i => {
                let (a, b) = (&l[i - 1], &l[i]);
                Bracket::Between(i - 1, (z - a.altitude) / (b.altitude - a.altitude))
            }
        }
    }

    fn lerp_by(&self, z: f64, f: impl Fn(&AmbientLevel) -> f64) -> f64 {
        self.lerp_in(self.bracket(z), f)
    }

    fn lerp_in(&self, bracket: Bracket, f: impl Fn(&AmbientLevel) -> f64) -> f64 {
        match bracket {
            Bracket::Below => f(&self.levels[0]),
            Bracket::Above => f(self.levels.last().expect("non-empty")),
            Bracket::Between(i, t) => f(&self.levels[i]) + (f(&self.levels[i + 1]) - f(&self.levels[i])) * t,
        }
    }

    /// Temperature (K) at `z` m above sea level, `bracket` being `self.bracket(z)`.
    fn temperature_at(&self, z: f64, bracket: Bracket) -> f64 {
        let base = self.base.profile();
        match bracket {
            Bracket::Below => {
                let l = &self.levels[0];
                base.temperature(z) + (l.temperature - base.temperature(l.altitude))
            }
            Bracket::Above => {
                let l = self.levels.last().expect("non-empty");
                base.temperature(z) + (l.temperature - base.temperature(l.altitude))
            }
            Bracket::Between(..) => self.lerp_in(bracket, |l| l.temperature),
        }
    }

    /// Wind (plume frame, m/s) at `z` m above sea level.
    pub fn wind_at(&self, z: f64) -> DVec2 {
        let bracket = self.bracket(z);
        DVec2::new(self.lerp_in(bracket, |l| l.wind.x), self.lerp_in(bracket, |l| l.wind.y))
    }
}

#[derive(Clone, Copy)]
enum Bracket {
    Below,
    Above,
    Between(usize, f64),
}

impl AtmosphereProfile for LayeredAmbient {
    fn sample(&self, z: f64) -> AirState {
        let z = if z.is_nan() { 0.0 } else { z };
        // One bracket for the temperature and the humidity (a slice samples the air in each
        // of its substeps).
        let bracket = self.bracket(z);
        let temperature = self.temperature_at(z, bracket).max(100.0);
        let pressure = self.base.profile().pressure(z);
        // Specific humidity from the vapour density over the dry air's (g/m³ → kg/kg).
        let dry = pressure / (R_AIR * temperature);
        let humidity = self.lerp_in(bracket, |l| l.humidity).max(0.0);
        let q = (1e-3 * humidity / dry.max(1e-9)).min(0.2);
        let density = pressure / (R_AIR * temperature * (1.0 + 0.608 * q));
        AirState { temperature, pressure, density }
    }

    fn humidity(&self, z: f64) -> f64 {
        self.lerp_by(z, |l| l.humidity).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_core::UsStandard1976;

    fn standard_levels(alts: &[f64]) -> Vec<AmbientLevel> {
        alts.iter()
            .map(|&z| AmbientLevel {
                altitude: z,
                temperature: UsStandard1976.temperature(z),
                humidity: 0.0,
                wind: DVec2::ZERO,
            })
            .collect()
    }

    #[test]
    fn levels_from_the_standard_give_back_the_standard() {
        // Levels inside one linear segment of the standard (the troposphere) and beyond it:
        // inside, linear interpolation is exact up to the standard being linear in
        // geopotential rather than geometric altitude (≈ 3 mK at 2 km); outside, the base
        // shape is kept exactly.
        let a = LayeredAmbient::new(
            AtmosphereModel::UsStandard1976,
            standard_levels(&[1_000.0, 5_000.0, 9_000.0]),
        )
        .unwrap();
        for z in [0.0, 2_000.0, 7_500.0, 15_000.0] {
            let (got, want) = (a.sample(z), UsStandard1976.sample(z));
            assert!((got.temperature - want.temperature).abs() < 1e-2, "{z}: {got:?} vs {want:?}");
            assert!((got.density - want.density).abs() / want.density < 1e-4, "{z}");
        }
    }

    #[test]
    fn warm_moist_levels_are_lighter_and_wind_interpolates() {
        let mut levels = standard_levels(&[1_000.0, 3_000.0]);
        levels[0].wind = DVec2::new(10.0, 0.0);
        levels[1].wind = DVec2::new(0.0, 10.0);
        let dry = LayeredAmbient::new(AtmosphereModel::UsStandard1976, levels.clone()).unwrap();
        levels[0].humidity = 10.0;
        levels[0].temperature += 5.0;
        let moist = LayeredAmbient::new(AtmosphereModel::UsStandard1976, levels).unwrap();
        assert!(moist.density(1_000.0) < dry.density(1_000.0) * 0.98);
        assert!((dry.wind_at(2_000.0) - DVec2::new(5.0, 5.0)).length() < 1e-12);
        assert_eq!(dry.wind_at(-50.0), DVec2::new(10.0, 0.0));
        assert_eq!(moist.humidity(2_000.0), 5.0);
    }

    #[test]
    fn bad_levels_are_named_errors() {
        assert!(LayeredAmbient::new(AtmosphereModel::Thesis, vec![]).is_err());
        let mut l = standard_levels(&[2_000.0, 1_000.0]);
        assert!(
            LayeredAmbient::new(AtmosphereModel::Thesis, l.clone())
                .unwrap_err()
                .to_string()
                .contains("increasing")
        );
        l.reverse();
        l[0].temperature = f64::NAN;
        assert!(
            LayeredAmbient::new(AtmosphereModel::Thesis, l).unwrap_err().to_string().contains("temperature")
        );
    }
}
