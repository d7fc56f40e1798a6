//! Wind by altitude, an input of the plume model (a coupled atmosphere replaces it, see
//! `model::ambient`).

use bevy::math::DVec2;
use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::error::{ConfigError, finite, in_range};

/// Horizontal wind as a function of altitude above the vent.
#[derive(Debug, Clone, PartialEq, Default, Reflect, Serialize, Deserialize)]
pub enum WindProfile {
    /// No wind.
    #[default]
    Calm,
    /// The thesis' validation profile (§3.7.2): speed linear from 0 at the ground to `max` at
    /// `top` metres, constant above; blowing toward `direction_deg` (counter-clockwise from +x).
    Linear {
        /// Speed at and above `top` (m/s).
        max: f64,
        /// Altitude above the vent where the maximum is reached (m); 12 km in the thesis.
        top: f64,
        /// Direction the wind blows toward, degrees counter-clockwise from +x.
        direction_deg: f64,
    },
    /// Levels `(altitude m, speed m/s, direction deg)` sorted by altitude, linearly
    /// interpolated (speed and direction as a vector), constant outside.
    Table(Vec<(f64, f64, f64)>),
}

impl WindProfile {
    /// Largest wind speed accepted (m/s): stronger than any jet stream.
    pub const MAX_SPEED: f64 = 200.0;

    /// Checks speeds, altitudes and directions.
    pub fn validate(&self) -> Result<(), ConfigError> {
        match self {
            WindProfile::Calm => Ok(()),
            WindProfile::Linear { max, top, direction_deg } => {
                in_range("wind max", *max, 0.0, Self::MAX_SPEED)?;
                in_range("wind top", *top, 1.0, 100_000.0)?;
                finite("wind direction_deg", *direction_deg)?;
                Ok(())
            }
            WindProfile::Table(levels) => {
                let mut prev = f64::NEG_INFINITY;
                for &(z, s, d) in levels {
                    finite("wind level altitude", z)?;
                    if z <= prev {
                        return Err(ConfigError::InvalidParameter {
                            name: "wind level altitude",
                            value: z,
                            reason: "levels must be sorted by strictly increasing altitude".into(),
                        });
                    }
                    prev = z;
                    in_range("wind level speed", s, 0.0, Self::MAX_SPEED)?;
                    finite("wind level direction", d)?;
                }
                Ok(())
            }
        }
    }

    /// Wind velocity (m/s, horizontal x/y) at `z` metres above the vent.
    pub fn at(&self, z: f64) -> DVec2 {
        let dir = |deg: f64| DVec2::new(deg.to_radians().cos(), deg.to_radians().sin());
        match self {
            WindProfile::Calm => DVec2::ZERO,
            WindProfile::Linear { max, top, direction_deg } => {
                dir(*direction_deg) * max * (z / top).clamp(0.0, 1.0)
            }
            WindProfile::Table(levels) => {
                let v = |&(_, s, d): &(f64, f64, f64)| dir(d) * s;
                match levels.iter().position(|l| l.0 > z) {
                    None => levels.last().map_or(DVec2::ZERO, v),
                    Some(0) => v(&levels[0]),
                    Some(i) => {
                        let (a, b) = (&levels[i - 1], &levels[i]);
                        let t = (z - a.0) / (b.0 - a.0);
                        v(a).lerp(v(b), t)
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_profile_matches_thesis_shape() {
        let w = WindProfile::Linear { max: 45.0, top: 12_000.0, direction_deg: 90.0 };
        assert!((w.at(6_000.0) - DVec2::new(0.0, 22.5)).length() < 1e-9);
        assert!((w.at(20_000.0).length() - 45.0).abs() < 1e-9);
        assert_eq!(w.at(-10.0), DVec2::ZERO);
    }

    #[test]
    fn table_interpolates_and_validates() {
        let w = WindProfile::Table(vec![(0.0, 0.0, 0.0), (1_000.0, 10.0, 0.0), (2_000.0, 10.0, 90.0)]);
        w.validate().unwrap();
        assert!((w.at(500.0) - DVec2::new(5.0, 0.0)).length() < 1e-9);
        assert!((w.at(5_000.0) - DVec2::new(0.0, 10.0)).length() < 1e-9);
        assert!(WindProfile::Table(vec![(5.0, 1.0, 0.0), (1.0, 1.0, 0.0)]).validate().is_err());
        assert!(WindProfile::Linear { max: f64::NAN, top: 1.0, direction_deg: 0.0 }.validate().is_err());
    }
}
