//! The rounded ends of a column, as the renderer draws them (issue 18 item 1; docs/ARCHITECTURE.md
//! §4.3, "Column ends").
//!
//! A slice's s1 spheres sit on its vortex ring (thesis §3.5.1): radius ≈ r/2, centres r/2 from
//! the axis. Their union is a torus-like ring whose surface touches the axis only in the slice's
//! plane, so where a column *ends* (its leading slice, the last one behind a gap, a secondary
//! column of one slice) the end seen along the axis is a ring of lumps around a dimple (with the
//! jittered sizes, a larger sphere may reach over the axis): a flat, hollow-looking disc face. Inside the column the next slice fills that dimple; at an end
//! nothing does. The thesis draws no cap (its columns are seen from the side, and its umbrella
//! hides the top).
//!
//! A real column ends in the rounded head of a starting plume (Turner 1962, *J. Fluid Mech.*
//! 13: the front of a starting plume is a buoyant vortex ring capped by a dome). This module
//! adds, for the view only, one parent sphere on the axis of each end slice, pushed ahead along
//! the axis so that it closes the dimple into a dome: a cap of radius `radius · r` at
//! `offset · r` ahead of the slice plane. With the defaults (0.7, 0.3) the dome's front stands
//! r ahead of the plane on the axis and 0.79 r ahead at r/2 from it, just beyond the ring
//! spheres' fronts there (r/2 for a sphere of mean size, 0.75 r for the largest), and its
//! sides stay inside the ring (0.7 r < r). It is drawn like an s1 sphere (detail spheres, density shading, light) and
//! feeds nothing back into the model.

use bevy::prelude::*;
use thiserror::Error;

use super::ParentSphere;

/// Bit set in a cap's [`ParentSphere::id`] (s1 ids are `slice index << 8 | k`, below 2⁵⁶ for
/// any reachable index; clouds use bit 62), so caps have ids of their own and stable children.
pub const CAP_ID_BIT: u64 = 1 << 61;

/// How the ends of columns are capped (a [`Resource`], editable live).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct ColumnEndSettings {
    /// Whether ends are capped (off: only the slices' rings, the thesis' drawing).
    pub enabled: bool,
    /// Cap radius as a fraction of the slice size r.
    pub radius: f64,
    /// Distance of the cap's centre ahead of the slice plane (outward along the axis), as a
    /// fraction of r.
    pub offset: f64,
    /// Consecutive slices of one column further apart than `gap · (r_a + r_b)` are two
    /// columns (a pause in the eruption): both sides of the gap are ends.
    pub gap: f64,
}

impl Default for ColumnEndSettings {
    fn default() -> Self {
        Self { enabled: true, radius: 0.7, offset: 0.3, gap: 1.0 }
    }
}

/// A rejected [`ColumnEndSettings`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ColumnEndError {
    /// A value outside its range (name, value, range).
    #[error("column ends: {0} = {1} must be {2}")]
    OutOfRange(&'static str, f64, &'static str),
}

impl ColumnEndSettings {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), ColumnEndError> {
        let within = |name, v: f64, lo: f64, hi: f64, text| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err(ColumnEndError::OutOfRange(name, v, text))
            }
        };
        within("radius", self.radius, 0.05, 1.5, "in [0.05, 1.5]")?;
        within("offset", self.offset, 0.0, 1.0, "in [0, 1]")?;
        within("gap", self.gap, 0.1, 100.0, "in [0.1, 100]")?;
        Ok(())
    }
}

/// One slice as the caps see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliceEnd {
    /// Index of the eruption in the [`EruptionView`](super::EruptionView) list.
    pub eruption: usize,
    /// Emission index of the slice.
    pub index: u64,
    /// A secondary column (one slice lifted off a current): a column of its own.
    pub secondary: bool,
    /// Centre (world, m).
    pub center: Vec3,
    /// Orientation: world +y turned to the slice's direction of motion.
    pub rotation: Quat,
    /// Slice size r (m).
    pub r: f32,
    /// Density (kg/m³).
    pub density: f32,
}

impl SliceEnd {
    fn axis(&self) -> Vec3 {
        (self.rotation * Vec3::Y).normalize_or(Vec3::Y)
    }

    fn cap(&self, s: &ColumnEndSettings, outward: f32, end: u64) -> ParentSphere {
        ParentSphere {
            id: CAP_ID_BIT | self.index << 8 | end,
            eruption: self.eruption,
            center: self.center + self.axis() * (outward * s.offset as f32 * self.r),
            radius: s.radius as f32 * self.r,
            rotation: self.rotation,
            density: self.density,
            umbrella: false,
            flow: false,
            cloud: false,
        }
    }
}

/// Appends a cap to every end of every column in `slices` (any order): the leading end (the
/// oldest slice of a run, capped ahead along its direction of motion) and the trailing end (the
/// newest, capped behind). A run is the main column's slices of one eruption in emission order,
/// cut wherever two consecutive ones are further apart than `gap · (r_a + r_b)`; each
/// secondary slice is a run of its own. Slices with a non-finite or non-positive size are
/// skipped. Deterministic: the result depends on the set of slices, not their order.
pub fn column_ends(
    slices: &[SliceEnd],
    settings: &ColumnEndSettings,
    out: &mut Vec<ParentSphere>,
) -> Result<(), ColumnEndError> {
    settings.validate()?;
    if !settings.enabled {
        return Ok(());
    }
    let mut sorted: Vec<&SliceEnd> =
        slices.iter().filter(|s| s.r.is_finite() && s.r > 0.0 && s.center.is_finite()).collect();
    sorted.sort_by_key(|s| (s.eruption, s.secondary, s.index));
    let joined = |a: &SliceEnd, b: &SliceEnd| {
        a.eruption == b.eruption
            && !a.secondary
            && !b.secondary
            && a.center.distance(b.center) <= settings.gap as f32 * (a.r + b.r)
    };
    for (i, s) in sorted.iter().enumerate() {
        // Emission order: the previous slice is older, so further along the column.
        let ahead = i.checked_sub(1).is_some_and(|j| joined(sorted[j], s));
        let behind = sorted.get(i + 1).is_some_and(|n| joined(s, n));
        if !ahead {
            out.push(s.cap(settings, 1.0, 0));
        }
        if !behind {
            out.push(s.cap(settings, -1.0, 1));
        }
    }
    Ok(())
}

#[cfg(test)]
#[path = "ends_tests.rs"]
mod tests;
