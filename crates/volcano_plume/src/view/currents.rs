//! The ash cloud a pyroclastic current carries above itself, as the renderer draws it
//! (docs/RENDERING.md (the ash), "Pyroclastic currents").
//!
//! The model's particles are the current's dense basal part (thesis §3.6: s2-sized spheres that
//! follow the terrain). A real current also carries a dilute, turbulent ash cloud over that
//! underflow, hundreds of metres thick, swollen into a billowing head at its front, and ash that
//! lifts off its top where the flow turns buoyant (co-ignimbrite ash). The thesis renders none of
//! these; this module derives them, for the view only, from what each particle already has:
//! its speed sets the cloud's thickness by the front condition of a gravity current, its place
//! in its sector of the runout says whether it is in the head, and its buoyancy flag whether its
//! ash lifts. Nothing here feeds back into the model, its budgets or its deposit.
//!
//! Each derived cloud is a [`ParentSphere`] with `cloud` set: a smoke puff without detail
//! spheres, lit and shadowed like the column's puffs (so the clouds also shade the dark
//! underflow beneath them).

use bevy::prelude::*;
use thiserror::Error;

use super::ParentSphere;

/// Standard gravity (m/s²).
const G: f64 = 9.81;
/// Air density at sea level (kg/m³) and its isothermal scale height (m), for the clouds' own
/// density (they are only slightly denser or lighter than the air around them).
const AIR_DENSITY: f32 = 1.225;
const SCALE_HEIGHT: f32 = 8_400.0;

/// Bit set in a cloud's [`ParentSphere::id`] (the particle's own id never reaches it: slice
/// index << 16 | k), so clouds keep ids of their own and a stable texture variant.
pub const CLOUD_ID_BIT: u64 = 1 << 62;

/// How the clouds over pyroclastic currents are derived (a [`Resource`], editable live).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct CurrentCloudSettings {
    /// Whether the clouds are drawn at all (off: only the model's particles).
    pub enabled: bool,
    /// Densimetric Froude number of the current's front, `Fr` in [`surge_thickness`]
    /// (≈ 1.2 for a current much thinner than the air above it).
    pub froude: f64,
    /// Density excess of the dilute cloud over the air, `Δρ/ρ` in [`surge_thickness`].
    pub density_excess: f64,
    /// Thickness bounds (m): at least the particle's diameter, at most this.
    pub max_thickness_m: f64,
    /// Azimuth sectors around the vent in which the front (the farthest particle) is found.
    pub sectors: u32,
    /// Outer fraction of each sector's runout that is the head, in (0, 1).
    pub head_fraction: f64,
    /// How much larger a cloud at the very front is than one in the body (1 = twice).
    pub head_swell: f64,
    /// Height of lifting (buoyant) ash above its current, in cloud thicknesses.
    pub lift_height: f64,
    /// One particle in `every` carries a cloud (by a hash of its id; the others' clouds are
    /// covered by the larger puffs of their neighbours): 1 draws one per particle.
    pub every: u32,
}

impl Default for CurrentCloudSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            froude: 1.19,
            density_excess: 0.3,
            max_thickness_m: 300.0,
            sectors: 64,
            head_fraction: 0.2,
            head_swell: 1.2,
            lift_height: 1.5,
            every: 4,
        }
    }
}

/// A rejected [`CurrentCloudSettings`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CurrentCloudError {
    /// A value outside its range (name, value, range).
    #[error("current clouds: {0} = {1} must be {2}")]
    OutOfRange(&'static str, f64, &'static str),
}

impl CurrentCloudSettings {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), CurrentCloudError> {
        let positive = |name, v: f64| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(CurrentCloudError::OutOfRange(name, v, "> 0")) }
        };
        let non_negative = |name, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(CurrentCloudError::OutOfRange(name, v, "≥ 0"))
            }
        };
        positive("froude", self.froude)?;
        positive("density_excess", self.density_excess)?;
        positive("max_thickness_m", self.max_thickness_m)?;
        non_negative("head_swell", self.head_swell)?;
        non_negative("lift_height", self.lift_height)?;
        if !(self.head_fraction > 0.0 && self.head_fraction < 1.0) {
            return Err(CurrentCloudError::OutOfRange("head_fraction", self.head_fraction, "in (0, 1)"));
        }
        if self.sectors == 0 || self.sectors > 4096 {
            return Err(CurrentCloudError::OutOfRange("sectors", self.sectors as f64, "in 1 ..= 4096"));
        }
        if self.every == 0 {
            return Err(CurrentCloudError::OutOfRange("every", 0.0, "≥ 1"));
        }
        Ok(())
    }
}

/// Thickness (m) of a gravity current moving at `speed` (m/s), from its front condition
/// `u = Fr √(g′ h)` with the reduced gravity `g′ = g Δρ/ρ` (Benjamin 1968, J. Fluid Mech. 31;
/// Huppert & Simpson 1980 for Fr ≈ 1.2): `h = u² / (Fr² g′)`. Not a thesis equation: the thesis
/// draws no cloud over its currents. A 20 m/s current of ash 10 % denser than the air carries a
/// ≈ 290 m cloud, a 5 m/s one ≈ 18 m, the order of observed ash-cloud surges.
pub fn surge_thickness(speed: f64, froude: f64, density_excess: f64) -> f64 {
    speed * speed / (froude * froude * G * density_excess)
}

/// One particle of a current, as [`current_clouds`] needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlowSample {
    /// The particle's [`ParentSphere::id`].
    pub id: u64,
    /// Index of its eruption in the view list.
    pub eruption: usize,
    /// Centre (world, m, y up).
    pub center: Vec3,
    /// Radius (m).
    pub radius: f32,
    /// Speed (m/s).
    pub speed: f32,
    /// Density (kg/m³).
    pub density: f32,
    /// Lighter than the air after its last step.
    pub buoyant: bool,
    /// Its vent (world).
    pub vent: Vec3,
}

/// Where a particle stands in its current: 0 in the body, rising to 1 at the front of its
/// azimuth sector around the vent (`head_fraction` of the sector's runout).
fn headness(d: f32, front: f32, head_fraction: f64) -> f32 {
    if front <= 0.0 {
        return 0.0;
    }
    let start = 1.0 - head_fraction as f32;
    ((d / front - start) / (1.0 - start)).clamp(0.0, 1.0)
}

fn sector_of(s: &FlowSample, sectors: u32) -> (usize, f32) {
    let d = Vec2::new(s.center.x - s.vent.x, s.center.z - s.vent.z);
    let turn = (d.y.atan2(d.x) / std::f32::consts::TAU).rem_euclid(1.0);
    let k = ((turn * sectors as f32) as u32).min(sectors - 1);
    (s.eruption * sectors as usize + k as usize, d.length())
}

/// The clouds over the currents of `samples`, appended to `out` in the samples' order (so the
/// result does not depend on anything but the samples). Invalid settings draw nothing and are
/// the error; a sample with a non-finite value is skipped. A cloud's density is the air's (sea level, scale height
/// 8.4 km) times `1 ± Δρ/ρ` (denser while it runs, lighter where it lifts): it sets the shade,
/// so the clouds are lighter than the dense underflow but darker than ash diluted aloft.
pub fn current_clouds(
    samples: &[FlowSample],
    settings: &CurrentCloudSettings,
    out: &mut Vec<ParentSphere>,
) -> Result<(), CurrentCloudError> {
    if !settings.enabled {
        return Ok(());
    }
    settings.validate()?;
    let finite = |s: &FlowSample| {
        s.center.is_finite()
            && s.vent.is_finite()
            && s.radius.is_finite()
            && s.radius > 0.0
            && s.speed.is_finite()
    };
    // The front of each (eruption, sector): its farthest particle from the vent.
    let eruptions = samples.iter().map(|s| s.eruption + 1).max().unwrap_or(0);
    let mut front = vec![0.0f32; eruptions * settings.sectors as usize];
    for s in samples.iter().filter(|s| finite(s)) {
        let (k, d) = sector_of(s, settings.sectors);
        front[k] = front[k].max(d);
    }
    let cube_root_every = (settings.every as f32).cbrt();
    for s in samples.iter().filter(|s| finite(s)) {
        if !super::mix32(s.id).is_multiple_of(settings.every) {
            continue;
        }
        let (k, d) = sector_of(s, settings.sectors);
        let head = headness(d, front[k], settings.head_fraction);
        let diameter = 2.0 * s.radius as f64;
        let h = surge_thickness(s.speed as f64, settings.froude, settings.density_excess)
            .clamp(diameter, settings.max_thickness_m.max(diameter)) as f32;
        // Fewer, larger puffs for the same cover when not every particle carries one.
        let radius = 0.5 * h * (1.0 + settings.head_swell as f32 * head) * cube_root_every;
        let lift = if s.buoyant { settings.lift_height as f32 * h } else { 0.0 };
        // Denser than the air by Δρ/ρ while it runs, lighter by as much where it lifts.
        let air = AIR_DENSITY * (-s.center.y.max(0.0) / SCALE_HEIGHT).exp();
        let excess = settings.density_excess as f32 * if s.buoyant { -1.0 } else { 1.0 };
        let density = air * (1.0 + excess).max(0.05);
        out.push(ParentSphere {
            id: s.id | CLOUD_ID_BIT,
            eruption: s.eruption,
            center: s.center + Vec3::Y * (0.8 * radius + lift),
            radius,
            rotation: Quat::IDENTITY,
            density,
            umbrella: false,
            flow: false,
            cloud: true,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(id: u64, x: f32, speed: f32, buoyant: bool) -> FlowSample {
        FlowSample {
            id,
            eruption: 0,
            center: Vec3::new(x, 100.0, 0.0),
            radius: 10.0,
            speed,
            density: 4.0,
            buoyant,
            vent: Vec3::ZERO,
        }
    }

    fn every_one() -> CurrentCloudSettings {
        CurrentCloudSettings { every: 1, ..Default::default() }
    }

    #[test]
    fn a_faster_current_carries_a_thicker_cloud() {
        // The front condition: thickness grows with the square of the speed.
        let h5 = surge_thickness(5.0, 1.19, 0.1);
        let h20 = surge_thickness(20.0, 1.19, 0.1);
        assert!((h20 / h5 - 16.0).abs() < 1e-9);
        // u = Fr √(g′h) holds for the returned h.
        assert!((1.19 * (9.81 * 0.1 * h20).sqrt() - 20.0).abs() < 1e-9);
        assert!((250.0..330.0).contains(&h20), "20 m/s: {h20} m");
        // And with a lighter cloud (smaller density excess), for the same speed.
        assert!(surge_thickness(20.0, 1.19, 0.05) > h20);
    }

    #[test]
    fn the_front_of_each_sector_swells_into_a_head() {
        // One sector: particles at 500 .. 3,000 m from the vent at the same speed; the farthest
        // are in the head and get larger clouds than the body.
        let samples: Vec<FlowSample> =
            (0..6).map(|i| sample(i, 500.0 + 500.0 * i as f32, 15.0, false)).collect();
        let mut out = Vec::new();
        current_clouds(&samples, &every_one(), &mut out).unwrap();
        assert_eq!(out.len(), 6);
        let body = out[0].radius;
        assert_eq!(out[1].radius, body, "inside the body");
        assert!(out[5].radius > 1.9 * body, "front {} vs body {body}", out[5].radius);
        // Another sector has its own front: a lone particle at 600 m is its own head.
        let mut other = samples.clone();
        other.push(FlowSample { center: Vec3::new(0.0, 100.0, 600.0), ..sample(9, 0.0, 15.0, false) });
        out.clear();
        current_clouds(&other, &every_one(), &mut out).unwrap();
        assert!(out[6].radius > 1.9 * body);
    }

    #[test]
    fn buoyant_ash_lifts_above_its_current_and_is_lighter() {
        let mut out = Vec::new();
        current_clouds(
            &[sample(1, 500.0, 15.0, false), sample(2, 500.0, 15.0, true)],
            &every_one(),
            &mut out,
        )
        .unwrap();
        let (ground, lifting) = (out[0], out[1]);
        assert!(lifting.center.y > ground.center.y + ground.radius, "{lifting:?} vs {ground:?}");
        assert!(lifting.density < ground.density);
        // The running cloud is denser than the air, the lifting ash lighter.
        let air = 1.225 * (-100.0f32 / 8_400.0).exp();
        assert!(
            ground.density > air && lifting.density < air,
            "{} / {} vs air {air}",
            ground.density,
            lifting.density
        );
        // Both sit above their particle and are clouds without detail spheres.
        assert!(ground.center.y > 100.0 && ground.cloud && !ground.flow);
        assert_eq!(ground.id & CLOUD_ID_BIT, CLOUD_ID_BIT);
    }

    #[test]
    fn thinning_keeps_about_one_in_every_and_grows_the_puffs() {
        let samples: Vec<FlowSample> = (0..3_000).map(|i| sample(i, 100.0 + i as f32, 10.0, false)).collect();
        let mut all = Vec::new();
        current_clouds(&samples, &every_one(), &mut all).unwrap();
        let mut some = Vec::new();
        let settings = CurrentCloudSettings { every: 3, ..Default::default() };
        current_clouds(&samples, &settings, &mut some).unwrap();
        assert_eq!(all.len(), 3_000);
        assert!((900..1_100).contains(&some.len()), "{} of 3000", some.len());
        // Body clouds (same speed, not in the head): larger by ∛3.
        assert!((some[0].radius / all[0].radius - 3f32.cbrt()).abs() < 1e-5);
    }

    #[test]
    fn bad_samples_and_settings_draw_nothing_wrong() {
        let mut out = Vec::new();
        let bad = FlowSample { speed: f32::NAN, ..sample(1, 100.0, 1.0, false) };
        current_clouds(&[bad, sample(2, 200.0, 10.0, false)], &every_one(), &mut out).unwrap();
        assert_eq!(out.len(), 1);
        assert!(out.iter().all(|p| p.center.is_finite() && p.radius.is_finite() && p.radius > 0.0));
        for broken in [
            CurrentCloudSettings { froude: 0.0, ..Default::default() },
            CurrentCloudSettings { density_excess: f64::NAN, ..Default::default() },
            CurrentCloudSettings { head_fraction: 1.0, ..Default::default() },
            CurrentCloudSettings { sectors: 0, ..Default::default() },
            CurrentCloudSettings { every: 0, ..Default::default() },
        ] {
            assert!(broken.validate().is_err(), "{broken:?}");
            out.clear();
            assert!(current_clouds(&[sample(2, 200.0, 10.0, false)], &broken, &mut out).is_err());
            assert!(out.is_empty());
        }
        assert!(CurrentCloudSettings::default().validate().is_ok());
    }
}
