//! Sun position from date, local solar time and latitude (the "classical celestial model" of
//! thesis §4.2.5), and the relative air mass `D(θ)` of eq. (4.9).
//!
//! Frame: x east, y north, z up. The grid's +x is east and +y north.

/// Direction toward the sun and its elevation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SunPosition {
    /// Unit vector toward the sun (x east, y north, z up).
    pub direction: [f64; 3],
    /// Elevation above the horizon (radians; negative at night).
    pub elevation: f64,
}

/// Solar declination (radians) on day `day_of_year` (Cooper 1969):
/// `δ = 23.45° · sin(2π (284 + N) / 365)`.
pub fn declination(day_of_year: f64) -> f64 {
    23.45f64.to_radians() * (std::f64::consts::TAU * (284.0 + day_of_year) / 365.0).sin()
}

/// Sun position at local solar time `hour` (0–24, noon = 12) on `day_of_year` at latitude
/// `latitude_deg`: hour angle `ω = 15° (hour − 12)`,
/// `sin(el) = sin φ sin δ + cos φ cos δ cos ω`, east = `−cos δ sin ω`,
/// north = `sin δ cos φ − cos δ sin φ cos ω`.
pub fn sun_position(day_of_year: f64, hour: f64, latitude_deg: f64) -> SunPosition {
    let d = declination(day_of_year);
    let phi = latitude_deg.to_radians();
    let w = (15.0 * (hour - 12.0)).to_radians();
    let up = phi.sin() * d.sin() + phi.cos() * d.cos() * w.cos();
    let east = -d.cos() * w.sin();
    let north = d.sin() * phi.cos() - d.cos() * phi.sin() * w.cos();
    let len = (east * east + north * north + up * up).sqrt().max(1e-12);
    SunPosition {
        direction: [east / len, north / len, up / len],
        elevation: (up / len).clamp(-1.0, 1.0).asin(),
    }
}

/// Relative atmospheric path `D(θ)` for a sun at zenith angle θ (`cos_zenith = cos θ`), by the
/// law of cosines on a spherical shell of thickness `H` over an Earth of radius `R`
/// (`r = R/H`): `D = √((r cos θ)² + 2r + 1) − r cos θ`; 1 at the zenith, ≈ 38 at the horizon.
pub fn air_mass(cos_zenith: f64) -> f64 {
    const R_OVER_H: f64 = 6_371.0 / 9.0;
    let c = cos_zenith.clamp(0.0, 1.0);
    let rc = R_OVER_H * c;
    (rc * rc + 2.0 * R_OVER_H + 1.0).sqrt() - rc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equinox_noon_and_solstices() {
        // Equinox (day 81, δ ≈ 0), 45° N, noon: elevation 45°, sun due south.
        let s = sun_position(81.0, 12.0, 45.0);
        assert!((s.elevation.to_degrees() - 45.0).abs() < 0.5, "{}", s.elevation.to_degrees());
        assert!(s.direction[0].abs() < 1e-9 && s.direction[1] < 0.0);
        // Morning sun in the east, evening in the west, midnight below the horizon.
        assert!(sun_position(81.0, 8.0, 45.0).direction[0] > 0.3);
        assert!(sun_position(81.0, 16.0, 45.0).direction[0] < -0.3);
        assert!(sun_position(81.0, 0.0, 45.0).elevation < 0.0);
        // June solstice noon at 45° N: 90 − 45 + 23.45 = 68.45°.
        let s = sun_position(172.0, 12.0, 45.0);
        assert!((s.elevation.to_degrees() - 68.45).abs() < 0.2);
    }

    #[test]
    fn air_mass_is_one_at_zenith_and_grows_to_the_horizon() {
        assert!((air_mass(1.0) - 1.0).abs() < 1e-9);
        // Plane-parallel limit 1/cos θ holds at 60°.
        assert!((air_mass(0.5) - 2.0).abs() < 0.01);
        assert!(air_mass(0.0) > 30.0 && air_mass(0.0) < 45.0);
    }
}
