//! How ground looks: the colour of a point of terrain from its land-cover class, altitude, slope
//! and position. Plain functions over plain data, shared by the terrain mesh, its far ring
//! ([`super::horizon`]) and the deposit tint.
//!
//! The generator's classes are coarse (`Ground` covers the whole upper cone and every steep
//! slope), so the renderer splits them with rules a viewer expects of a stratovolcano: bare rock
//! on steep slopes; scoria (red-brown) and ash (grey) on the gentle ground of the upper cone, ash
//! more common towards the summit; vegetation on the lower slopes, drier and patchier with
//! height; snow above the generator's snow line giving way to rock where steep. Value noise at
//! three wavelengths (2.5 km, 600 m, 150 m) varies the hue and brightness so no slope reads as
//! one flat colour. These are look rules, not physics: no thesis equation applies (the thesis
//! renders terrain from a given heightmap and texture, §5.5).

use bevy::color::{LinearRgba, Srgba};
use bevy::prelude::*;
use volcano_core::{LandCover, Terrain};

/// Bare rock on steep slopes (sRGB): dark grey and a browner variant.
const ROCK_GREY: Srgba = Srgba::rgb(0.27, 0.26, 0.25);
const ROCK_BROWN: Srgba = Srgba::rgb(0.36, 0.30, 0.25);
/// Scoria (oxidised, red-brown) and fresh ash (grey) of the upper cone.
const SCORIA: Srgba = Srgba::rgb(0.37, 0.27, 0.21);
const ASH: Srgba = Srgba::rgb(0.46, 0.45, 0.43);
/// Bare soil of gentle low ground without vegetation.
const SOIL: Srgba = Srgba::rgb(0.40, 0.35, 0.28);
/// Vegetation, lush (low, wet) and dry (higher, sparser).
const VEG_LUSH: Srgba = Srgba::rgb(0.20, 0.31, 0.12);
const VEG_DRY: Srgba = Srgba::rgb(0.31, 0.34, 0.17);
const SNOW: Srgba = Srgba::rgb(0.93, 0.94, 0.97);
const WATER_DEEP: Srgba = Srgba::rgb(0.06, 0.16, 0.30);
const WATER_SHALLOW: Srgba = Srgba::rgb(0.10, 0.25, 0.36);

/// A point of ground to colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundSample {
    /// Land-cover class.
    pub cover: LandCover,
    /// World position `(x, z)`, metres.
    pub position: Vec2,
    /// Altitude, metres.
    pub altitude: f32,
    /// Unit surface normal (y up).
    pub normal: Vec3,
    /// Distance to the neighbouring vertices, metres: noise finer than about twice this is
    /// faded to its mean (it would alias into streaks between vertices).
    pub footprint: f32,
}

/// The altitude range the rules are relative to: "near the summit" is near `high`.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct Relief {
    /// Lowest land (or the sea level, if higher), metres.
    pub low: f32,
    /// Highest node, metres.
    pub high: f32,
}

impl Relief {
    /// The relief of `terrain`: from its lowest node above the sea (or the sea level) to its
    /// highest node. NaN heights are skipped.
    pub fn of(terrain: &Terrain) -> Self {
        let sea = terrain.sea_level();
        let (mut low, mut high) = (f32::INFINITY, f32::NEG_INFINITY);
        for &h in terrain.heights().data() {
            if h.is_finite() {
                low = low.min(h.max(sea));
                high = high.max(h);
            }
        }
        if low > high { Self { low: 0.0, high: 0.0 } } else { Self { low, high } }
    }

    /// Where `altitude` sits in the range, 0 (lowest) to 1 (summit); 0 on a flat terrain.
    pub fn fraction(&self, altitude: f32) -> f32 {
        let span = self.high - self.low;
        if span < 1.0 || !altitude.is_finite() { 0.0 } else { ((altitude - self.low) / span).clamp(0.0, 1.0) }
    }
}

/// Linear colour of a point of ground (see the module docs for the rules).
pub fn ground_color(s: GroundSample, relief: Relief) -> LinearRgba {
    let (p, fp) = (s.position, s.footprint);
    let broad = octave(p, 2500.0, 1, fp);
    let mid = octave(p, 600.0, 2, fp);
    let fine = octave(p, 150.0, 3, fp);
    // 0 on flat ground, 0.29 at 45°.
    let slope = (1.0 - s.normal.y.clamp(0.0, 1.0)).clamp(0.0, 1.0);
    let rel = relief.fraction(s.altitude);
    // Rock from ~25° to ~40°, the threshold shifting a little with the noise.
    let steep = smoothstep(0.08, 0.22, slope + 0.04 * (mid - 0.5));
    let rock = mix(lin(ROCK_GREY), lin(ROCK_BROWN), broad);
    // Scoria or ash: ash more common towards the summit.
    let cone = mix(lin(SCORIA), lin(ASH), smoothstep(0.25, 0.65, 0.6 * mid + 0.7 * rel - 0.1));
    let bare = mix(lin(SOIL), cone, smoothstep(0.25, 0.55, rel));
    let base = match s.cover {
        LandCover::Water => return mix(lin(WATER_DEEP), lin(WATER_SHALLOW), 0.6 * broad + 0.4 * fine),
        LandCover::Snow => mix(lin(SNOW), rock, steep),
        LandCover::Ground => mix(bare, rock, steep),
        LandCover::Vegetation => {
            let veg = mix(lin(VEG_LUSH), lin(VEG_DRY), smoothstep(0.3, 0.9, 0.6 * broad + 0.5 * rel));
            // Sparser with height: bare patches show through from a third of the relief up.
            let patchy = smoothstep(0.3, 0.7, rel + 0.5 * (mid - 0.5));
            mix(mix(veg, bare, patchy), rock, steep)
        }
    };
    // Brightness varies ±12 % at the finest scale; steep faces darken (they read under flat light).
    let shade = (0.88 + 0.24 * fine) * (1.0 - 0.3 * smoothstep(0.0, 0.35, slope));
    LinearRgba::rgb(base.red * shade, base.green * shade, base.blue * shade)
}

/// [`value_noise`] faded to its mean 0.5 where vertices `footprint` metres apart cannot show it
/// (from a quarter to half the wavelength).
fn octave(p: Vec2, wavelength: f32, seed: u32, footprint: f32) -> f32 {
    let keep = 1.0 - smoothstep(0.25 * wavelength, 0.5 * wavelength, footprint);
    if keep <= 0.0 { 0.5 } else { 0.5 + (value_noise(p, wavelength, seed) - 0.5) * keep }
}

fn lin(c: Srgba) -> LinearRgba {
    LinearRgba::from(c)
}

/// Smooth value noise in [0, 1) over the plane: random values on a square lattice of spacing
/// `wavelength` metres, blended with a smoothstep. Deterministic (a hash of the lattice point
/// and `seed`), the same on every platform.
pub fn value_noise(p: Vec2, wavelength: f32, seed: u32) -> f32 {
    let q = p / wavelength.max(1e-3);
    if !q.is_finite() {
        return 0.5;
    }
    let f = q.floor();
    let t = q - f;
    let (ix, iz) = (f.x as i32, f.y as i32);
    let (u, v) = (t.x * t.x * (3.0 - 2.0 * t.x), t.y * t.y * (3.0 - 2.0 * t.y));
    let h = |dx: i32, dz: i32| lattice_hash(ix.wrapping_add(dx), iz.wrapping_add(dz), seed);
    let a = h(0, 0) + (h(1, 0) - h(0, 0)) * u;
    let b = h(0, 1) + (h(1, 1) - h(0, 1)) * u;
    a + (b - a) * v
}

/// Hash of a lattice point to [0, 1) (also the lava crust's cell pattern).
pub(crate) fn lattice_hash(ix: i32, iz: i32, seed: u32) -> f32 {
    let mut h = (ix as u32).wrapping_mul(0x8da6_b343)
        ^ (iz as u32).wrapping_mul(0xd816_3841)
        ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    (h >> 8) as f32 / 16_777_216.0
}

pub(crate) fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

pub(crate) fn mix(a: LinearRgba, b: LinearRgba, t: f32) -> LinearRgba {
    LinearRgba::rgb(
        a.red + (b.red - a.red) * t,
        a.green + (b.green - a.green) * t,
        a.blue + (b.blue - a.blue) * t,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const RELIEF: Relief = Relief { low: 200.0, high: 2700.0 };

    fn at(cover: LandCover, x: f32, altitude: f32, normal: Vec3) -> LinearRgba {
        ground_color(
            GroundSample { cover, position: Vec2::new(x, 1234.0), altitude, normal, footprint: 40.0 },
            RELIEF,
        )
    }

    fn steep() -> Vec3 {
        // 50°.
        Vec3::new(50f32.to_radians().sin(), 50f32.to_radians().cos(), 0.0)
    }

    /// Hue classes a viewer would name, checked over many positions (the noise must not break
    /// them anywhere).
    #[test]
    fn rock_where_steep_snow_where_high_vegetation_where_low_and_gentle() {
        for k in 0..200 {
            let x = k as f32 * 97.0;
            let low = at(LandCover::Vegetation, x, 300.0, Vec3::Y);
            assert!(low.green > low.red && low.green > 1.5 * low.blue, "low gentle ground is green: {low:?}");
            for cover in [LandCover::Vegetation, LandCover::Snow, LandCover::Ground] {
                let c = at(cover, x, 1500.0, steep());
                assert!(c.green <= c.red && c.blue <= c.red * 1.05, "steep {cover:?} is rock: {c:?}");
                assert!(c.red < 0.2, "steep {cover:?} is dark rock: {c:?}");
            }
            let snow = at(LandCover::Snow, x, 2600.0, Vec3::Y);
            assert!(snow.red > 0.6 && snow.blue > 0.6, "high gentle snow is white: {snow:?}");
            // Near the summit bare ground is scoria or ash: not green, brighter than rock.
            let top = at(LandCover::Ground, x, 2500.0, Vec3::new(0.2, 1.0, 0.0).normalize());
            assert!(top.green <= top.red, "summit ground is not green: {top:?}");
        }
    }

    /// The flank of the cone is not one flat colour: along a 5 km line of gentle `Ground` at
    /// one altitude, luminance and hue vary.
    #[test]
    fn a_flank_is_not_one_colour() {
        let n = Vec3::new(0.25, 1.0, 0.0).normalize();
        let cs: Vec<LinearRgba> =
            (0..100).map(|k| at(LandCover::Ground, k as f32 * 50.0, 2000.0, n)).collect();
        let lum: Vec<f32> = cs.iter().map(|c| c.red + c.green + c.blue).collect();
        let mean = lum.iter().sum::<f32>() / lum.len() as f32;
        let sd = (lum.iter().map(|l| (l - mean).powi(2)).sum::<f32>() / lum.len() as f32).sqrt();
        assert!(sd > 0.05 * mean, "luminance σ {sd} of mean {mean}");
        let ratio: Vec<f32> = cs.iter().map(|c| c.red / c.blue).collect();
        let (lo, hi) = ratio.iter().fold((f32::INFINITY, 0f32), |(a, b), &r| (a.min(r), b.max(r)));
        assert!(hi > 1.3 * lo, "red/blue from {lo} to {hi}: one hue");
    }

    /// Vertices kilometres apart get no metre-scale detail: the colour does not depend on the
    /// fine octaves (two points 75 m apart, half the finest wavelength, look the same).
    #[test]
    fn coarse_vertices_get_no_fine_noise() {
        let c = |x: f32, footprint: f32| {
            let s = GroundSample {
                cover: LandCover::Ground,
                position: Vec2::new(x, 0.0),
                altitude: 300.0,
                normal: Vec3::Y,
                footprint,
            };
            ground_color(s, RELIEF)
        };
        assert_ne!(c(0.0, 40.0), c(75.0, 40.0));
        let (a, b) = (c(0.0, 5000.0), c(75.0, 5000.0));
        assert!((a.red - b.red).abs() < 1e-6 && (a.blue - b.blue).abs() < 1e-6, "{a:?} vs {b:?}");
    }

    #[test]
    fn value_noise_is_smooth_bounded_and_deterministic() {
        let mut last = value_noise(Vec2::new(-900.0, -300.0), 100.0, 9);
        for k in 1..2000 {
            let p = Vec2::new(k as f32 * 1.3 - 900.0, k as f32 * 0.7 - 300.0);
            let v = value_noise(p, 100.0, 9);
            assert!((0.0..1.0).contains(&v), "{v}");
            assert!((v - last).abs() < 0.1, "jump {last} → {v} over 1.5 m");
            assert_eq!(v, value_noise(p, 100.0, 9));
            last = v;
        }
        assert_ne!(
            value_noise(Vec2::new(50.0, 50.0), 100.0, 1),
            value_noise(Vec2::new(50.0, 50.0), 100.0, 2)
        );
        assert_eq!(value_noise(Vec2::NAN, 100.0, 1), 0.5);
    }

    #[test]
    fn relief_spans_land_above_the_sea() {
        let mut t = Terrain::flat(3, 10.0, -50.0).unwrap();
        t.heights_mut().set(1, 1, 900.0);
        let r = Relief::of(&t);
        assert_eq!((r.low, r.high), (t.sea_level().max(-50.0), 900.0));
        assert_eq!(r.fraction(900.0), 1.0);
        assert_eq!(Relief { low: 5.0, high: 5.0 }.fraction(5.0), 0.0);
    }
}
