//! Procedural umbrella (thesis §3.5.2): at the apex the s1 spheres detach from their slice and
//! spread radially from the column axis with `v_umbrella(d) = v r / d` (volume conservation:
//! the slice's expansion `π r² v` spread over a ring of radius `d`), with `v` the slice's vertical
//! speed when it crossed the neutral-buoyancy altitude and `d ≥ r`, while their altitude
//! relaxes from the apex toward `z_neutral` along a `1/d` profile.

use bevy::math::DVec2;
use bevy::reflect::Reflect;

/// A detached sphere of the umbrella.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct UmbrellaSphere {
    /// Column axis (horizontal position of the apex), m.
    pub axis: DVec2,
    /// Unit radial direction away from the axis.
    pub direction: DVec2,
    /// Radial distance from the axis (m), ≥ `r`.
    pub d: f64,
    /// Size of the slice it came from (m).
    pub r: f64,
    /// Slice speed when it crossed `z_neutral` (m/s).
    pub v_neutral: f64,
    /// Altitude of the apex (m).
    pub z_apex: f64,
    /// Neutral-buoyancy altitude (m).
    pub z_neutral: f64,
}

/// Radial speed `v r / d` (m/s), with `d` clamped to at least `r` (§3.5.2).
pub fn radial_speed(v_neutral: f64, r: f64, d: f64) -> f64 {
    v_neutral * r / d.max(r)
}

/// Altitude on the `1/d` relaxation profile: the apex at `d = r`, tending to `z_neutral`.
pub fn altitude(z_neutral: f64, z_apex: f64, r: f64, d: f64) -> f64 {
    z_neutral + (z_apex - z_neutral) * r / d.max(r)
}

impl UmbrellaSphere {
    /// Current altitude (m).
    pub fn altitude(&self) -> f64 {
        altitude(self.z_neutral, self.z_apex, self.r, self.d)
    }

    /// Horizontal position (m).
    pub fn horizontal(&self) -> DVec2 {
        self.axis + self.direction * self.d
    }

    /// Advances by `dt`. `dd/dt = v r / d` has the exact solution `d² = d₀² + 2 v r t`, used
    /// here so any time step is stable and step-size independent.
    /// Inside `d < r` the speed is `v` (the clamp), so the sphere moves linearly until `d = r`.
    pub fn step(&mut self, dt: f64) {
        let v = self.v_neutral.max(0.0);
        let mut t = if dt.is_finite() { dt.max(0.0) } else { 0.0 };
        if v == 0.0 || t == 0.0 {
            return;
        }
        if self.d < self.r {
            let to_r = (self.r - self.d) / v;
            if to_r >= t {
                self.d += v * t;
                return;
            }
            self.d = self.r;
            t -= to_r;
        }
        self.d = (self.d * self.d + 2.0 * v * self.r * t).sqrt();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere() -> UmbrellaSphere {
        UmbrellaSphere {
            axis: DVec2::new(100.0, -50.0),
            direction: DVec2::X,
            d: 300.0,
            r: 300.0,
            v_neutral: 60.0,
            z_apex: 10_200.0,
            z_neutral: 7_400.0,
        }
    }

    #[test]
    fn spreading_conserves_volume_flux_and_is_step_independent() {
        let (mut a, mut b) = (sphere(), sphere());
        for _ in 0..10 {
            a.step(6.0);
        }
        for _ in 0..6000 {
            b.step(0.01);
        }
        assert!((a.d - b.d).abs() < 1e-6 * a.d, "{} vs {}", a.d, b.d);
        // d² = d0² + 2 v r t at t = 60 s.
        let expect = (300.0f64.powi(2) + 2.0 * 60.0 * 300.0 * 60.0).sqrt();
        assert!((a.d - expect).abs() < 1e-9);
        // Flux through the ring 2π d · v(d) · h stays equal to the one at d = r.
        let flux = |d: f64| d * radial_speed(60.0, 300.0, d);
        assert!((flux(a.d) - flux(300.0)).abs() < 1e-9);
    }

    #[test]
    fn altitude_relaxes_from_apex_to_neutral() {
        let mut s = sphere();
        assert!((s.altitude() - 10_200.0).abs() < 1e-9, "starts at the apex");
        let mut prev = s.altitude();
        for _ in 0..200 {
            s.step(5.0);
            let z = s.altitude();
            assert!(z < prev && z > 7_400.0);
            prev = z;
        }
        // At d = 10 r the excess over neutral is a tenth.
        assert!((altitude(7_400.0, 10_200.0, 300.0, 3_000.0) - 7_680.0).abs() < 1e-9);
        // Starting inside the clamp (d < r) it moves at v, then follows the exact law.
        let mut inner = UmbrellaSphere { d: 150.0, ..sphere() };
        inner.step(1.0);
        assert!((inner.d - 210.0).abs() < 1e-9);
        inner.step(10.0);
        let expect = (300.0f64.powi(2) + 2.0 * 60.0 * 300.0 * 8.5).sqrt();
        assert!((inner.d - expect).abs() < 1e-9, "{} vs {expect}", inner.d);
        // A slice stopped at the apex (v = 0) does not spread.
        let mut still = UmbrellaSphere { v_neutral: 0.0, ..sphere() };
        still.step(100.0);
        assert_eq!(still.d, 300.0);
        assert_eq!(radial_speed(50.0, 100.0, 10.0), 50.0, "d is clamped to r");
    }
}
