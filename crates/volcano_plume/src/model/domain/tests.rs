//! The plume domain step's report: emission and its backlog, a collapse with its ash, a slice
//! at its apex spreading as the umbrella, a non-finite slice removed and booked, a frozen
//! eruption, the caps.

use bevy::math::{DVec3, Vec3};
use volcano_core::VolcanoRng;

use super::*;
use crate::model::params::PlumeParams;
use crate::model::slice::Slice;
use crate::model::spheres::SphereParams;

const DT: f64 = 0.002;

fn inputs<'a>(p: &'a PlumeParams, spheres: &'a SphereParams, rng: &'a VolcanoRng) -> PlumeInputs<'a> {
    PlumeInputs {
        params: p,
        spheres,
        active: true,
        frozen: false,
        emitter: Some(Emitter { vent: Vec3::new(10.0, 200.0, -5.0), rng }),
        umbrella_lifetime: 300.0,
        umbrella_fallout_s: 600.0,
        air: PlumeAir::Own,
        caps: StepCaps::default(),
        rings: None,
        dt: DT,
        umbrella_dt: DT,
    }
}

/// A state holding one slice (index 7, with its ring) in the given condition.
fn one_slice(
    p: &PlumeParams,
    spheres: &SphereParams,
    rng: &VolcanoRng,
    edit: impl Fn(&mut LiveSlice),
) -> PlumeState {
    let mut slice = LiveSlice::at_vent(p, 7, Vec3::new(10.0, 200.0, -5.0));
    edit(&mut slice);
    PlumeState {
        slices: vec![slice],
        rings: ring(spheres, rng, 7),
        emission: Emission { emitted: 8, ..Default::default() },
        ..Default::default()
    }
}

#[test]
fn emission_is_capped_per_step_and_the_backlog_is_counted() {
    let (p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    let interval = p.emission_interval();
    let mut state = PlumeState::default();
    state.emission.since_last = 10.0 * interval;
    let r = step(&mut state, &inputs(&p, &spheres, &rng));
    assert_eq!(r.emitted.len(), MAX_EMISSIONS_PER_STEP as usize);
    assert_eq!(state.emission.emitted, 4);
    // 10 intervals (and a step) were due, four went: six are carried.
    assert_eq!(state.emission.backlog, 6);
    assert_eq!((state.emission.capped_steps, r.backlog_began), (1, true));
    let solid = Slice::at_vent(&p).solid_mass;
    assert!((state.ash.emitted_kg - 4.0 * solid).abs() <= 1e-12 * solid);
    // Each new slice has its ring, from its own stream, and was stepped once.
    assert_eq!(state.slices.len(), 4);
    assert_eq!(state.rings.len(), 4 * spheres.s1_per_slice as usize);
    for (k, em) in r.emitted.iter().enumerate() {
        assert_eq!((em.at, em.slice.index, em.first_ring), (k, k as u64, 6 * k));
        assert_eq!(em.ring, ring(&spheres, &rng, k as u64));
        assert_eq!(r.slice_fates[k], SliceFate::Kept(k));
        assert!((state.slices[k].state.age - DT).abs() < 1e-15);
    }
    // The next step keeps emitting four and the backlog shrinks; it did not begin again.
    let r = step(&mut state, &inputs(&p, &spheres, &rng));
    assert_eq!((r.emitted.len(), state.emission.backlog, r.backlog_began), (4, 2, false));
    assert_eq!(state.emission.capped_steps, 2);
}

#[test]
fn a_collapsing_slice_is_reported_with_its_ash() {
    let (p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    // Dense vent material sinking before it was ever buoyant: it collapses on this step.
    let mut state = one_slice(&p, &spheres, &rng, |s| {
        s.state.position.z = 800.0;
        s.state.velocity = DVec3::new(0.0, 0.0, -2.0);
        s.ash_pending = 40.0;
    });
    let mut no_emission = inputs(&p, &spheres, &rng);
    no_emission.active = false;
    let r = step(&mut state, &no_emission);
    assert_eq!(r.finished.len(), 1);
    let f = &r.finished[0];
    assert_eq!((f.outcome, f.removed.at, f.removed.slice.index), (Outcome::Collapsed, 0, 7));
    assert_eq!(f.removed.slice.state.phase, Phase::Collapsed);
    let s = &f.removed.slice;
    let ash = s.state.solid_mass + s.ash_pending;
    assert!(s.ash_pending > 40.0, "it shed ash on its last step too");
    assert_eq!(f.removed.ash_kg, ash);
    assert_eq!(state.ash.to_flows_kg, ash);
    assert_eq!(state.ash.lost_kg, 0.0);
    // Gone with its ring; no umbrella sphere; the report says where everything went.
    assert_eq!(f.removed.ring, (0..6).collect::<Vec<_>>());
    assert!(f.spheres.is_empty() && state.umbrella.is_empty());
    assert!(state.slices.is_empty() && state.rings.is_empty());
    assert_eq!(r.slice_fates, vec![SliceFate::Finished(0)]);
    assert_eq!(r.collapsed().count(), 1);
}

#[test]
fn a_slice_at_its_apex_spreads_its_ring_and_ash_as_the_umbrella() {
    let (p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    // Buoyant once, rising barely: its weight turns it round at this step (an apex).
    let mut state = one_slice(&p, &spheres, &rng, |s| {
        s.state.position.z = 6_000.0;
        s.state.velocity = DVec3::new(0.0, 0.0, 0.01);
        s.state.phase = Phase::Buoyant;
        s.state.buoyant_from = Some(1_000.0);
        s.ash_pending = 12.0;
    });
    let ring_before = state.rings.clone();
    let mut no_emission = inputs(&p, &spheres, &rng);
    no_emission.active = false;
    let r = step(&mut state, &no_emission);
    let f = &r.finished[0];
    assert_eq!(f.outcome, Outcome::Umbrella);
    assert_eq!(r.neutral.len(), 1, "denser than the air again: its neutral level");
    let s = &f.removed.slice.state;
    let solid = s.solid_mass;
    assert_eq!(f.spheres, 0..6);
    assert_eq!(state.umbrella.len(), 6);
    for (m, u) in state.umbrella.iter().enumerate() {
        assert_eq!(u.id, ring_before[m].id);
        assert_eq!(u.radius, ring_before[m].sphere.radius(s.r));
        // Stepped once in the umbrella already (detached in this step).
        assert_eq!(u.age, DT);
        assert!(
            (u.ash + u.ash_pending - solid / 6.0 - if m == 0 { f.removed.slice.ash_pending } else { 0.0 })
                .abs()
                < 1e-9 * solid
        );
    }
    assert_eq!(r.sphere_fates, (0..6).map(SphereFate::Kept).collect::<Vec<_>>());
    assert_eq!((state.ash.to_flows_kg, state.ash.lost_kg), (0.0, 0.0));
    assert!(state.slices.is_empty() && state.rings.is_empty());
    assert_eq!(r.spreading().count(), 1);
}

#[test]
fn a_non_finite_slice_is_removed_with_its_ring_and_its_ash_booked_as_lost() {
    let (p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    let mut state = one_slice(&p, &spheres, &rng, |s| {
        s.state.position.z = 500.0;
        s.state.velocity.x = f64::NAN;
        s.ash_pending = 25.0;
    });
    // A second, healthy slice after it keeps its place.
    let healthy = LiveSlice::at_vent(&p, 9, Vec3::new(10.0, 200.0, -5.0));
    state.slices.push(healthy);
    state.rings.extend(ring(&spheres, &rng, 9));
    let mut no_emission = inputs(&p, &spheres, &rng);
    no_emission.active = false;
    let r = step(&mut state, &no_emission);
    assert_eq!(r.non_finite.len(), 1);
    let removed = &r.non_finite[0];
    assert_eq!((removed.at, removed.slice.index), (0, 7));
    assert!(removed.ash_kg >= 25.0);
    assert_eq!(state.ash.lost_kg, removed.ash_kg);
    assert_eq!(removed.ring, (0..6).collect::<Vec<_>>());
    assert_eq!(r.slice_fates, vec![SliceFate::NonFinite(0), SliceFate::Kept(0)]);
    assert_eq!(state.slices.len(), 1);
    assert_eq!(state.slices[0].index, 9);
    assert!(state.rings.iter().all(|r| r.slice == 9) && state.rings.len() == 6);
}

#[test]
fn a_non_finite_umbrella_sphere_is_removed_and_its_ash_booked_as_lost() {
    let (p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    let sphere = |id: u64, ash: f64| CloudSphere {
        id,
        sphere: UmbrellaSphere::detach(&Slice::at_vent(&p), DVec3::X, Spread::Thesis),
        radius: 10.0,
        density: 1.0,
        age: 1.0,
        vent: Vec3::ZERO,
        ash,
        ash_pending: 2.0,
    };
    let umbrella = vec![sphere(0, 5.0), sphere(1, 7.0), sphere(2, f64::NAN), sphere(3, 1.0)];
    let mut state = PlumeState { umbrella, ..Default::default() };
    state.umbrella[1].sphere.d = f64::INFINITY;
    state.umbrella[3].age = f64::NAN;
    let mut no_emission = inputs(&p, &spheres, &rng);
    no_emission.active = false;
    let r = step(&mut state, &no_emission);
    let gone: Vec<(usize, u64)> = r.umbrella_non_finite.iter().map(|s| (s.at, s.sphere.id)).collect();
    assert_eq!(gone, vec![(1, 1), (2, 2), (3, 3)]);
    assert_eq!(
        r.sphere_fates[1..],
        [SphereFate::NonFinite(0), SphereFate::NonFinite(1), SphereFate::NonFinite(2)]
    );
    assert_eq!(state.umbrella.iter().map(|u| u.id).collect::<Vec<_>>(), vec![0]);
    // What they still held where it was finite: the NaN ash falls out into the sphere's
    // pending ash too, so that sphere books nothing.
    let held: f64 = r.umbrella_non_finite.iter().map(|s| s.ash_kg).sum();
    assert!((held - (7.0 + 2.0 + 1.0 + 2.0)).abs() < 1e-9, "{held}");
    assert_eq!(state.ash.lost_kg, held);
    assert_eq!(state.ash.released_kg, 0.0);
}

#[test]
fn a_frozen_eruption_emits_nothing_and_holds_its_slices_while_the_umbrella_spreads() {
    let (p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    let mut state = one_slice(&p, &spheres, &rng, |s| s.state.position.z = 300.0);
    state.emission.since_last = 5.0;
    let before = state.slices.clone();
    let mut source = one_slice(&p, &spheres, &rng, |s| {
        s.state.position.z = 6_000.0;
        s.state.velocity = DVec3::new(0.0, 0.0, 0.01);
        s.state.phase = Phase::Buoyant;
        s.state.buoyant_from = Some(1_000.0);
    });
    let mut no_emission = inputs(&p, &spheres, &rng);
    no_emission.active = false;
    step(&mut source, &no_emission);
    state.umbrella = source.umbrella.clone();
    let mut frozen = inputs(&p, &spheres, &rng);
    frozen.frozen = true;
    let r = step(&mut state, &frozen);
    assert!(!r.stepped && r.emitted.is_empty());
    assert_eq!(state.slices, before);
    assert_eq!(state.emission.since_last, 5.0);
    assert!(state.umbrella.iter().zip(&source.umbrella).all(|(a, b)| a.age > b.age));
}

#[test]
fn the_caps_retire_secondary_columns_first_and_the_oldest_spheres() {
    let (p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    let mut state = PlumeState::default();
    for index in 0..5 {
        let mut s = LiveSlice::at_vent(&p, index, Vec3::ZERO);
        s.state.position.z = 100.0 * index as f64;
        s.secondary = index == 3;
        state.slices.push(s);
        state.rings.extend(ring(&spheres, &rng, index));
    }
    let mut capped = inputs(&p, &spheres, &rng);
    capped.active = false;
    capped.caps.max_live_slices = 3;
    let r = step(&mut state, &capped);
    // The secondary column goes first, then the oldest column slice.
    let gone: Vec<u64> = r.retired.iter().map(|s| s.slice.index).collect();
    assert_eq!(gone, vec![3, 0]);
    let released: f64 = r.retired.iter().map(|s| s.ash_kg).sum();
    assert_eq!((state.ash.released_kg, state.ash.capped_kg), (released, released));
    assert_eq!(state.slices.iter().map(|s| s.index).collect::<Vec<_>>(), vec![1, 2, 4]);
    assert_eq!(state.rings.len(), 18);
    assert_eq!(r.retired[0].ring, (18..24).collect::<Vec<_>>());
    // Umbrella spheres beyond the cap: the oldest expire early.
    state.umbrella = (0..5)
        .map(|k| CloudSphere {
            id: k,
            sphere: UmbrellaSphere::detach(&Slice::at_vent(&p), DVec3::X, Spread::Thesis),
            radius: 10.0,
            density: 1.0,
            age: k as f64,
            vent: Vec3::ZERO,
            ash: 1.0,
            ash_pending: 0.0,
        })
        .collect();
    capped.caps.max_umbrella_spheres = 2;
    let r = step(&mut state, &capped);
    let gone: Vec<u64> = r.umbrella_retired.iter().map(|s| s.sphere.id).collect();
    assert_eq!(gone, vec![4, 3, 2]);
    assert_eq!(state.umbrella.iter().map(|u| u.id).collect::<Vec<_>>(), vec![0, 1]);
    assert_eq!(r.sphere_fates[4], SphereFate::Retired(0));
}

/// The plugin steps the umbrella once per base tick (`umbrella_dt` = 10 steps) instead of in
/// every 2 ms step: its spreading and fallout laws are exact for any step and the wind drift
/// is evaluated at the start of each step, so after 60 s under a sheared wind the spheres
/// (moved 0.7–1.7 km) are where stepping every 2 ms puts them, 1 cm apart (bound 2 cm), and hold
/// the same ash. Fails if a law's error grew with the step: with an Euler spread
/// `d += v r/d · Δt` they are 5.6 cm apart (tried).
#[test]
fn an_umbrella_stepped_once_per_tick_follows_one_stepped_every_substep() {
    let (mut p, spheres, rng) = (PlumeParams::default(), SphereParams::default(), VolcanoRng::new(3));
    p.wind = crate::model::wind::WindProfile::Linear { max: 30.0, top: 12_000.0, direction_deg: 30.0 };
    let mut slice = Slice::at_vent(&p);
    slice.position.z = 9_000.0;
    slice.velocity.z = 40.0;
    slice.apex = 9_000.0;
    slice.neutral_altitude = Some(7_000.0);
    slice.neutral_speed = Some(60.0);
    let mut start = PlumeState::default();
    for k in 0..6u64 {
        let local = DVec3::new((k as f64).cos(), (k as f64).sin(), 0.0) * 300.0;
        let mut sphere = UmbrellaSphere::detach(&slice, local, Spread::Thesis);
        sphere.v_neutral = 60.0;
        start.umbrella.push(CloudSphere {
            id: k,
            sphere,
            radius: 150.0,
            density: 0.5,
            age: 0.0,
            vent: Vec3::ZERO,
            ash: 1_000.0,
            ash_pending: 0.0,
        });
    }
    let mut base = inputs(&p, &spheres, &rng);
    base.active = false;
    let (mut fine, mut coarse) = (start.clone(), start.clone());
    for n in 1..=30_000u32 {
        step(&mut fine, &base);
        let umbrella_dt = if n % 10 == 0 { 10.0 * DT } else { 0.0 };
        step(&mut coarse, &PlumeInputs { umbrella_dt, ..base });
    }
    for ((f, c), s) in fine.umbrella.iter().zip(&coarse.umbrella).zip(&start.umbrella) {
        let (a, b) = (f.position(), c.position());
        eprintln!("sphere {}: moved {:.0} m, {:.4} m apart", f.id, a.distance(s.position()), a.distance(b));
        assert!(a.distance(s.position()) > 500.0, "moved {a}");
        assert!(a.distance(b) < 0.02, "sphere {}: {a} vs {b}", f.id);
        assert!((f.age - c.age).abs() < 1e-9, "{} vs {}", f.age, c.age);
        let (ash_f, ash_c) = (f.ash + f.ash_pending, c.ash + c.ash_pending);
        assert!((ash_f - ash_c).abs() < 1e-9 * ash_f && f.ash < 1_000.0, "{ash_f} vs {ash_c}");
        assert!((f.ash - c.ash).abs() < 1e-9 * f.ash, "{} vs {}", f.ash, c.ash);
    }
    assert_eq!(fine.umbrella.len(), 6);
    assert_eq!(coarse.umbrella.len(), 6);
}
