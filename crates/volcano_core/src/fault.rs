//! [`SimFault`]: what a domain's guard reports when it finds state that is no longer finite.
//!
//! Every domain checks its state once per step in every build (release included), because a
//! shipped game has no debug assertions: one NaN left in a grid spreads through every
//! neighbour within a few steps, and the bounds of a `clamp` computed from it panic. A guard
//! resets the bad cells (or removes the bad particles, slices or spheres), books what they
//! held as lost in the domain's own mass or volume accounts so the budgets still close, logs
//! a warning and writes one [`SimFault`] per entity and step.

use bevy::ecs::entity::Entity;
use bevy::ecs::message::Message;
use bevy::reflect::Reflect;

/// The simulation domain a [`SimFault`] comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Reflect)]
pub enum SimDomain {
    /// A lava field (`LavaState`): cells reset.
    Lava,
    /// An atmosphere's layers and ground: cells reset.
    Atmosphere,
    /// The plume → atmosphere coupling: ash parcels dropped.
    Coupling,
    /// A volcano's pyroclastic flows: particles removed.
    Pyroclastic,
    /// A volcano's rising column: slices removed.
    Plume,
    /// A volcano's umbrella cloud: spheres removed.
    Umbrella,
}

/// A domain found non-finite (or impossible, e.g. negative amounts) state in `entity` and
/// repaired it. The amounts are what the repaired cells or removed particles still held where
/// that was finite (an amount that was itself NaN is unknown and counts as zero); they are
/// booked as lost in the domain's accounts (e.g. `VolumeBudget::faulted` of a lava field,
/// `PlumeAshBudget::lost_kg`, `PyroclasticBudget::lost`).
#[derive(Message, Debug, Clone, PartialEq, Reflect)]
pub struct SimFault {
    /// The entity whose state was repaired (lava field, atmosphere, volcano).
    pub entity: Entity,
    /// Which of its domains.
    pub domain: SimDomain,
    /// Cells reset, or particles, slices, spheres or parcels removed.
    pub repaired: u64,
    /// Ash removed with them (kg).
    pub lost_ash_kg: f64,
    /// Water (vapour and condensed) removed with them (kg).
    pub lost_water_kg: f64,
    /// Liquid lava removed with them (m³).
    pub lost_lava_m3: f64,
}

impl SimFault {
    /// A fault of `domain` in `entity` with `repaired` things repaired and nothing booked yet.
    pub fn new(entity: Entity, domain: SimDomain, repaired: u64) -> Self {
        Self { entity, domain, repaired, lost_ash_kg: 0.0, lost_water_kg: 0.0, lost_lava_m3: 0.0 }
    }

    /// Logs the fault as a warning (every guard reports what it did).
    pub fn warn(&self) {
        bevy::log::warn!("{self}");
    }
}

impl std::fmt::Display for SimFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{:?} state of {} was not finite: {} repaired, lost {:.3e} kg ash, {:.3e} kg water, \
             {:.3e} m³ lava",
            self.domain, self.entity, self.repaired, self.lost_ash_kg, self.lost_water_kg, self.lost_lava_m3
        )
    }
}

/// A finite, non-negative amount, else 0: what a guard can still book of a value it resets.
pub fn bookable(x: f64) -> f64 {
    if x.is_finite() && x > 0.0 { x } else { 0.0 }
}

/// Whether every value is finite and at least `lo`: the guards' fast path, one pass at memory
/// speed. Eight independent lanes sum `x · 0` (0 for a finite `x`, NaN for NaN or ±∞) and take
/// the minimum, which the compiler turns into vector code (a single running sum could not be
/// reordered); only a slice that fails is searched cell by cell.
pub fn finite_and_at_least<T: Copy + Into<f64>>(xs: &[T], lo: f64) -> bool {
    let mut zero = [0.0f64; 8];
    let mut min = [f64::INFINITY; 8];
    let chunks = xs.chunks_exact(8);
    let rest = chunks.remainder();
    if lo == f64::NEG_INFINITY {
        for c in chunks {
            for l in 0..8 {
                let x: f64 = c[l].into();
                zero[l] += x * 0.0;
            }
        }
    } else {
        for c in chunks {
            for l in 0..8 {
                let x: f64 = c[l].into();
                zero[l] += x * 0.0;
                // `minpd`'s own semantics (NaN is caught by the sum).
                min[l] = if x < min[l] { x } else { min[l] };
            }
        }
    }
    let lanes_ok = zero.iter().sum::<f64>() == 0.0 && min.iter().all(|&m| m >= lo);
    lanes_ok
        && rest.iter().all(|&x| {
            let x: f64 = x.into();
            x.is_finite() && x >= lo
        })
}

/// Whether `f` is finite on every item (`f` sums an item's numbers: NaN or ±∞ if any is):
/// [`finite_and_at_least`]'s lanes over a slice of structs, without a copy.
pub fn finite_by<T>(items: &[T], f: impl Fn(&T) -> f64) -> bool {
    let mut zero = [0.0f64; 8];
    let chunks = items.chunks_exact(8);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..8 {
            zero[l] += f(&c[l]) * 0.0;
        }
    }
    zero.iter().sum::<f64>() == 0.0 && rest.iter().all(|x| f(x).is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fast_path_finds_every_kind_of_bad_value_in_every_lane() {
        for n in [0, 1, 7, 8, 9, 64, 67] {
            let good: Vec<f64> = (0..n).map(|k| k as f64 * 0.5 - 1.0).collect();
            assert!(finite_and_at_least(&good, -1.0), "{n}");
            for k in 0..n {
                for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -2.0] {
                    let mut v = good.clone();
                    v[k] = bad;
                    assert!(!finite_and_at_least(&v, -1.0), "{n} values, {bad} at {k}");
                }
            }
        }
        let f: Vec<f32> = vec![1.0, 2.0, f32::NAN, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        assert!(!finite_and_at_least(&f, f64::NEG_INFINITY));
        assert!(finite_and_at_least(&[1.0f32; 9], 0.5));
        let pairs: Vec<(f64, f64)> = (0..19).map(|k| (k as f64, -(k as f64))).collect();
        assert!(finite_by(&pairs, |p| p.0 + p.1));
        for k in 0..19 {
            let mut bad = pairs.clone();
            bad[k].1 = f64::NAN;
            assert!(!finite_by(&bad, |p| p.0 + p.1), "NaN at {k}");
        }
    }
}
