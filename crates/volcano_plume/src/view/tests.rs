use super::*;

fn parent(id: u64, density: f32, umbrella: bool) -> ParentSphere {
    ParentSphere {
        id,
        eruption: 0,
        center: Vec3::new(0.0, 1000.0 + id as f32, 0.0),
        radius: 50.0,
        rotation: Quat::from_axis_angle(Vec3::X, 0.8),
        density,
        umbrella,
        flow: false,
        cloud: false,
    }
}

fn view(s2: u32) -> Vec<EruptionView> {
    vec![EruptionView {
        seed: 3,
        spheres: SphereParams { s2_per_s1: s2, ..Default::default() },
        rho0: 200.0,
        vent: Vec3::ZERO,
    }]
}

#[test]
fn shade_is_dark_at_the_vent_and_light_aloft() {
    assert_eq!(shade_for(200.0, 200.0), 0.0);
    assert_eq!(shade_for(DILUTE_DENSITY, 200.0), 1.0);
    let mid = shade_for(3.0, 200.0);
    assert!(mid > 0.3 && mid < 0.7, "{mid}");
    assert!(shade_for(f32::NAN, 200.0).is_finite());
    assert_eq!(shade_for(0.0, 200.0), 1.0);
}

#[test]
fn instance_counts_follow_settings_and_budget() {
    let parents: Vec<_> = (0..10).map(|i| parent(i, 200.0, false)).collect();
    let e = view(100);
    let mut out = Vec::new();
    let all = PlumeViewSettings { max_instances: u32::MAX, ..Default::default() };
    build_instances(&all, None, &e, &parents, &mut out);
    // Dense ash (shade 0): every detail sphere is kept.
    assert_eq!(out.len(), 10 + 10 * 100);
    assert_eq!(out.iter().filter(|i| i.kind >= 1.0).count(), 10);
    let capped = PlumeViewSettings { max_instances: 500, ..Default::default() };
    build_instances(&capped, None, &e, &parents, &mut out);
    assert!(out.len() <= 500 && out.len() > 350, "budget spreads evenly: {}", out.len());
    let spread: std::collections::HashSet<u32> =
        out.iter().filter(|i| i.kind < 1.0).map(|i| (i.center[1] / 1.0) as u32).collect();
    assert!(spread.len() > 5, "detail kept for many parents, not just the first");
    let none = PlumeViewSettings { detail: false, ..Default::default() };
    build_instances(&none, None, &e, &parents, &mut out);
    assert_eq!(out.len(), 10);
}

#[test]
fn dilute_ash_is_lighter_and_thinner() {
    let e = view(200);
    let mut dense = Vec::new();
    let mut dilute = Vec::new();
    let s = PlumeViewSettings::default();
    build_instances(&s, None, &e, &[parent(1, 150.0, false)], &mut dense);
    build_instances(&s, None, &e, &[parent(1, 0.1, false)], &mut dilute);
    assert!(dilute.len() < dense.len() * 3 / 4, "{} vs {}", dilute.len(), dense.len());
    assert!(dilute[0].shade > dense[0].shade + 0.5);
    assert!(dilute[0].coverage < dense[0].coverage);
}

#[test]
fn billboard_turns_with_the_projected_spin() {
    let e = view(0);
    let s = PlumeViewSettings::default();
    let mut out = Vec::new();
    // Spin axis x, angle 0.8: seen along the axis the billboard turns by the full angle,
    // seen from the side (along z) not at all.
    let p = parent(5, 100.0, false);
    build_instances(&s, Some(p.center + Vec3::X * 1000.0), &e, &[p], &mut out);
    assert!((out[0].angle - 0.8).abs() < 1e-4, "{}", out[0].angle);
    build_instances(&s, Some(p.center + Vec3::Z * 1000.0), &e, &[p], &mut out);
    assert!(out[0].angle.abs() < 1e-4, "{}", out[0].angle);
}

#[test]
fn enumeration_matches_instances_and_is_deterministic() {
    let e = view(20);
    let parents: Vec<_> = (0..4).map(|i| parent(i, 200.0, i % 2 == 0)).collect();
    let mut a = Vec::new();
    for_each_sphere(&e, &parents, |s| a.push(s));
    let mut b = Vec::new();
    for_each_sphere(&e, &parents, |s| b.push(s));
    assert_eq!(a, b);
    assert_eq!(a.len(), 4 * 21);
    let mut inst = Vec::new();
    let s = PlumeViewSettings { billboard_scale: 1.0, max_instances: u32::MAX, ..Default::default() };
    build_instances(&s, None, &e, &parents, &mut inst);
    assert_eq!(inst.len(), a.len());
    for (r, i) in a.iter().zip(&inst) {
        assert!((r.center.as_vec3() - Vec3::from_array(i.center)).length() < 1e-3);
        assert!((r.radius as f32 - i.radius).abs() < 1e-4);
    }
}

#[test]
fn parallel_chunks_match_the_sequential_enumeration() {
    // 700 parents: three chunks filled by different tasks.
    let e = view(7);
    let parents: Vec<_> = (0..700).map(|i| parent(i, 200.0, i % 3 == 0)).collect();
    let mut seq = Vec::new();
    for_each_sphere(&e, &parents, |s| seq.push(s));
    let s = PlumeViewSettings { billboard_scale: 1.0, max_instances: u32::MAX, ..Default::default() };
    let mut inst = vec![AshInstance::default(); 10]; // reused buffer with stale content
    build_instances(&s, None, &e, &parents, &mut inst);
    assert_eq!(inst.len(), seq.len());
    for (r, i) in seq.iter().zip(&inst) {
        assert_eq!(r.center.as_vec3().to_array(), i.center);
        assert_eq!(r.radius as f32, i.radius);
    }
}
