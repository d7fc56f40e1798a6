//! Spheres of uniform density splatted onto a voxel grid, so that an offline renderer sees the
//! column's and the umbrella's spheres (thesis §3.3–3.5: every scale a union of spheres of its
//! slice's density) as one density volume.
//!
//! A voxel takes `density × c`, with `c` the sphere's coverage of the voxel, approximated
//! across one voxel of its surface: `c = clamp((r − d) / h + ½, 0, 1)` for a voxel centre at
//! distance `d` from the centre and voxels of edge `h` (exact for a plane through a cube
//! perpendicular to an axis). The coverages are then scaled so that they sum to the sphere's
//! volume, `Σ c h³ = 4/3 π r³`: a sphere smaller than a voxel keeps its mass instead of
//! vanishing between voxel centres or filling a whole voxel. Overlapping spheres combine by
//! [`Combine`]: `Max` is the density of their union (the rule the ash light uses, overlapping
//! spheres do not stack their mass), `Add` sums their masses.

use crate::vdb::{FloatGrid, VdbError};

/// One sphere to splat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre (world).
    pub center: [f64; 3],
    /// Radius (world units).
    pub radius: f64,
    /// Density inside.
    pub density: f32,
}

/// How a voxel already holding a value combines with a sphere's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Combine {
    /// The larger of the two (a union of spheres of one density has that density).
    Max,
    /// Their sum (masses add).
    Add,
}

/// What a sphere puts in the voxels it covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fill {
    /// A density: `density × coverage`, normalised to the sphere's volume (mass kept).
    Density,
    /// An intensive value (a temperature): the sphere's value in every voxel whose centre is
    /// within half a voxel of its surface, whatever the coverage.
    Value,
}

/// What a splat did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SplatReport {
    /// Spheres splatted.
    pub spheres: u64,
    /// Spheres skipped: non-finite or non-positive radius or density, or a non-finite centre.
    pub skipped: u64,
    /// Voxel writes.
    pub voxel_writes: u64,
}

/// Splats `spheres` onto `grid` (their `density` read as the value of `fill`), refusing to grow it past `max_active` active voxels (the
/// grid is left as it was before the sphere that would have crossed the limit).
pub fn splat_spheres(
    grid: &mut FloatGrid,
    spheres: impl IntoIterator<Item = Sphere>,
    fill: Fill,
    combine: Combine,
    max_active: u64,
) -> Result<SplatReport, VdbError> {
    let t = *grid.transform();
    let h = t.voxel_size();
    let mut report = SplatReport::default();
    let mut cells: Vec<([i32; 3], f64)> = Vec::new();
    let mut values: Vec<([i32; 3], f32)> = Vec::new();
    let mut active = grid.active_voxel_count();
    for s in spheres {
        let valid = s.center.iter().all(|c| c.is_finite())
            && s.radius.is_finite()
            && s.radius > 0.0
            && s.density.is_finite()
            && s.density > 0.0;
        if !valid {
            report.skipped += 1;
            continue;
        }
        let c = t.world_to_index(s.center);
        let r = s.radius / h;
        // Voxels whose centre may get a coverage: within r + ½ voxel of the centre.
        let reach = r + 0.5;
        let lo = c.map(|x| (x - reach).ceil() as i64);
        let hi = c.map(|x| (x + reach).floor() as i64);
        if lo.iter().chain(&hi).any(|&v| v < i32::MIN as i64 || v > i32::MAX as i64) {
            report.skipped += 1;
            continue;
        }
        cells.clear();
        let mut sum = 0.0;
        // Leaf by leaf (8³ blocks), so that the grid looks each leaf up once.
        let block = |a: usize| {
            (lo[a].div_euclid(8)..=hi[a].div_euclid(8))
                .map(move |b| (b * 8).max(lo[a])..=(b * 8 + 7).min(hi[a]))
        };
        for xs in block(0) {
            for ys in block(1) {
                for zs in block(2) {
                    for i in xs.clone() {
                        for j in ys.clone() {
                            for k in zs.clone() {
                                let d = ((i as f64 - c[0]).powi(2)
                                    + (j as f64 - c[1]).powi(2)
                                    + (k as f64 - c[2]).powi(2))
                                .sqrt();
                                let cov = (r - d + 0.5).clamp(0.0, 1.0);
                                if cov > 0.0 {
                                    cells.push(([i as i32, j as i32, k as i32], cov));
                                    sum += cov;
                                }
                            }
                        }
                    }
                }
            }
        }
        if cells.is_empty() {
            // Smaller than a voxel and away from every centre: the nearest voxel holds it.
            cells.push((c.map(|x| x.round() as i32), 1.0));
            sum = 1.0;
        }
        let scale = match fill {
            Fill::Density => 4.0 / 3.0 * std::f64::consts::PI * r.powi(3) / sum,
            Fill::Value => 1.0,
        };
        values.clear();
        values.extend(cells.iter().map(|&(ijk, cov)| {
            let v = match fill {
                Fill::Density => (s.density as f64 * cov * scale) as f32,
                Fill::Value => s.density,
            };
            (ijk, v)
        }));
        let new = grid.count_inactive(&values);
        if active + new > max_active {
            return Err(VdbError::TooManyVoxels { grid: grid.name().to_owned(), limit: max_active });
        }
        grid.update_cells(&values, |old, v| match combine {
            Combine::Max => old.max(v),
            Combine::Add => old + v,
        })?;
        active += new;
        report.spheres += 1;
        report.voxel_writes += cells.len() as u64;
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vdb::{GridClass, Transform};

    fn grid(h: f64) -> FloatGrid {
        FloatGrid::new("ash", GridClass::FogVolume, Transform::new(h, [0.0; 3]).unwrap()).unwrap()
    }

    /// A sphere of radius 10 voxels: full density within r − 1 voxel of its centre, nothing
    /// past r + ½, and its mass within 1e-6 of ρ 4/3 π r³.
    #[test]
    fn a_large_sphere_is_full_inside_empty_outside_and_keeps_its_mass() {
        let mut g = grid(2.0);
        let s = Sphere { center: [3.3, -1.7, 0.9], radius: 20.0, density: 1.5 };
        splat_spheres(&mut g, [s], Fill::Density, Combine::Add, u64::MAX).unwrap();
        let mass = 1.5 * 4.0 / 3.0 * std::f64::consts::PI * 20f64.powi(3);
        assert!((g.integral() / mass - 1.0).abs() < 1e-6, "{} vs {mass}", g.integral());
        for (ijk, v) in g.iter_active() {
            let w = g.transform().index_to_world(ijk);
            let d = ((w[0] - 3.3).powi(2) + (w[1] + 1.7).powi(2) + (w[2] - 0.9).powi(2)).sqrt();
            assert!(d < 20.0 + 1.0 + 1e-9, "voxel at {d} m");
            if d < 18.0 {
                assert!((v - 1.5).abs() < 0.02, "inside at {d}: {v}");
            }
        }
        // The active box is the sphere's diameter, widened by at most a voxel (the surface
        // spreads over ± ½ voxel).
        let (lo, hi) = g.active_bbox().unwrap();
        let width = (hi[0] - lo[0] + 1) as f64 * 2.0;
        assert!((40.0..=42.0).contains(&width), "{width}");
    }

    #[test]
    fn a_sphere_smaller_than_a_voxel_keeps_its_mass() {
        let mut g = grid(10.0);
        let s = Sphere { center: [4.0, 4.0, 4.0], radius: 1.0, density: 2.0 };
        splat_spheres(&mut g, [s], Fill::Density, Combine::Add, u64::MAX).unwrap();
        let mass = 2.0 * 4.0 / 3.0 * std::f64::consts::PI;
        assert!((g.integral() / mass - 1.0).abs() < 1e-6);
        assert_eq!(g.active_voxel_count(), 1);
    }

    #[test]
    fn max_is_the_union_add_the_sum() {
        let s = Sphere { center: [0.0; 3], radius: 8.0, density: 1.0 };
        let (mut a, mut m) = (grid(1.0), grid(1.0));
        splat_spheres(&mut a, [s, s], Fill::Density, Combine::Add, u64::MAX).unwrap();
        splat_spheres(&mut m, [s, s], Fill::Density, Combine::Max, u64::MAX).unwrap();
        assert!((m.get([0, 0, 0]) - 1.0).abs() < 0.01, "{}", m.get([0, 0, 0]));
        assert_eq!(a.active_voxel_count(), m.active_voxel_count());
        assert!(m.iter_active().all(|(ijk, v)| a.get(ijk) == 2.0 * v));
    }

    /// A temperature is the sphere's own in every voxel it reaches, and the hotter of two
    /// overlapping spheres wins.
    #[test]
    fn an_intensive_value_is_not_diluted() {
        let mut g = grid(1.0);
        let hot = Sphere { center: [0.0; 3], radius: 3.0, density: 900.0 };
        let warm = Sphere { center: [2.0, 0.0, 0.0], radius: 3.0, density: 400.0 };
        splat_spheres(&mut g, [hot, warm], Fill::Value, Combine::Max, u64::MAX).unwrap();
        assert_eq!(g.get([0, 0, 0]), 900.0);
        assert_eq!(g.get([-3, 0, 0]), 900.0, "the surface voxel is not a fraction of it");
        assert_eq!(g.get([5, 0, 0]), 400.0);
        assert!(g.iter_active().all(|(_, v)| v == 900.0 || v == 400.0));
    }

    #[test]
    fn bad_spheres_are_skipped_and_the_budget_is_an_error() {
        let mut g = grid(1.0);
        let bad = [
            Sphere { center: [f64::NAN, 0.0, 0.0], radius: 1.0, density: 1.0 },
            Sphere { center: [0.0; 3], radius: -1.0, density: 1.0 },
            Sphere { center: [0.0; 3], radius: 1.0, density: f32::INFINITY },
            Sphere { center: [1e12, 0.0, 0.0], radius: 1.0, density: 1.0 },
        ];
        let r = splat_spheres(&mut g, bad, Fill::Density, Combine::Max, u64::MAX).unwrap();
        assert_eq!((r.spheres, r.skipped), (0, 4));
        assert_eq!(g.active_voxel_count(), 0);
        let big = Sphere { center: [0.0; 3], radius: 10.0, density: 1.0 };
        let e = splat_spheres(&mut g, [big], Fill::Density, Combine::Max, 1000).unwrap_err();
        assert!(matches!(e, VdbError::TooManyVoxels { limit: 1000, .. }));
        assert_eq!(g.active_voxel_count(), 0, "nothing written past the budget");
    }
}
