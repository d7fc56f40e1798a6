//! Procedural stratovolcano terrain: a concave cone with a summit crater, radial fBm ridges
//! (gullies) on the flanks and a rolling fBm landscape around it, all from the `noise` crate
//! and seeded, so the same parameters and seed give the same terrain bit for bit.

use bevy::reflect::Reflect;
use noise::{Fbm, MultiFractal, NoiseFn, Perlin, RidgedMulti};
use serde::{Deserialize, Serialize};

use super::{LandCover, Terrain, centred_origin};
use crate::error::{ConfigError, in_range, positive};
use crate::grid::Grid2;

/// Parameters of [`StratovolcanoParams::generate`]. All lengths in metres; altitudes above sea
/// level. Defaults give a 2.5 km high cone, 12 km wide, on a 20 km square at 512² samples.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default)]
pub struct StratovolcanoParams {
    /// Samples per side (2..=4097).
    pub resolution: u32,
    /// Distance between samples (m).
    pub cell: f64,
    /// Altitude of the surrounding plain (m).
    pub base_altitude: f32,
    /// Height of the crater rim above the plain (m).
    pub summit_height: f32,
    /// Radius of the cone's foot (m).
    pub cone_radius: f32,
    /// Exponent of the flank profile; > 1 gives the concave stratovolcano shape.
    pub flank_exponent: f32,
    /// Radius of the summit crater (m).
    pub crater_radius: f32,
    /// Depth of the crater below the rim (m).
    pub crater_depth: f32,
    /// Amplitude of the radial ridges and gullies (m).
    pub ridge_amplitude: f32,
    /// Amplitude of the rolling landscape around the cone (m).
    pub hills_amplitude: f32,
    /// Sea level (m); cells below it become water. Use a low value for no sea.
    pub sea_level: f32,
    /// Altitude above which the ground is snow-covered (m).
    pub snow_line: f32,
    /// Slope (degrees) above which vegetation gives way to bare ground.
    pub bare_slope_deg: f32,
    /// Noise seed.
    pub seed: u32,
}

impl Default for StratovolcanoParams {
    fn default() -> Self {
        Self {
            resolution: 512,
            cell: 40.0,
            base_altitude: 200.0,
            summit_height: 2_500.0,
            cone_radius: 6_000.0,
            flank_exponent: 1.6,
            crater_radius: 350.0,
            crater_depth: 120.0,
            ridge_amplitude: 60.0,
            hills_amplitude: 150.0,
            sea_level: 0.0,
            snow_line: 2_300.0,
            bare_slope_deg: 28.0,
            seed: 7,
        }
    }
}

impl StratovolcanoParams {
    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("resolution", self.resolution as f64, 2.0, 4097.0)?;
        positive("cell", self.cell)?;
        in_range("base_altitude", self.base_altitude as f64, -11_000.0, 9_000.0)?;
        in_range("summit_height", self.summit_height as f64, 0.0, 9_000.0)?;
        positive("cone_radius", self.cone_radius as f64)?;
        in_range("flank_exponent", self.flank_exponent as f64, 0.2, 5.0)?;
        in_range("crater_radius", self.crater_radius as f64, 0.0, self.cone_radius as f64 * 0.9)?;
        in_range("crater_depth", self.crater_depth as f64, 0.0, self.summit_height as f64)?;
        in_range("ridge_amplitude", self.ridge_amplitude as f64, 0.0, 2_000.0)?;
        in_range("hills_amplitude", self.hills_amplitude as f64, 0.0, 5_000.0)?;
        in_range("sea_level", self.sea_level as f64, -20_000.0, 20_000.0)?;
        in_range("snow_line", self.snow_line as f64, -20_000.0, 20_000.0)?;
        in_range("bare_slope_deg", self.bare_slope_deg as f64, 0.0, 90.0)?;
        Ok(())
    }

    /// Generates the terrain, centred on world (0, 0) with the crater at the centre.
    pub fn generate(&self) -> Result<Terrain, ConfigError> {
        self.validate()?;
        let n = self.resolution as usize;
        let origin = centred_origin(n, self.cell);
        let mut heights = Grid2::new(n, n, self.cell, origin, 0.0f32)?;
        let ridges = RidgedMulti::<Perlin>::new(self.seed).set_octaves(5).set_frequency(1.0);
        let hills = Fbm::<Perlin>::new(self.seed.wrapping_add(1)).set_octaves(5).set_frequency(1.0);
        let r_foot = self.cone_radius as f64;
        for j in 0..n {
            for i in 0..n {
                let p = heights.position(i, j);
                let (x, z) = (p.x as f64, p.y as f64);
                let r = (x * x + z * z).sqrt();
                let cone = self.cone_profile(r);
                // Radial ridges: noise sampled in (angle, radius) so gullies run downslope;
                // strongest mid-flank, fading at the crater and the foot.
                let theta = z.atan2(x);
                let flank = (std::f64::consts::PI * (r / r_foot).clamp(0.0, 1.0)).sin();
                let ridge =
                    ridges.get([theta.cos() * 6.0 + 10.0, theta.sin() * 6.0 + 10.0, r / r_foot * 2.0]);
                // Rolling landscape, fading under the cone.
                let outside = ((r / r_foot - 0.6) / 0.6).clamp(0.0, 1.0);
                let hill = hills.get([x / 4_000.0, z / 4_000.0]);
                let h = self.base_altitude as f64
                    + cone
                    + self.ridge_amplitude as f64 * flank * ridge
                    + self.hills_amplitude as f64 * outside * hill;
                heights.set(i, j, h as f32);
            }
        }
        let cover = self.land_cover(&heights)?;
        Terrain::new(heights, cover, self.sea_level)
    }

    /// Cone height above the plain at distance `r` from the centre: concave flanks
    /// `H ((R − r)/(R − r_c))^p` outside the crater, a parabolic bowl inside it.
    fn cone_profile(&self, r: f64) -> f64 {
        let h = self.summit_height as f64;
        let rc = self.crater_radius as f64;
        let rf = self.cone_radius as f64;
        if r >= rf {
            0.0
        } else if r >= rc {
            h * ((rf - r) / (rf - rc)).powf(self.flank_exponent as f64)
        } else {
            let s = r / rc.max(1e-6);
            h - self.crater_depth as f64 * (1.0 - s * s)
        }
    }

    fn land_cover(&self, heights: &Grid2<f32>) -> Result<Grid2<LandCover>, ConfigError> {
        let (n, cell) = (heights.nx(), heights.cell());
        let mut cover = Grid2::new(n, n, cell, heights.origin(), LandCover::Ground)?;
        let max_tan = (self.bare_slope_deg as f64).to_radians().tan();
        let bare_radius = self.cone_radius as f64 * 0.35;
        for j in 0..n {
            for i in 0..n {
                let h = heights.get(i, j);
                let p = heights.position(i, j);
                let r = ((p.x * p.x + p.y * p.y) as f64).sqrt();
                let slope = heights.gradient(i, j, crate::Boundary::Clamp).length() as f64;
                let c = if h < self.sea_level {
                    LandCover::Water
                } else if h > self.snow_line {
                    LandCover::Snow
                } else if slope > max_tan || r < bare_radius {
                    LandCover::Ground
                } else {
                    LandCover::Vegetation
                };
                cover.set(i, j, c);
            }
        }
        Ok(cover)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(seed: u32) -> StratovolcanoParams {
        StratovolcanoParams { resolution: 96, cell: 150.0, seed, ..Default::default() }
    }

    #[test]
    fn deterministic_per_seed() {
        let a = small(3).generate().unwrap();
        let b = small(3).generate().unwrap();
        let c = small(4).generate().unwrap();
        assert_eq!(a.heights().data(), b.heights().data(), "same seed must give identical terrain");
        assert_eq!(a.cover().data(), b.cover().data());
        assert_ne!(a.heights().data(), c.heights().data(), "another seed must differ");
    }

    #[test]
    fn has_a_cone_and_a_crater() {
        let p = small(1);
        let t = p.generate().unwrap();
        let rim = t.height_at(p.crater_radius, 0.0);
        let centre = t.height_at(0.0, 0.0);
        let foot = t.height_at(p.cone_radius * 1.2, 0.0);
        assert!(rim > foot + 0.8 * p.summit_height, "rim {rim} foot {foot}");
        assert!(centre < rim - 0.5 * p.crater_depth, "crater floor {centre} rim {rim}");
        // Flanks fall monotonically on average along a ray.
        let mid = t.height_at(p.cone_radius * 0.5, 0.0);
        assert!(rim > mid && mid > foot);
        // Summit above the snow line is snowy; the far plain is not.
        assert_eq!(t.cover_at(p.crater_radius * 1.5, 0.0), LandCover::Snow);
        assert_ne!(t.cover_at(p.cone_radius * 1.4, p.cone_radius * 1.4), LandCover::Snow);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let mut p = small(1);
        p.cell = f64::NAN;
        assert!(p.generate().unwrap_err().to_string().contains("cell"));
        let mut p = small(1);
        p.crater_radius = -5.0;
        assert!(p.validate().unwrap_err().to_string().contains("crater_radius"));
        let mut p = small(1);
        p.resolution = 1;
        assert!(p.validate().is_err());
    }
}
