//! How much sun and sky reach each parent sphere: the ash between a parent and the light, from
//! a coarse density grid splatted from the parents every frame (docs/RENDERING.md, "How ash
//! is lit"). Engine-free: plain functions over [`ParentSphere`]s, tested with plain `#[test]`s
//! and measured by the plume benchmark with the rest of a frame's plain data; only packing the
//! result into the shader's 32-bit word is the renderer's (`volcano_render::plume::layout`).
//!
//! The grid is aligned with the light (its third axis points at it), so the optical depth from
//! every cell toward the light is one running sum per grid column, `O(cells)`. A parent reads
//! the optical depth at its light-facing surface, minus its own contribution (a sphere does not
//! shadow itself through the grid; the shader shades its own body with its normal). A cell's
//! density is capped at the densest parent reaching it: the parents overlap as samples of one
//! continuum, and summing their masses would make a column's head 20 times too opaque (dark
//! discs).

use bevy::prelude::*;

use super::ParentSphere;

mod depth;
use depth::DepthGrid;
use volcano_core::parallel::{Bands, par_map};

/// Parents looked up per task of [`light_parents`].
const PARENTS_PER_BAND: usize = 1_024;

/// Lighting inputs of the ash renderer (a resource, editable live through reflection).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct AshLightSettings {
    /// Direction toward the sun (world, y up; normalised on use). The renderer copies its
    /// first directional light here every frame.
    pub sun: Vec3,
    /// Extinction per kg/m³ of mixture (m²/kg). A rendering choice, not a measured value:
    /// the parents carry the mixture density, not the ash concentration, and the textbook
    /// value for 20 µm ash (`3 Q_ext / (4 ρ_p r) ≈ 29 m²/kg`, Q_ext ≈ 2) would make even the
    /// umbrella opaque at the grid's resolution.
    pub extinction: f32,
    /// Most grid cells per axis (the cell size follows from the column's extent).
    pub max_cells_per_axis: u32,
    /// Distance (m) from the vent at which its incandescent light on the ash has fallen to
    /// half ([`vent_light`]; > 0).
    pub vent_reach_m: f32,
    /// Compute the light on Bevy's `AsyncComputeTaskPool`: frames use the last light
    /// finished, matched to their parents, while the next one runs (`volcano_render`'s
    /// renderer, at the cadence of [`Self::refresh_ticks`]; [`light_parents`] itself always
    /// computes at once). Off: each light is computed on the main thread when it is due.
    pub off_thread: bool,
    /// Base ticks (`SimTick`) between two lights of the renderer (1..=1,000): a new light
    /// starts once this many ticks have passed since the last one started, or at once when
    /// the sun turns by more than [`Self::SUN_TURN_DEG`] or the grid or extinction change;
    /// frames in between carry the last light over to their parents. A light off the main
    /// thread is taken up `refresh_ticks` ticks or rendered frames after it started, whichever
    /// comes first, so it has that long to finish. The ash moves metres per tick against grid
    /// cells of tens to hundreds of metres: a light per frame bought nothing a viewer sees
    /// (docs/RENDERING.md, "How ash is lit"). 1 lights once per base tick.
    pub refresh_ticks: u32,
}

impl Default for AshLightSettings {
    fn default() -> Self {
        Self {
            sun: Vec3::new(-0.58, 0.57, 0.58),
            extinction: 0.003,
            max_cells_per_axis: 64,
            vent_reach_m: 500.0,
            off_thread: true,
            refresh_ticks: 3,
        }
    }
}

/// A rejected [`AshLightSettings`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AshLightError {
    /// The sun direction is zero or not finite.
    #[error("sun direction {0} is zero or not finite")]
    Sun(Vec3),
    /// The extinction is negative or not finite.
    #[error("extinction {0} m²/kg must be finite and ≥ 0")]
    Extinction(f32),
    /// The grid would have fewer than 2 or more than 256 cells per axis.
    #[error("max_cells_per_axis {0} must be in 2..=256")]
    Cells(u32),
    /// The vent's reach is not a positive finite distance.
    #[error("vent_reach_m {0} must be finite and > 0")]
    VentReach(f32),
    /// The refresh interval is 0 or more than 1,000 ticks.
    #[error("refresh_ticks {0} must be in 1..=1000")]
    RefreshTicks(u32),
}

impl AshLightSettings {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), AshLightError> {
        if !self.sun.is_finite() || self.sun.length_squared() < 1e-12 {
            return Err(AshLightError::Sun(self.sun));
        }
        if !self.extinction.is_finite() || self.extinction < 0.0 {
            return Err(AshLightError::Extinction(self.extinction));
        }
        if !(2..=256).contains(&self.max_cells_per_axis) {
            return Err(AshLightError::Cells(self.max_cells_per_axis));
        }
        if !self.vent_reach_m.is_finite() || self.vent_reach_m <= 0.0 {
            return Err(AshLightError::VentReach(self.vent_reach_m));
        }
        if !(1..=1_000).contains(&self.refresh_ticks) {
            return Err(AshLightError::RefreshTicks(self.refresh_ticks));
        }
        Ok(())
    }

    /// Largest turn of the sun (degrees) that does not start a new light at once.
    pub const SUN_TURN_DEG: f32 = 0.5;

    /// Whether a light computed with `other` is still this one's: the same grid and
    /// extinction and a sun within [`Self::SUN_TURN_DEG`] (the vent's reach and where the
    /// light runs do not change what [`light_parents`] computes).
    pub fn lights_like(&self, other: &Self) -> bool {
        let turn = self.sun.normalize_or_zero().dot(other.sun.normalize_or_zero());
        self.extinction == other.extinction
            && self.max_cells_per_axis == other.max_cells_per_axis
            && turn >= Self::SUN_TURN_DEG.to_radians().cos()
    }
}

/// Light reaching one parent, as transmittances in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct ParentLight {
    /// Sunlight reaching the parent's sun-facing surface, `exp(−τ_sun)`.
    pub sun: f32,
    /// Skylight from straight above, `exp(−τ_up)` (the ambient-occlusion term).
    pub sky: f32,
    /// Light from the incandescent vent, relative to a parent at the vent ([`vent_light`]).
    pub vent: f32,
}

impl ParentLight {
    /// Nothing in the way, no vent light.
    pub const CLEAR: Self = Self { sun: 1.0, sky: 1.0, vent: 0.0 };
}

/// Sun and sky transmittance of every parent (same order as `parents`), Beer–Lambert
/// `T = exp(−∫ κ ρ ds)` through the other parents (Bohren & Huffman 1983, §3.4), with `ρ` the
/// density of their union: overlapping parents do not stack their mass. Invalid
/// settings are the caller's to reject ([`AshLightSettings::validate`]); here they give
/// [`ParentLight::CLEAR`] for everyone.
pub fn light_parents(parents: &[ParentSphere], settings: &AshLightSettings) -> Vec<ParentLight> {
    if settings.validate().is_err() {
        return vec![ParentLight::CLEAR; parents.len()];
    }
    let n = settings.max_cells_per_axis as usize;
    // The two grids, then the parents in fixed bands, on the compute pool: each result is a
    // pure function of its inputs, so the light is the same on any number of threads.
    let towards = vec![settings.sun.normalize(), Vec3::Y];
    let mut grids = par_map(towards, |_, w| DepthGrid::build(parents, w, settings.extinction, n)).into_iter();
    let (sun, up) = (grids.next().flatten(), grids.next().flatten());
    let bands = Bands::of(PARENTS_PER_BAND).map_ranges(parents.len(), |band| {
        band.map(|i| {
            let t = |g: &Option<DepthGrid>| {
                g.as_ref().map_or(1.0, |g| (-g.depth_at_surface(i, &parents[i])).exp())
            };
            ParentLight { sun: t(&sun), sky: t(&up), vent: 0.0 }
        })
        .collect::<Vec<_>>()
    });
    bands.concat()
}

/// Light from each parent's vent (same order as `parents`): `1 / (1 + (d / reach)²)`, `d`
/// the distance from the vent (`vents[parent.eruption]`) to the parent's nearest surface, so
/// the puffs around the vent get 1 and the light has fallen to half at `reach_m`. The jet
/// leaves the vent at 1,000 K and more (thesis Table 3.1: 1,100 K), and its incandescence lights
/// the base of the column from inside; this is a rendering falloff (inverse square past the
/// reach), not radiative transfer: the ash between the vent and a parent does not dim it.
/// Parents of an eruption with no vent entry get 0.
pub fn vent_light(parents: &[ParentSphere], vents: &[Vec3], reach_m: f32, out: &mut [ParentLight]) {
    let reach = if reach_m.is_finite() && reach_m > 0.0 { reach_m } else { return };
    for (p, l) in parents.iter().zip(out.iter_mut()) {
        l.vent = match vents.get(p.eruption) {
            Some(v) if valid(p) && v.is_finite() => {
                let d = (p.center.distance(*v) - p.radius).max(0.0) / reach;
                1.0 / (1.0 + d * d)
            }
            _ => 0.0,
        };
    }
}

fn valid(p: &ParentSphere) -> bool {
    p.center.is_finite() && p.radius.is_finite() && p.radius > 0.0 && p.density.is_finite() && p.density > 0.0
}

/// A plain s1 parent of eruption 0 (tests of this module and of [`depth`]).
#[cfg(test)]
fn sphere(id: u64, center: Vec3, radius: f32, density: f32) -> ParentSphere {
    ParentSphere {
        id,
        eruption: 0,
        center,
        radius,
        rotation: Quat::IDENTITY,
        density,
        umbrella: false,
        flow: false,
        cloud: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(sun: Vec3) -> AshLightSettings {
        AshLightSettings { sun, ..Default::default() }
    }

    #[test]
    fn a_lone_parent_is_not_shadowed_by_itself() {
        let p = [sphere(1, Vec3::new(10.0, 2_000.0, -5.0), 80.0, 200.0)];
        let l = light_parents(&p, &settings(Vec3::new(0.3, 0.8, 0.2)));
        assert!(l[0].sun > 0.99 && l[0].sky > 0.99, "{:?}", l[0]);
    }

    #[test]
    fn ash_between_a_parent_and_the_sun_shadows_it() {
        let sun = Vec3::new(1.0, 1.0, 0.0).normalize();
        let target = Vec3::new(0.0, 1_000.0, 0.0);
        // A dense cloud of parents 600 m toward the sun, and one far off to the side.
        let mut parents = vec![sphere(0, target, 50.0, 5.0)];
        for i in 0..27u64 {
            let o = Vec3::new((i % 3) as f32, (i / 3 % 3) as f32, (i / 9) as f32) * 60.0 - 60.0;
            parents.push(sphere(1 + i, target + sun * 600.0 + o, 50.0, 5.0));
        }
        parents.push(sphere(99, target + Vec3::new(0.0, 0.0, 3_000.0), 50.0, 5.0));
        let l = light_parents(&parents, &settings(sun));
        assert!(l[0].sun < 0.2, "behind the cloud: {:?}", l[0]);
        assert!(l[28].sun > 0.95, "beside it: {:?}", l[28]);
        // The cloud is not above the target: the sky is open.
        assert!(l[0].sky > 0.9, "{:?}", l[0]);
        // The cloud's far side is shaded by its near side.
        let far = (1..28).min_by(|&a, &b| parents[a].center.dot(sun).total_cmp(&parents[b].center.dot(sun)));
        let near = (1..28).max_by(|&a, &b| parents[a].center.dot(sun).total_cmp(&parents[b].center.dot(sun)));
        let (far, near) = (far.unwrap(), near.unwrap());
        assert!(l[far].sun < l[near].sun - 0.2, "far {:?} near {:?}", l[far], l[near]);
    }

    #[test]
    fn overlapping_spheres_of_one_column_shadow_like_the_column() {
        // A vertical column of radius 400 m and density 0.5 kg/m³ as the model draws it:
        // slices every 20 m, each a ring of six spheres of radius 200 m, 200 m off the axis.
        // Neighbouring spheres and slices overlap many times over; they are samples of one
        // continuum, not stacked material. The ray to a horizontal sun from a probe behind the
        // column's middle crosses 800 m of ash: τ = κ ρ L = 0.003 × 0.5 × 800 = 1.2.
        let (radius, rho) = (400.0f32, 0.5f32);
        let mut parents = vec![sphere(0, Vec3::new(-radius - 60.0, 1_000.0, 0.0), 20.0, 0.01)];
        for slice in 0..100u64 {
            for k in 0..6u64 {
                let a = std::f32::consts::TAU * k as f32 / 6.0 + 0.37 * slice as f32;
                let c = Vec3::new(a.cos(), 0.0, a.sin()) * 0.5 * radius + Vec3::Y * 20.0 * slice as f32;
                parents.push(sphere(1 + slice * 8 + k, c, 0.5 * radius, rho));
            }
        }
        let l = light_parents(&parents, &settings(Vec3::X));
        let tau = -l[0].sun.ln();
        // The grid blurs the column's edge and the rings leave gaps: within half of 1.2 (1.23
        // measured). Summing the spheres' masses instead would give τ ≈ 29.
        assert!((0.6..1.8).contains(&tau), "τ = {tau} (sun {:?})", l[0]);
    }

    #[test]
    fn a_layer_above_occludes_the_sky() {
        let mut parents = vec![sphere(0, Vec3::new(0.0, 500.0, 0.0), 40.0, 5.0)];
        for i in 0..25u64 {
            let o = Vec3::new((i % 5) as f32 * 80.0 - 160.0, 1_500.0, (i / 5) as f32 * 80.0 - 160.0);
            parents.push(sphere(1 + i, o, 60.0, 15.0));
        }
        let sideways_sun = settings(Vec3::new(1.0, 0.05, 0.0));
        let l = light_parents(&parents, &sideways_sun);
        assert!(l[0].sky < 0.3, "{:?}", l[0]);
        assert!(l[0].sun > 0.95, "{:?}", l[0]);
    }

    #[test]
    fn bad_settings_are_rejected_and_light_everything() {
        for bad in [
            AshLightSettings { sun: Vec3::ZERO, ..Default::default() },
            AshLightSettings { sun: Vec3::NAN, ..Default::default() },
            AshLightSettings { extinction: -1.0, ..Default::default() },
            AshLightSettings { extinction: f32::INFINITY, ..Default::default() },
            AshLightSettings { max_cells_per_axis: 1, ..Default::default() },
            AshLightSettings { refresh_ticks: 0, ..Default::default() },
            AshLightSettings { refresh_ticks: 1_001, ..Default::default() },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
            let l = light_parents(&[sphere(0, Vec3::ZERO, 1.0, 1.0)], &bad);
            assert_eq!(l, vec![ParentLight::CLEAR]);
        }
        // NaN parents neither poison the grid nor get NaN light.
        let parents = [sphere(0, Vec3::ZERO, 10.0, 5.0), sphere(1, Vec3::NAN, f32::NAN, f32::NAN)];
        let l = light_parents(&parents, &AshLightSettings::default());
        assert!(l.iter().all(|l| l.sun.is_finite() && l.sky.is_finite()), "{l:?}");
    }

    #[test]
    fn the_vent_lights_the_base_of_its_own_column() {
        let mut a = sphere(0, Vec3::new(0.0, 2_600.0, 0.0), 80.0, 1.0);
        a.eruption = 0;
        let mut high = sphere(1, Vec3::new(0.0, 5_000.0, 0.0), 300.0, 1.0);
        high.eruption = 0;
        // The same height above its own vent, 10 km away, as `a` above vent 0.
        let mut other = sphere(2, Vec3::new(10_000.0, 2_600.0, 0.0), 80.0, 1.0);
        other.eruption = 1;
        let parents = [a, high, other];
        let vents = [Vec3::new(0.0, 2_500.0, 0.0), Vec3::new(10_000.0, 2_500.0, 0.0)];
        let mut light = vec![ParentLight::CLEAR; 3];
        vent_light(&parents, &vents, 700.0, &mut light);
        assert!(light[0].vent > 0.95, "{:?}", light[0]);
        // 2.2 km from its surface to the vent: (2,500 − 300) / 700 = 3.1 reaches.
        assert!(light[1].vent > 0.08 && light[1].vent < 0.1, "{:?}", light[1]);
        assert_eq!(light[2].vent, light[0].vent, "each column is lit by its own vent");
        let mut none = vec![ParentLight::CLEAR; 3];
        vent_light(&parents, &vents[..1], 700.0, &mut none);
        assert_eq!(none[2].vent, 0.0, "no vent, no light");
        assert!(AshLightSettings { vent_reach_m: 0.0, ..default() }.validate().is_err());
    }
}
