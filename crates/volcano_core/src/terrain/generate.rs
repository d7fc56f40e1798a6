//! Procedural stratovolcano terrain: a concave cone with a summit crater, radial gullies and
//! ridges on the flanks and a rolling fBm landscape around it, all from the `noise` crate and
//! seeded, so the same parameters and seed give the same terrain bit for bit.
//!
//! The gully law (`Gullies`) is this crate's own, for the look; it is not from the thesis.

use bevy::reflect::Reflect;
use noise::{Fbm, MultiFractal, NoiseFn, Perlin};
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
    /// Amplitude of the radial ridges and gullies (m): the gully field spans about ± this on
    /// the mid-flank (see [`StratovolcanoParams::generate`]).
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
    ///
    /// Height = plain + concave cone (`Self::cone_profile`) + `ridge_amplitude` × the gully
    /// field + `hills_amplitude` × a rolling fBm faded in from 0.6 `cone_radius` outwards.
    /// The gully field is described at `Gullies`: radial ridged noise whose cross-slope
    /// wavelengths never go below a few cells, so a 40 m grid draws gullies, not hairlines.
    pub fn generate(&self) -> Result<Terrain, ConfigError> {
        self.validate()?;
        let n = self.resolution as usize;
        let origin = centred_origin(n, self.cell);
        let mut heights = Grid2::new(n, n, self.cell, origin, 0.0f32)?;
        let gullies = Gullies::new(self);
        let hills = Fbm::<Perlin>::new(self.seed.wrapping_add(1)).set_octaves(5).set_frequency(1.0);
        let r_foot = self.cone_radius as f64;
        for j in 0..n {
            for i in 0..n {
                let p = heights.position(i, j);
                let (x, z) = (p.x as f64, p.y as f64);
                let r = (x * x + z * z).sqrt();
                let cone = self.cone_profile(r);
                // Rolling landscape, fading under the cone.
                let outside = ((r / r_foot - 0.6) / 0.6).clamp(0.0, 1.0);
                let hill = hills.get([x / 4_000.0, z / 4_000.0]);
                let h = self.base_altitude as f64
                    + cone
                    + self.ridge_amplitude as f64 * gullies.at(x, z)
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

/// The radial gully field of [`StratovolcanoParams::generate`], about [−1, 1] (standard
/// deviation 0.40 on the upper and middle flank). Our own law for the look, not from
/// the thesis: it is tuned against aerial views of stratovolcanoes (Mayon, Fuji, Ruapehu),
/// whose flanks carry gullies a few hundred metres apart, irregular, branching and merging, a
/// few times longer than wide, that die out on the lower apron.
///
/// Ridged multifractal noise (`(1 − |n|)²`, each octave weighted by the one before, as in
/// `noise::RidgedMulti`) sampled in polar coordinates around the crater, with its sign flipped
/// so that the sharp ridged lines are V-shaped gully floors between broad interfluves:
///
/// - **Across the slope**, octave `i` (of [`Gullies::OCTAVES`]) goes round a circle of radius
///   `k_i = K0 · 2^i` in noise space, so one noise unit spans `r / k_i` metres: the coarsest
///   octave has `r / 3` (1 km at mid-flank). An octave fades in only where its unit is at least
///   [`Gullies::MIN_CELLS`] cells (fully at twice that), so no octave is ever finer than the
///   grid can draw at that radius: near the summit only the coarsest remains, downslope finer
///   ones join in and gullies branch; a coarse grid (the tests' 100–500 m cells) gets fewer,
///   broader gullies rather than aliased ones. Five octaves on a fixed circle of radius 6
///   would reach 26 m across the slope at mid-flank, below the 40 m cell, and alias into
///   hairline streaks.
/// - **Down the slope** the coordinate is `(k_i / ELONGATION) · ln(r / r_foot)`: `(θ, ln r)` is
///   conformal, so every octave is [`Gullies::ELONGATION`] times longer down the slope than
///   across it at every radius (ridges on a fixed circle: 6:1 at mid-flank, 30:1 near the
///   crater).
/// - The crest `|n|` is rounded (`√(n² + ε²)`, `ε` = two cells over the octave's unit, at
///   least 0.15), so gully floors are about two cells wide rather than one-node creases.
/// - The angle is warped by a slow noise (about ±0.1 rad, changing over the flank's length),
///   so gullies bend instead of running as straight rays.
/// - The envelope rises from the crater rim over 0.1 `r_foot`, is full down to 0.5 `r_foot`
///   and falls smoothly to zero at the foot (0.22 of full at 0.85 `r_foot`, where a
///   `sin(π r / r_foot)` envelope gives 0.45): the gentle concave apron is where real gullies end
///   in fans, so they fade out instead of running on as straight lines.
///
/// Measured on the default cone at 40 m (tests below, seeds 7, 1, 2): the share of the
/// cross-slope slope variance at wavelengths under three cells is at most 0.03 from
/// 0.15 `r_foot` outwards, and the correlation length is 2.9–6.5 times longer down the slope
/// than across it, at least 85 m across.
struct Gullies {
    octaves: Vec<Perlin>,
    warp: Perlin,
    r_crater: f64,
    r_foot: f64,
    /// Smallest noise unit (m) across the slope an octave may use: `MIN_CELLS` cells.
    min_unit: f64,
    cell: f64,
}

impl Gullies {
    const OCTAVES: usize = 5;
    /// Noise-space circle radius of the coarsest octave (one unit = `r / K0` m across).
    const K0: f64 = 3.0;
    /// Octave amplitude ratio.
    const PERSISTENCE: f64 = 0.7;
    /// Down-slope over cross-slope length of every octave.
    const ELONGATION: f64 = 4.0;
    /// An octave fades in from this many cells per noise unit, fully at twice as many.
    const MIN_CELLS: f64 = 5.0;
    /// Scale of the field: its standard deviation between 0.2 and 0.5 `r_foot` is then 0.40, so
    /// `ridge_amplitude` scales a field of that size.
    const GAIN: f64 = 1.3;
    /// Angular warp amplitude, in units of the coarsest octave's angular unit (1 / K0 rad).
    const WARP: f64 = 0.8;

    fn new(p: &StratovolcanoParams) -> Self {
        Self {
            octaves: (0..Self::OCTAVES as u32).map(|i| Perlin::new(p.seed.wrapping_add(10 + i))).collect(),
            warp: Perlin::new(p.seed.wrapping_add(3)),
            r_crater: p.crater_radius as f64,
            r_foot: p.cone_radius as f64,
            min_unit: Self::MIN_CELLS * p.cell,
            cell: p.cell,
        }
    }

    /// The field at world `(x, z)`, about [−1, 1]; 0 in the crater and beyond 0.9 `r_foot`.
    fn at(&self, x: f64, z: f64) -> f64 {
        let r = (x * x + z * z).sqrt();
        let rho = r / self.r_foot;
        let envelope = smoothstep((r - self.r_crater) / (0.1 * self.r_foot)) * smoothstep((1.0 - rho) / 0.5);
        if envelope <= 0.0 {
            return 0.0;
        }
        let theta = z.atan2(x);
        let down = rho.ln();
        let wk = 0.5 * Self::K0;
        let warp = self.warp.get([
            wk * theta.cos() + 50.0,
            wk * theta.sin() + 50.0,
            0.5 * wk / Self::ELONGATION * down,
        ]);
        let theta = theta + Self::WARP * warp / Self::K0;
        let (c, s) = (theta.cos(), theta.sin());
        let (mut sum, mut norm, mut weight, mut amplitude) = (0.0, 0.0, 1.0, 1.0);
        for (i, octave) in self.octaves.iter().enumerate() {
            let k = Self::K0 * (1u32 << i) as f64;
            let unit = r / k;
            let fade = smoothstep((unit - self.min_unit) / self.min_unit);
            if fade <= 0.0 {
                // Finer octaves are finer still.
                break;
            }
            let n = octave.get([k * c, k * s, k / Self::ELONGATION * down]);
            let eps = (2.0 * self.cell / unit).max(0.15);
            let crest = 1.0 - (n * n + eps * eps).sqrt();
            let signal = crest * crest * weight;
            weight = fade * (2.0 * signal).clamp(0.0, 1.0) + (1.0 - fade) * weight;
            sum += amplitude * fade * signal;
            norm += amplitude * fade;
            amplitude *= Self::PERSISTENCE;
        }
        if norm <= 0.0 {
            return 0.0;
        }
        // Mean of the active octaves mapped to [−1, 1]; a fading-in coarsest octave (norm < 1)
        // fades the field with it.
        // Ridges of the octave sum are the gully floors: sign flipped.
        -Self::GAIN * envelope * (2.0 * sum / norm - 1.0) * norm.min(1.0)
    }
}

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
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

    /// A 12.8 km square at the default 40 m cell and cone, without the rolling hills, so that
    /// on the flank the heights minus the plain and the cone are the gully field alone.
    fn flank(seed: u32) -> (StratovolcanoParams, Grid2<f32>) {
        let p = StratovolcanoParams { resolution: 320, hills_amplitude: 0.0, seed, ..Default::default() };
        let t = p.generate().unwrap();
        let mut g = t.heights().clone();
        for j in 0..g.ny() {
            for i in 0..g.nx() {
                let q = g.position(i, j);
                let r = (q.x as f64).hypot(q.y as f64);
                let v = g.get(i, j) as f64 - p.base_altitude as f64 - p.cone_profile(r);
                g.set(i, j, v as f32);
            }
        }
        (p, g)
    }

    /// The gully field on the ring of radius `r`, one sample a cell apart, mean removed.
    fn ring(g: &Grid2<f32>, r: f64) -> Vec<f64> {
        let m = (std::f64::consts::TAU * r / g.cell()).round() as usize;
        let v: Vec<f64> = (0..m)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / m as f64;
                g.sample(
                    bevy::math::Vec2::new((r * a.cos()) as f32, (r * a.sin()) as f32),
                    crate::Boundary::Clamp,
                ) as f64
            })
            .collect();
        let mean = v.iter().sum::<f64>() / m as f64;
        v.into_iter().map(|x| x - mean).collect()
    }

    /// Share of the cross-slope *slope* variance (what shading shows) on the ring of radius `r`
    /// carried by wavelengths shorter than three cells: the part a 40 m grid cannot draw as
    /// anything but hairlines.
    fn fine_slope_share(g: &Grid2<f32>, r: f64) -> f64 {
        let v = ring(g, r);
        let m = v.len();
        let f_fine = (std::f64::consts::TAU * r / (3.0 * g.cell())) as usize;
        let (mut fine, mut all) = (0.0, 0.0);
        for f in 1..=m / 2 {
            let (mut re, mut im) = (0.0, 0.0);
            for (k, x) in v.iter().enumerate() {
                let a = std::f64::consts::TAU * ((f * k) % m) as f64 / m as f64;
                re += x * a.cos();
                im += x * a.sin();
            }
            let slope_power = (re * re + im * im) * (f * f) as f64;
            all += slope_power;
            if f >= f_fine {
                fine += slope_power;
            }
        }
        fine / all
    }

    /// Lags (m) at which the gully field's correlation falls to one half across the slope
    /// (along rings) and down it (ring to ring), over rings within 400 m of radius `r`.
    fn correlation_lengths(g: &Grid2<f32>, r: f64) -> (f64, f64) {
        let cell = g.cell();
        let step = cell / 4.0;
        let corr = |down: bool, lag: usize| {
            let (mut aa, mut bb, mut ab) = (0.0, 0.0, 0.0);
            let mut rr = r - 400.0;
            while rr <= r + 400.0 {
                let a = ring(g, rr);
                let m = a.len();
                let b = if down { ring(g, rr + lag as f64 * step) } else { a.clone() };
                let rings = |k: usize| {
                    if down || m != b.len() {
                        return b[k * b.len() / m];
                    }
                    let (q, f) = (lag / 4, (lag % 4) as f64 / 4.0);
                    b[(k + q) % m] * (1.0 - f) + b[(k + q + 1) % m] * f
                };
                for (k, x) in a.iter().enumerate() {
                    let y = rings(k);
                    aa += x * x;
                    bb += y * y;
                    ab += x * y;
                }
                rr += cell;
            }
            ab / (aa * bb).sqrt()
        };
        let length = |down: bool| {
            let mut prev = 1.0;
            for lag in 1..=400 {
                let c = corr(down, lag);
                if c < 0.5 {
                    return (lag as f64 - (0.5 - c) / (prev - c)) * step;
                }
                prev = c;
            }
            400.0 * step
        };
        (length(false), length(true))
    }

    /// No cross-slope octave goes below the cell: one that did would alias node to node into
    /// hairline radial stripes on the flanks.
    #[test]
    fn gullies_are_resolved_across_the_slope() {
        let mut worst: f64 = 0.0;
        let mut worst_top: f64 = 0.0;
        for seed in [7, 1, 2] {
            let (p, g) = flank(seed);
            let rf = p.cone_radius as f64;
            let shares: Vec<f64> =
                [0.15, 0.2, 0.3, 0.5, 0.7].iter().map(|&x| fine_slope_share(&g, x * rf)).collect();
            println!(
                "seed {seed}: share of cross-slope slope variance under 3 cells at r/r_foot 0.15, 0.2, 0.3, 0.5, 0.7: {shares:.3?}"
            );
            worst_top = worst_top.max(shares[0]);
            worst = shares[1..].iter().fold(worst, |w, &s| w.max(s));
        }
        assert!(worst < 0.04, "cross-slope detail under 3 cells carries {worst:.3} of the slope variance");
        assert!(worst_top < 0.08, "near the summit detail under 3 cells carries {worst_top:.3}");
    }

    /// Gullies run down the slope, a few times longer than wide, but not as 10:1 streaks; and
    /// nowhere narrower than two cells.
    #[test]
    fn gullies_are_elongated_downslope_but_not_streaks() {
        let mut bad = Vec::new();
        for seed in [7, 1, 2] {
            let (p, g) = flank(seed);
            let rf = p.cone_radius as f64;
            for x in [0.15, 0.2, 0.3, 0.5] {
                let (across, down) = correlation_lengths(&g, x * rf);
                let ratio = down / across;
                println!(
                    "seed {seed} r/r_foot {x}: correlation length across {across:.0} m, down {down:.0} m, ratio {ratio:.2}"
                );
                if across < 2.0 * p.cell || (x >= 0.2 && !(2.5..7.5).contains(&ratio)) {
                    bad.push(format!("seed {seed} at {x}: {across:.0} m across, elongation {ratio:.2}"));
                }
            }
        }
        assert!(bad.is_empty(), "{bad:?}");
    }

    /// The gully relief has a standard deviation of 0.40 `ridge_amplitude` on the upper and
    /// middle flank, dies out on the apron and is nil on the plain.
    #[test]
    fn gully_relief_fades_out_on_the_apron() {
        for seed in [7, 1, 2] {
            let (p, g) = flank(seed);
            let rf = p.cone_radius as f64;
            let sd = |lo: f64, hi: f64| {
                let (mut n, mut s, mut s2) = (0.0, 0.0, 0.0);
                for j in 0..g.ny() {
                    for i in 0..g.nx() {
                        let q = g.position(i, j);
                        let rho = (q.x as f64).hypot(q.y as f64) / rf;
                        if (lo..hi).contains(&rho) {
                            let v = g.get(i, j) as f64;
                            n += 1.0;
                            s += v;
                            s2 += v * v;
                        }
                    }
                }
                ((s2 / n - (s / n).powi(2)).max(0.0)).sqrt() / p.ridge_amplitude as f64
            };
            let (mid, apron, plain) = (sd(0.2, 0.5), sd(0.8, 0.9), sd(1.0, 1.06));
            println!(
                "seed {seed}: relief sd / ridge_amplitude at 0.2–0.5 r_foot {mid:.3}, 0.8–0.9 {apron:.3}, beyond the foot {plain:.3}"
            );
            assert!((0.3..0.5).contains(&mid), "seed {seed}: mid-flank relief {mid:.3}");
            assert!(apron < 0.35 * mid, "seed {seed}: apron relief {apron:.3} against {mid:.3}");
            assert!(plain < 1e-3, "seed {seed}: relief {plain:.3} beyond the foot");
        }
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
