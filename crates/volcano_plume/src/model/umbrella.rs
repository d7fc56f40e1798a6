//! Procedural umbrella (thesis §3.5.2): at the apex the s1 spheres detach from their slice and
//! spread radially from the column axis with `v_umbrella(d) = v r / d` (volume conservation:
//! the slice's expansion `π r² v` spread over a ring of radius `d`), with `v` the slice's vertical
//! speed when it crossed the neutral-buoyancy altitude and `d ≥ r`, while their altitude
//! relaxes from the apex toward `z_neutral` along a `1/d` profile.
//!
//! The physical column's umbrella ([`Spread::GravityCurrent`]) spreads instead as a gravity
//! current fed at a constant volume rate Q in air of buoyancy frequency N: its front is at
//! `R(t) = c t^{2/3}`, `c = (3 λ N Q / 2π)^{1/3}` (Woods & Kienle 1994; λ ≈ 0.2, Suzuki &
//! Koyaguchi 2009). A sphere at distance d moves at the speed of a front there,
//! `dd/dt = (2/3) c^{3/2} d^{−1/2}`.

use bevy::math::{DVec2, DVec3};
use bevy::reflect::Reflect;
use volcano_core::atmosphere::AtmosphereProfile;
use volcano_core::units::G0;

use super::slice::Slice;

/// How the umbrella spreads.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub enum Spread {
    /// The thesis' `v r / d` (§3.5.2) with `v` the sphere's `v_neutral`.
    Thesis,
    /// A gravity current with front `R = c t^{2/3}`; `c` in m/s^{2/3}.
    GravityCurrent {
        /// `(3 λ N Q / 2π)^{1/3}`.
        c: f64,
    },
}

/// Coefficient `c = (3 λ N Q / 2π)^{1/3}` (m/s^{2/3}) of a gravity-current umbrella front
/// `R = c t^{2/3}` (Woods & Kienle 1994), `q` the volume rate into the umbrella (m³/s), `n`
/// the buoyancy frequency (1/s).
pub fn gravity_current_coefficient(lambda: f64, n: f64, q: f64) -> f64 {
    (3.0 * lambda * n * q / (2.0 * std::f64::consts::PI)).max(0.0).cbrt()
}

/// Smallest buoyancy frequency (1/s) used for the umbrella: where the air is neutral or
/// unstable (N² ≤ 0) a gravity current is not held up; 10⁻³ s⁻¹ (a tenth of the troposphere's)
/// keeps the law defined. [`buoyancy_frequency`] says when it acts.
pub const MIN_BUOYANCY_FREQUENCY: f64 = 1e-3;

/// Buoyancy (Brunt–Väisälä) frequency N (1/s) of the air at altitude `z` (m above sea level):
/// `N² = (g/T)(dT/dz + g/c_p)` by central differences over ±100 m; the bool is true when N
/// was raised to [`MIN_BUOYANCY_FREQUENCY`].
pub fn buoyancy_frequency(air: &dyn AtmosphereProfile, z: f64) -> (f64, bool) {
    let dz = 100.0;
    let t = air.temperature(z);
    let dtdz = (air.temperature(z + dz) - air.temperature(z - dz)) / (2.0 * dz);
    let n2 = G0 / t * (dtdz + G0 / super::column::CP_AIR);
    let n = n2.max(0.0).sqrt();
    if n < MIN_BUOYANCY_FREQUENCY { (MIN_BUOYANCY_FREQUENCY, true) } else { (n, false) }
}

/// A detached sphere of the umbrella.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct UmbrellaSphere {
    /// The point it spreads from (m): the column's axis at the apex for an untilted ring, within
    /// a ring diameter of it for a tilted one ([`UmbrellaSphere::detach`]); carried by the wind.
    pub axis: DVec2,
    /// Unit radial direction away from the axis (the sphere's ring azimuth).
    pub direction: DVec2,
    /// Radial distance from the axis (m), ≥ `r`.
    pub d: f64,
    /// Size of the slice it came from (m).
    pub r: f64,
    /// Slice speed when it crossed `z_neutral` (m/s).
    pub v_neutral: f64,
    /// Altitude the relaxation starts from (m): the sphere's own altitude when it left its
    /// slice at the apex (the apex itself for a sphere on an untilted ring).
    pub z_apex: f64,
    /// Neutral-buoyancy altitude (m).
    pub z_neutral: f64,
    /// Spreading law.
    pub spread: Spread,
}

impl UmbrellaSphere {
    /// Whether every number of its state is finite.
    pub fn is_finite(&self) -> bool {
        let spread = match self.spread {
            Spread::Thesis => true,
            Spread::GravityCurrent { c } => c.is_finite(),
        };
        self.axis.is_finite()
            && self.direction.is_finite()
            && self.d.is_finite()
            && self.r.is_finite()
            && self.v_neutral.is_finite()
            && self.z_apex.is_finite()
            && self.z_neutral.is_finite()
            && spread
    }
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
    /// The umbrella sphere of an s1 sphere leaving `slice` at its apex, `local` its offset on
    /// the vortex ring in the slice frame: it starts where it is, the slice centre plus
    /// `slice.rotation() * local` (a slice bent by the wind has a tilted ring), spreads
    /// horizontally along its ring azimuth (the direction of `local` in the slice plane), at
    /// the distance from the axis of its offset's horizontal part, and relaxes from its own
    /// altitude toward `z_neutral`.
    ///
    /// Our reading of §3.5.2 (docs/physics/plume.md §4.3, "Umbrella"): the thesis spreads the
    /// spheres radially from a vertical column's axis, where the ring is horizontal and the
    /// ring azimuth *is* the radial direction, so an untilted slice spreads as the thesis has it.
    /// A column bent over by the wind arrives with a near-vertical ring, whose offsets all point
    /// across the wind horizontally: spread along them, every slice's spheres would pile up in
    /// two clumps.
    /// The point the sphere spreads from (`axis`) is set so that it starts where it sat, within
    /// a ring diameter of the slice centre. Under either law: a gravity current's spheres too
    /// start where they sit and move on at the speed the front would have there (starting on
    /// the axis would be a jump of half a slice — up to a kilometre for the physical column —
    /// at detachment).
    pub fn detach(slice: &Slice, local: DVec3, spread: Spread) -> Self {
        let offset = slice.rotation() * local;
        let h = offset.truncate();
        let direction = local.truncate().try_normalize().unwrap_or(DVec2::X);
        let d = h.length();
        Self {
            axis: slice.position.truncate() + h - direction * d,
            direction,
            d,
            r: slice.r,
            v_neutral: slice.neutral_speed.unwrap_or(0.0),
            z_apex: slice.position.z + offset.z,
            z_neutral: slice.neutral_altitude.unwrap_or(slice.apex),
            spread,
        }
    }

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
    ///
    /// A gravity current: `d^{3/2} = d₀^{3/2} + c^{3/2} t`, exact for any step.
    pub fn step(&mut self, dt: f64) {
        if let Spread::GravityCurrent { c } = self.spread {
            let t = if dt.is_finite() { dt.max(0.0) } else { 0.0 };
            let c = if c.is_finite() { c.max(0.0) } else { 0.0 };
            self.d = (self.d.max(0.0).powf(1.5) + c.powf(1.5) * t).powf(2.0 / 3.0);
            return;
        }
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
            spread: Spread::Thesis,
        }
    }

    /// Integrates `dd/dt = speed(d)` by classical Runge–Kutta with 1 ms steps: an integration
    /// of the spreading law that shares nothing with the closed forms `step` uses.
    fn integrate(mut d: f64, seconds: f64, speed: impl Fn(f64) -> f64) -> f64 {
        let h = 1e-3;
        for _ in 0..(seconds / h).round() as u64 {
            let k1 = speed(d);
            let k2 = speed(d + 0.5 * h * k1);
            let k3 = speed(d + 0.5 * h * k2);
            let k4 = speed(d + h * k3);
            d += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0;
        }
        d
    }

    #[test]
    fn spreading_follows_the_volume_flux_law_whatever_the_step() {
        // §3.5.2: the ring's volume flux 2π d v(d) h is constant beyond d = r, so
        // dd/dt = v r / d (v inside the clamp). Start inside the clamp, cross it, spread 60 s;
        // `step` with 6 s steps must land where the integrated law does.
        let mut a = UmbrellaSphere { d: 120.0, ..sphere() };
        for _ in 0..10 {
            a.step(6.0);
        }
        let want = integrate(120.0, 60.0, |d| radial_speed(60.0, 300.0, d));
        assert!((a.d - want).abs() < 1e-6 * want, "step {} m vs integrated law {} m", a.d, want);
        // A gravity current (Spread::GravityCurrent, c = 12 m/s): d^{3/2} grows as c^{3/2} t,
        // i.e. dd/dt = (2/3) c^{3/2} d^{-1/2} — started off the axis to keep the law regular.
        let mut g = UmbrellaSphere { d: 50.0, spread: Spread::GravityCurrent { c: 12.0 }, ..sphere() };
        g.step(40.0);
        let want = integrate(50.0, 40.0, |d| 2.0 / 3.0 * 12.0f64.powf(1.5) / d.sqrt());
        assert!((g.d - want).abs() < 1e-6 * want, "gravity current {} m vs {} m", g.d, want);
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

    #[test]
    fn gravity_current_front_grows_as_t_two_thirds_at_any_step() {
        // From the axis, stepped finely: the front doubles its age → grows by 2^{2/3}.
        let c = gravity_current_coefficient(0.2, 0.012, 4e8);
        let mut s = UmbrellaSphere { d: 0.0, spread: Spread::GravityCurrent { c }, ..sphere() };
        let mut at = Vec::new();
        for k in 1..=4000 {
            s.step(0.25);
            if k % 1000 == 0 {
                at.push(s.d);
            }
        }
        let slope = (at[3] / at[1]).ln() / 2f64.ln();
        assert!((slope - 2.0 / 3.0).abs() < 1e-9, "exponent {slope}");
        // The same in one step, and the thesis law (d ∝ t^{1/2}) is a different exponent.
        let mut one = UmbrellaSphere { d: 0.0, spread: Spread::GravityCurrent { c }, ..sphere() };
        one.step(1000.0);
        assert!((one.d - at[3]).abs() < 1e-6 * at[3]);
        // A standard troposphere holds it up (N ≈ 0.011 /s); an isothermal-free adiabat does not.
        let (n, floored) = buoyancy_frequency(&volcano_core::UsStandard1976, 5_000.0);
        assert!((n - 0.0114).abs() < 0.001 && !floored, "N = {n}");
    }

    /// A column bent over by the wind reaches its apex with its ring nearly vertical: the
    /// horizontal parts of the ring offsets all lie along one line across the wind. Spread
    /// along them, the umbrella would be two clumps on that line, every slice's spheres piled
    /// on the same two spots (seen end-on, such a clump shows as a flat disc face). Each sphere
    /// spreads along its own ring azimuth: a ring of six covers every direction, 60° apart,
    /// however the slice is tilted.
    #[test]
    fn a_bent_columns_ring_spreads_in_every_direction() {
        use super::super::params::Preset;
        let p = Preset::PlinianShowcase.params();
        for velocity in [DVec3::new(8.0, 3.0, 0.5), DVec3::new(-2.0, 9.0, 1.0), DVec3::new(0.1, 0.0, 12.0)] {
            let mut slice = Slice::at_vent(&p);
            slice.r = 1_500.0;
            slice.position = DVec3::new(1_000.0, -1_200.0, 12_000.0);
            slice.velocity = velocity;
            slice.apex = 12_000.0;
            slice.neutral_altitude = Some(11_000.0);
            slice.neutral_speed = Some(20.0);
            let mut azimuths: Vec<f64> = (0..6)
                .map(|k| {
                    let a = 0.3 + k as f64 * std::f64::consts::TAU / 6.0;
                    let local = DVec3::new(a.cos(), a.sin(), 0.0) * 0.5 * slice.r;
                    let mut u = UmbrellaSphere::detach(&slice, local, Spread::Thesis);
                    let start = u.horizontal();
                    u.step(120.0);
                    let moved = u.horizontal() - start;
                    assert!(moved.length() > 500.0, "{velocity}: moved {moved}");
                    moved.y.atan2(moved.x)
                })
                .collect();
            azimuths.sort_by(f64::total_cmp);
            let gap = azimuths
                .windows(2)
                .map(|w| w[1] - w[0])
                .chain([azimuths[0] + std::f64::consts::TAU - azimuths[5]])
                .fold(0.0, f64::max);
            assert!(
                gap.to_degrees() < 61.0,
                "{velocity}: largest gap between directions {:.0}°",
                gap.to_degrees()
            );
        }
    }

    /// A sphere leaving a wind-tilted slice starts where it sits on the ring, under either
    /// spreading law (the gravity current's spheres too, not on the axis).
    #[test]
    fn a_detached_sphere_starts_where_it_sat_on_the_tilted_ring() {
        use super::super::params::Preset;
        let p = Preset::Physical.params();
        let mut slice = Slice::at_vent(&p);
        slice.r = 1_500.0;
        slice.position = DVec3::new(2_000.0, -500.0, 16_000.0);
        slice.velocity = DVec3::new(8.0, 3.0, 10.0);
        slice.apex = 16_000.0;
        slice.neutral_altitude = Some(14_000.0);
        let local = DVec3::new(0.6, -0.8, 0.0) * 0.5 * slice.r;
        let at = slice.position + slice.rotation() * local;
        for spread in [Spread::Thesis, Spread::GravityCurrent { c: 20.0 }] {
            let u = UmbrellaSphere::detach(&slice, local, spread);
            let (h, z) = (u.horizontal(), u.altitude());
            assert!(
                h.distance(at.truncate()) < 1e-6 && (z - at.z).abs() < 1e-6,
                "{spread:?}: starts at ({h}, {z}) m, sat at {at} m"
            );
        }
    }
}
