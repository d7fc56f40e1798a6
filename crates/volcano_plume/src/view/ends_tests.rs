use super::*;
use crate::model::spheres::{S1Sphere, SphereParams, s1_ring};
use crate::view::CLOUD_ID_BIT;
use volcano_core::rng::derive_stream;

fn slice(index: u64, y: f32, r: f32) -> SliceEnd {
    SliceEnd {
        eruption: 0,
        index,
        secondary: false,
        center: Vec3::new(0.0, y, 0.0),
        rotation: Quat::IDENTITY,
        r,
        density: 2.0,
    }
}

/// A straight vertical column of `n` slices, the oldest (index 0) on top.
fn column(n: u64, r: f32, spacing: f32) -> Vec<SliceEnd> {
    (0..n).map(|i| slice(i, 5_000.0 - spacing * i as f32, r)).collect()
}

fn caps(slices: &[SliceEnd]) -> Vec<ParentSphere> {
    let mut out = Vec::new();
    column_ends(slices, &ColumnEndSettings::default(), &mut out).unwrap();
    out
}

/// Height of the topmost surface point of a union of spheres above the point `(x, z)` of the
/// horizontal plane, if any sphere covers it.
fn top_at(spheres: &[(Vec3, f32)], x: f32, z: f32) -> Option<f32> {
    spheres
        .iter()
        .filter_map(|(c, r)| {
            let d2 = (x - c.x).powi(2) + (z - c.z).powi(2);
            (d2 <= r * r).then(|| c.y + (r * r - d2).sqrt())
        })
        .max_by(f32::total_cmp)
}

#[test]
fn a_column_gets_one_cap_ahead_of_its_front_and_one_behind_its_tail() {
    let col = column(12, 300.0, 150.0);
    let caps = caps(&col);
    assert_eq!(caps.len(), 2, "{caps:?}");
    let front = caps.iter().find(|c| c.id & 0xff == 0).unwrap();
    let tail = caps.iter().find(|c| c.id & 0xff == 1).unwrap();
    // Ahead of the oldest slice (the top), behind the newest (the bottom).
    assert!(front.center.y > col[0].center.y && tail.center.y < col[11].center.y);
    assert_eq!(front.radius, 0.7 * 300.0);
    for c in &caps {
        assert_eq!(c.id & CAP_ID_BIT, CAP_ID_BIT);
        assert_eq!(c.id & CLOUD_ID_BIT, 0);
        assert!(!c.umbrella && !c.flow && !c.cloud && c.density == 2.0);
    }
}

/// Seen along its axis, the top of the leading slice's ring ends flat (the thesis' ring has a
/// dimple on the axis, which its spheres' union touches only in the slice plane); with the cap
/// the top is a dome standing about r ahead: highest on the axis, falling toward the rim.
#[test]
fn the_cap_turns_the_rings_dimple_into_a_dome() {
    // The thesis' ring (equal sizes on the ring), then the default jittered one.
    let thesis = SphereParams { size_jitter: 0.0, radial_jitter: 0.0, ..Default::default() };
    for (params, seed) in [(thesis, 7), (SphereParams::default(), 7), (SphereParams::default(), 8)] {
        dome_over_ring(&params, seed);
    }
}

fn dome_over_ring(params: &SphereParams, seed: u64) {
    let r = 400.0;
    let top = slice(0, 8_000.0, r);
    let mut rng = derive_stream(seed, 1);
    let ring: Vec<S1Sphere> = s1_ring(params, &mut rng);
    // Slice frame: local z is the axis; here the axis is world +y.
    let mut spheres: Vec<(Vec3, f32)> = ring
        .iter()
        .map(|s| {
            let o = s.local_offset(r as f64);
            (top.center + Vec3::new(o.x as f32, o.z as f32, -o.y as f32), s.radius(r as f64) as f32)
        })
        .collect();
    let height = |sp: &[(Vec3, f32)], rho: f32| {
        // The lowest top over a circle of radius `rho` (the dimple's worst direction).
        (0..36)
            .filter_map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 36.0;
                top_at(sp, rho * a.cos(), rho * a.sin())
            })
            .min_by(f32::total_cmp)
            .map(|y| y - top.center.y)
    };
    // The thesis' ring alone: a dimple on the axis, which it touches only in the slice plane (a
    // jittered ring's larger spheres may reach over the axis, at about the rim's height).
    let ring_axis = height(&spheres, 0.0).unwrap_or(0.0);
    let ring_rim = height(&spheres, 0.5 * r).unwrap();
    if params.size_jitter == 0.0 {
        assert!(
            ring_axis < 0.05 * r && ring_rim > 0.2 * r,
            "the thesis' ring: axis {ring_axis}, rim {ring_rim}"
        );
    }
    let cap = caps(&[top])[0];
    spheres.push((cap.center, cap.radius));
    let (axis, mid, rim) = (
        height(&spheres, 0.0).unwrap(),
        height(&spheres, 0.25 * r).unwrap(),
        height(&spheres, 0.5 * r).unwrap(),
    );
    assert!(axis > 0.9 * r, "capped axis {axis}");
    assert!(axis > mid && mid > rim, "not a dome: {axis}, {mid}, {rim}");
}

#[test]
fn a_pause_splits_the_column_into_two_with_four_ends() {
    let mut col = column(6, 300.0, 150.0);
    // Slices 6.. start 3 km lower: a pause in the eruption.
    col.extend((6..10).map(|i| slice(i, 5_000.0 - 3_000.0 - 150.0 * i as f32, 300.0)));
    let caps = caps(&col);
    let mut ends: Vec<(u64, u64)> = caps.iter().map(|c| ((c.id & !CAP_ID_BIT) >> 8, c.id & 0xff)).collect();
    ends.sort();
    assert_eq!(ends, vec![(0, 0), (5, 1), (6, 0), (9, 1)]);
}

#[test]
fn secondary_columns_and_other_eruptions_are_columns_of_their_own() {
    let mut col = column(4, 300.0, 150.0);
    // A secondary slice in the middle of the main column, and another eruption's slice there.
    col.push(SliceEnd { secondary: true, index: 2, ..slice(2, 4_800.0, 300.0) });
    col.push(SliceEnd { eruption: 1, ..slice(1, 4_800.0, 300.0) });
    let caps = caps(&col);
    assert_eq!(caps.len(), 2 + 2 + 2);
    assert_eq!(caps.iter().filter(|c| c.eruption == 1).count(), 2);
    // The main column is still capped at its own ends only.
    let main: Vec<u64> = caps.iter().filter(|c| c.eruption == 0).map(|c| c.id & !CAP_ID_BIT).collect();
    assert!(main.contains(&0) && main.contains(&(3 << 8 | 1)) && main.contains(&(2 << 8)), "{main:?}");
}

#[test]
fn a_tilted_column_is_capped_along_its_axis_whatever_the_input_order() {
    // Bent 70° toward +x: the oldest slice leads toward +x.
    let rotation = Quat::from_rotation_z(-70f32.to_radians());
    let dir = rotation * Vec3::Y;
    let col: Vec<SliceEnd> = (0..8)
        .map(|i| SliceEnd {
            rotation,
            center: Vec3::new(0.0, 9_000.0, 0.0) - dir * 200.0 * i as f32,
            ..slice(i, 0.0, 250.0)
        })
        .collect();
    let front = caps(&col).into_iter().find(|c| c.id & 0xff == 0).unwrap();
    let along = (front.center - col[0].center).normalize();
    assert!(along.dot(dir) > 0.999, "cap off the axis: {along} vs {dir}");
    let mut shuffled = col.clone();
    shuffled.reverse();
    shuffled.swap(1, 5);
    assert_eq!(caps(&shuffled), caps(&col));
}

#[test]
fn off_draws_nothing_and_bad_settings_are_refused() {
    let col = column(5, 300.0, 150.0);
    let mut out = Vec::new();
    column_ends(&col, &ColumnEndSettings { enabled: false, ..Default::default() }, &mut out).unwrap();
    assert!(out.is_empty());
    for bad in [
        ColumnEndSettings { radius: f64::NAN, ..Default::default() },
        ColumnEndSettings { radius: 0.0, ..Default::default() },
        ColumnEndSettings { offset: -0.1, ..Default::default() },
        ColumnEndSettings { gap: f64::INFINITY, ..Default::default() },
    ] {
        assert!(column_ends(&col, &bad, &mut out).is_err(), "{bad:?}");
    }
    assert!(out.is_empty());
    // A slice of no size is skipped, not capped with NaN.
    let mut broken = col.clone();
    broken[0].r = f32::NAN;
    assert!(caps(&broken).iter().all(|c| c.center.is_finite() && c.radius.is_finite()));
}
