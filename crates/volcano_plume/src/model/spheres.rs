//! Multi-scale rotating spheres (thesis §3.5.1).
//!
//! - s1: `n` spheres of radius ≈ r/2 whose centres lie on the slice's vortex ring (radius r/2,
//!   in the slice plane), sizes jittered (uniform 0.5–1.5, normalised to mean 1, as the
//!   authors' prototype), a random angular offset, and a spin `Ω = v_s / r_s` about the ring
//!   tangent (the sphere's surface moves with the slice's speed at the column's outside).
//!   Our reading adds a radial jitter (default ±30 % of r/2, [`SphereParams::radial_jitter`]):
//!   with every centre at exactly r/2, the rims of successive slices nested as concentric
//!   circles wherever the column was seen along its axis (docs/physics/plume.md §4.3).
//! - s2, s3: *procedural*, not simulated. Child `k` of a parent sits at a pseudo-random point of
//!   the parent's surface derived from `(seed, parent id, k)` only, with radius ÷5 per level, and
//!   turns rigidly with its parent. Rendering and export enumerate them with
//!   [`detail_spheres`], so millions of them cost no memory.

use bevy::math::{DMat3, DQuat, DVec3};
use bevy::reflect::Reflect;
use rand::RngExt;
use serde::{Deserialize, Serialize};
use volcano_core::error::{ConfigError, in_range};

/// Sphere counts and jitter.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SphereParams {
    /// s1 spheres per slice (thesis: 6).
    pub s1_per_slice: u32,
    /// Size jitter: s1 radii scale by a uniform factor in `[1 − j, 1 + j]`, normalised to mean 1.
    pub size_jitter: f64,
    /// s2 spheres per s1 sphere (prototype: 200, slider to 500).
    pub s2_per_s1: u32,
    /// s3 spheres per s2 sphere (0 to skip the third scale).
    pub s3_per_s2: u32,
    /// Radial jitter: each s1 centre lies at r/2 times a factor in `[1 − j, 1 + j]` (0 = the
    /// thesis' ring). Taken from a hash of the sphere's ring angle, so it draws nothing from
    /// the slice's random stream.
    pub radial_jitter: f64,
}

impl Default for SphereParams {
    fn default() -> Self {
        Self { s1_per_slice: 6, size_jitter: 0.5, s2_per_s1: 200, s3_per_s2: 0, radial_jitter: 0.3 }
    }
}

impl SphereParams {
    /// Radius ratio between a sphere and its children (§3.5.1).
    pub const CHILD_RATIO: f64 = 0.2;

    /// Checks counts and jitter.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("s1_per_slice", self.s1_per_slice as f64, 1.0, 64.0)?;
        in_range("size_jitter", self.size_jitter, 0.0, 0.9)?;
        in_range("s2_per_s1", self.s2_per_s1 as f64, 0.0, 500.0)?;
        in_range("s3_per_s2", self.s3_per_s2 as f64, 0.0, 100.0)?;
        in_range("radial_jitter", self.radial_jitter, 0.0, 0.6)?;
        Ok(())
    }
}

/// An s1 sphere in its slice's frame (slice plane = local xy, local z = slice axis).
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct S1Sphere {
    /// Angle of the centre on the vortex ring (rad).
    pub ring_angle: f64,
    /// Size factor (mean 1 over the slice); radius = factor × r/2.
    pub size_factor: f64,
    /// Radial factor: the centre lies at factor × r/2 from the slice's axis.
    pub radial_factor: f64,
}

impl S1Sphere {
    /// Centre relative to the slice centre, in the slice frame, for slice size `r`.
    pub fn local_offset(&self, r: f64) -> DVec3 {
        DVec3::new(self.ring_angle.cos(), self.ring_angle.sin(), 0.0) * (0.5 * r * self.radial_factor)
    }
    /// Radius for slice size `r`.
    pub fn radius(&self, r: f64) -> f64 {
        self.size_factor * 0.5 * r
    }
    /// Unit tangent of the ring at this sphere (slice frame), the spin axis.
    pub fn spin_axis(&self) -> DVec3 {
        DVec3::new(-self.ring_angle.sin(), self.ring_angle.cos(), 0.0)
    }
    /// Angular speed `Ω = v / r_s` (rad/s) for slice speed `v` and size `r`.
    pub fn angular_speed(&self, speed: f64, r: f64) -> f64 {
        speed / self.radius(r).max(1e-9)
    }
}

/// The s1 spheres of one slice: evenly spaced on the ring after a random angular offset, with
/// jittered sizes normalised to mean 1, and radial factors hashed from the ring angles. `rng` is
/// the slice's own stream.
pub fn s1_ring(p: &SphereParams, rng: &mut impl rand::Rng) -> Vec<S1Sphere> {
    let n = p.s1_per_slice.max(1) as usize;
    let offset: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let j = p.size_jitter.clamp(0.0, 0.9);
    let raw: Vec<f64> =
        (0..n).map(|_| if j > 0.0 { rng.random_range(1.0 - j..=1.0 + j) } else { 1.0 }).collect();
    let mean = raw.iter().sum::<f64>() / n as f64;
    let radial = p.radial_jitter.clamp(0.0, 0.6);
    raw.iter()
        .enumerate()
        .map(|(i, s)| {
            let ring_angle = offset + std::f64::consts::TAU * i as f64 / n as f64;
            let bits = ring_angle.to_bits();
            let u = hash32(bits as u32 ^ hash32((bits >> 32) as u32)) as f64 / u32::MAX as f64;
            S1Sphere { ring_angle, size_factor: s / mean, radial_factor: 1.0 + radial * (2.0 * u - 1.0) }
        })
        .collect()
}

/// One procedural detail sphere in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetailSphere {
    /// Centre (world, m).
    pub center: DVec3,
    /// Radius (m).
    pub radius: f64,
    /// 2 for s2, 3 for s3.
    pub level: u8,
}

/// The 32-bit hash both enumerations use (this CPU reference and the renderer's WGSL, which
/// has no portable 64-bit integer): the PCG-RXS-M-XS permutation as a stateless hash
/// ("pcg_hash", Jarzynski & Olano 2020, *Hash Functions for GPU Rendering*, JCGT 9(3)).
/// Written by hand: it is four integer operations, and the shader must repeat it bit for bit.
/// Counter-based, so child `k` of a parent is reached directly (the `rand` generators are
/// sequential streams).
#[inline]
pub fn hash32(x: u32) -> u32 {
    let state = x.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The 32-bit key of one parent sphere: the volcano's seed and the parent's id, both 64-bit,
/// folded word by word through [`hash32`]. Computed on the CPU once per parent and frame (the
/// renderer uploads it); the children derive from it with 32-bit arithmetic only.
pub fn parent_key(seed: u64, parent_id: u64) -> u32 {
    [(seed >> 32) as u32, parent_id as u32, (parent_id >> 32) as u32]
        .into_iter()
        .fold(hash32(seed as u32), |h, w| hash32(h ^ w))
}

/// Multiplier between consecutive children's keys (2³²/φ, odd), so children `k` and `k + 1`
/// hash unrelated words.
pub const CHILD_STRIDE: u32 = 0x9e37_79b9;

/// Key of the s2 child `k` of a parent with key `parent`.
#[inline]
pub fn s2_key(parent: u32, k: u32) -> u32 {
    hash32(parent ^ k.wrapping_mul(CHILD_STRIDE))
}

/// Key of the s3 child `j` of an s2 sphere with key `s2`.
#[inline]
pub fn s3_key(s2: u32, j: u32) -> u32 {
    hash32(s2 ^ j.wrapping_add(1))
}

/// Directions on the unit sphere, quasi-uniform (Fibonacci lattice of 2¹⁴ points), indexed by
/// the top bits of a key: a table lookup instead of trigonometry per child keeps the CPU
/// enumeration cheap (≈10⁶ children per frame); the shader evaluates [`lattice_direction`].
pub const DIRECTION_BITS: u32 = 14;

/// The golden-angle turn as a 32-bit fraction of a full turn: (3 − √5)/2 · 2³² (= 2³² − 2³²/φ).
/// Multiplying it by the point index with wrapping gives the azimuth modulo one turn exactly,
/// so f32 (shader) and f64 (here) agree to rounding instead of losing precision at i ≈ 16,000.
pub const GOLDEN_TURN: u32 = 0x61c8_8647;

/// Point `i` (`< 2^DIRECTION_BITS`) of the Fibonacci lattice: `z = 1 − (2i + 1)/N`, azimuth
/// `i` golden-angle turns (its top 24 bits, exact in f32).
pub fn lattice_direction(i: u32) -> DVec3 {
    let n = (1u32 << DIRECTION_BITS) as f64;
    let z = 1.0 - (2 * i + 1) as f64 / n;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let turn = (i.wrapping_mul(GOLDEN_TURN) >> 8) as f64 / (1u32 << 24) as f64;
    let phi = std::f64::consts::TAU * turn;
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// Lattice index chosen by a key (its top [`DIRECTION_BITS`] bits).
#[inline]
pub fn direction_index(key: u32) -> u32 {
    key >> (32 - DIRECTION_BITS)
}

fn directions() -> &'static [DVec3] {
    static TABLE: std::sync::OnceLock<Vec<DVec3>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| (0..1u32 << DIRECTION_BITS).map(lattice_direction).collect())
}

/// Enumerates the s2 (and s3) children of one s1 sphere: centre `center`, radius `radius`,
/// current orientation `rotation` (children turn rigidly with it), identified by
/// `(seed, parent_id)`. Deterministic: the same inputs give the same spheres in the same order:
/// s2 child `k` (centre on the parent's surface at the lattice direction of
/// [`s2_key`]`(key, k)`, turned by the parent), then its s3 children `j` (on the s2 surface,
/// direction of [`s3_key`]). The renderer's vertex shader (`volcano_render`, `ash.wgsl`)
/// repeats this for instance `k·(1 + n₃) + j` and is tested against it.
pub fn detail_spheres(
    p: &SphereParams,
    seed: u64,
    parent_id: u64,
    center: DVec3,
    radius: f64,
    rotation: DQuat,
) -> impl Iterator<Item = DetailSphere> {
    let base = parent_key(seed, parent_id);
    let (n2, n3) = (p.s2_per_s1, p.s3_per_s2);
    let r2 = radius * SphereParams::CHILD_RATIO;
    let r3 = r2 * SphereParams::CHILD_RATIO;
    let table = directions();
    // Children turn rigidly with the parent: one rotation matrix per parent.
    let m = DMat3::from_quat(rotation);
    (0..n2).flat_map(move |k| {
        let key2 = s2_key(base, k);
        let c2 = center + m * (table[direction_index(key2) as usize] * radius);
        let s2 = DetailSphere { center: c2, radius: r2, level: 2 };
        std::iter::once(s2).chain((0..n3).map(move |j| {
            let c3 = c2 + m * (table[direction_index(s3_key(key2, j)) as usize] * r2);
            DetailSphere { center: c3, radius: r3, level: 3 }
        }))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_core::rng::derive_stream;

    #[test]
    fn s1_ring_follows_parameters() {
        let p = SphereParams { s1_per_slice: 6, size_jitter: 0.5, ..Default::default() };
        let mut rng = derive_stream(7, 1);
        let ring = s1_ring(&p, &mut rng);
        assert_eq!(ring.len(), 6);
        let mean = ring.iter().map(|s| s.size_factor).sum::<f64>() / 6.0;
        assert!((mean - 1.0).abs() < 1e-12);
        assert!(ring.iter().all(|s| s.size_factor > 0.5 / 1.5 - 1e-9 && s.size_factor < 1.5 / 0.5 + 1e-9));
        let r = 80.0;
        let radii: Vec<f64> = ring.iter().map(|s| s.local_offset(r).length()).collect();
        assert!(
            radii.iter().all(|&d| (28.0 - 1e-9..=52.0 + 1e-9).contains(&d)),
            "centres within ±30 % of r/2: {radii:?}"
        );
        let spread =
            radii.iter().cloned().fold(f64::MIN, f64::max) - radii.iter().cloned().fold(f64::MAX, f64::min);
        assert!(spread > 4.0, "radial jitter barely acts: {radii:?}");
        let exact = s1_ring(&SphereParams { radial_jitter: 0.0, ..p.clone() }, &mut derive_stream(7, 1));
        for s in &exact {
            assert!(
                (s.local_offset(r).length() - 40.0).abs() < 1e-9,
                "without jitter, centres on the ring of radius r/2"
            );
        }
        for bad in [0.7, -0.1, f64::NAN] {
            assert!(SphereParams { radial_jitter: bad, ..p.clone() }.validate().is_err(), "{bad} accepted");
        }
        // The jitter draws nothing from the stream: the same angles and sizes either way.
        for (a, b) in ring.iter().zip(&exact) {
            assert_eq!((a.ring_angle, a.size_factor), (b.ring_angle, b.size_factor));
        }
        for s in &ring {
            assert!(s.spin_axis().dot(s.local_offset(r)).abs() < 1e-9, "spin about the ring tangent");
            assert!((s.angular_speed(100.0, r) - 100.0 / s.radius(r)).abs() < 1e-9);
        }
        // Same stream → same ring; another stream → another offset.
        let again = s1_ring(&p, &mut derive_stream(7, 1));
        assert_eq!(ring, again);
        assert_ne!(ring, s1_ring(&p, &mut derive_stream(7, 2)));
    }

    #[test]
    fn hash32_is_the_published_pcg_hash() {
        // Reference values from an independent implementation of Jarzynski & Olano's pcg_hash
        // (Python, 32-bit masks); the WGSL copy is held to the same values through the
        // renderer's readback test.
        assert_eq!(hash32(0), 0x07bb_2fe2);
        assert_eq!(hash32(1), 0xa8be_ea3c);
        assert_eq!(hash32(0xdead_beef), 0x6729_9972);
    }

    #[test]
    fn lattice_directions_are_unit_and_spread() {
        let n = 1u32 << DIRECTION_BITS;
        let mut mean = DVec3::ZERO;
        for i in 0..n {
            let d = lattice_direction(i);
            assert!((d.length() - 1.0).abs() < 1e-12, "{i}: {d}");
            mean += d;
        }
        assert!((mean / n as f64).length() < 1e-3, "mean {mean}");
        // Neighbours in index are a golden-angle turn apart in azimuth (≈137.5°).
        let (a, b) = (lattice_direction(4000), lattice_direction(4001));
        let turn = (b.y.atan2(b.x) - a.y.atan2(a.x)).rem_euclid(std::f64::consts::TAU);
        assert!((turn.to_degrees() - 137.507_764).abs() < 1e-3, "{}", turn.to_degrees());
        // Keys pick directions by their top bits, so all of the lattice is reachable.
        assert_eq!(direction_index(u32::MAX), n - 1);
        assert_eq!(direction_index(0), 0);
    }

    #[test]
    fn detail_spheres_are_deterministic_and_sized() {
        let p = SphereParams { s2_per_s1: 50, s3_per_s2: 4, ..Default::default() };
        let c = DVec3::new(10.0, 2000.0, -5.0);
        let rot = DQuat::from_rotation_y(0.7);
        let a: Vec<_> = detail_spheres(&p, 3, 99, c, 25.0, rot).collect();
        let b: Vec<_> = detail_spheres(&p, 3, 99, c, 25.0, rot).collect();
        assert_eq!(a, b);
        assert_eq!(a.len(), 50 * (1 + 4));
        assert_eq!(a.iter().filter(|s| s.level == 2).count(), 50);
        for s in a.iter().filter(|s| s.level == 2) {
            assert!((s.radius - 5.0).abs() < 1e-12);
            assert!(((s.center - c).length() - 25.0).abs() < 1e-9, "s2 centres on the parent surface");
        }
        assert!(a.iter().filter(|s| s.level == 3).all(|s| (s.radius - 1.0).abs() < 1e-12));
        let other: Vec<_> = detail_spheres(&p, 3, 100, c, 25.0, rot).collect();
        assert_ne!(a, other);
        // Rigid attachment: rotating the parent rotates every child about its centre.
        let turned: Vec<_> = detail_spheres(&p, 3, 99, c, 25.0, DQuat::from_rotation_y(0.2) * rot).collect();
        for (x, y) in a.iter().zip(&turned) {
            let expect = c + DQuat::from_rotation_y(0.2) * (x.center - c);
            assert!((y.center - expect).length() < 1e-9);
        }
        // Roughly uniform on the sphere: the mean direction of many children is near zero.
        let many = SphereParams { s2_per_s1: 500, ..Default::default() };
        let mean: DVec3 =
            detail_spheres(&many, 1, 1, DVec3::ZERO, 1.0, DQuat::IDENTITY).map(|s| s.center).sum::<DVec3>()
                / 500.0;
        assert!(mean.length() < 0.1, "mean direction {mean}");
    }
}
