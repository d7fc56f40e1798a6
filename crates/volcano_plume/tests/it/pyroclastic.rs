//! Pyroclastic model (thesis §3.6): collapse hand-over, particles on terrain, clustering and
//! secondary columns. Model level, no ECS.

use bevy::math::{DVec2, DVec3};
use volcano_core::rng::derive_stream;
use volcano_plume::model::params::PlumeParams;
use volcano_plume::model::pyroclastic::*;
use volcano_plume::model::slice::{Phase, Slice, SliceEnv};

fn env(air: &dyn volcano_core::AtmosphereProfile) -> SliceEnv<'_> {
    static CALM: fn(f64) -> DVec2 = |_| DVec2::ZERO;
    SliceEnv { air, vent_altitude: 0.0, wind: &CALM }
}

fn collapsing_slice() -> Slice {
    let p = PlumeParams { v0: 70.0, ..Default::default() };
    let mut s = Slice::at_vent(&p);
    let air = p.atmosphere.profile();
    let e = env(air);
    while s.phase != Phase::Collapsed {
        s.step(&p, &e, 0.002);
    }
    s
}

#[test]
fn collapse_conserves_mass_and_momentum() {
    let s = collapsing_slice();
    let ps = collapse(&s, 8.0, 100_000, &mut derive_stream(1, 2));
    let v_s2 = 4.0 / 3.0 * std::f64::consts::PI * 8f64.powi(3);
    assert_eq!(ps.len(), (s.volume() / v_s2).round() as usize);
    let m: f64 = ps.iter().map(|p| p.mass).sum();
    let mv: DVec3 = ps.iter().map(|p| p.velocity * p.mass).sum();
    assert!((m - s.mass).abs() <= 1e-9 * s.mass, "{m} vs {}", s.mass);
    assert!((mv - s.velocity * s.mass).length() <= 1e-9 * s.mass * s.velocity.length());
    let vol: f64 = ps.iter().map(|p| p.volume()).sum();
    assert!((vol - s.volume()).abs() < 1e-9 * s.volume(), "same total volume");
    // Each sphere's density is its mass over its volume: the slice's.
    assert!(ps.iter().all(|p| (p.density() - s.density).abs() < 1e-9 * s.density));
    // Capped count: bigger spheres, same totals.
    let few = collapse(&s, 8.0, 100, &mut derive_stream(1, 2));
    assert_eq!(few.len(), 100);
    assert!((few.iter().map(|p| p.mass).sum::<f64>() - s.mass).abs() <= 1e-9 * s.mass);
}

/// A cone of slope 0.3 with its summit at the origin (z = 0), and a V-shaped valley along +x.
fn cone(x: f64, y: f64) -> f64 {
    -0.3 * (x * x + y * y).sqrt()
}
fn valley(x: f64, y: f64) -> f64 {
    -0.2 * x + 0.5 * y.abs()
}

/// Runs one particle from rest at `start`; returns its track, its final mass and the deposits
/// it left (where, how much).
fn run_on(
    ground: &dyn Fn(f64, f64) -> f64,
    start: DVec3,
    params: &PyroclasticParams,
    seconds: f64,
) -> (Vec<DVec3>, f64, Vec<(DVec2, f64)>) {
    let air = PlumeParams::default().atmosphere.profile();
    let e = env(air);
    let mut p = Particle {
        position: start,
        velocity: DVec3::ZERO,
        radius: 8.0,
        mass: 3.0 * 4.0 / 3.0 * std::f64::consts::PI * 512.0,
        temperature: 900.0,
        grounded: false,
    };
    let mut deposits = Vec::new();
    let mut track = vec![p.position];
    for _ in 0..(seconds / 0.02) as usize {
        let r = step_particle(&mut p, params, &e, ground, 0.02);
        if r.deposited > 0.0 {
            deposits.push((r.deposit_at, r.deposited));
        }
        track.push(p.position);
        if r.settled {
            break;
        }
    }
    (track, p.mass, deposits)
}

#[test]
fn particles_run_down_a_cone() {
    // A slow mass loss, so the 3 kg/m³ sphere stays denser than the air for the whole run (with
    // the default showcase σ_pyr it turns buoyant after ≈6 s and stops running).
    let params = PyroclasticParams { sigma_pyr: 0.02, ..Default::default() };
    let (track, _, deposits) = run_on(&cone, DVec3::new(50.0, 20.0, 30.0), &params, 60.0);
    let first = track[0].truncate().length();
    let last = track.last().unwrap().truncate().length();
    assert!(last > first + 100.0, "ran downhill: {first} → {last} m from the summit");
    assert!(!deposits.is_empty(), "lost mass while moving");
    // Direction: away from the summit along the fall line (starting point's bearing).
    let bearing = track.last().unwrap().truncate().normalize().dot(track[0].truncate().normalize());
    assert!(bearing > 0.95, "follows the fall line: {bearing}");
}

/// Released 40 m up the side of a V-shaped valley, a particle is pulled to the floor and runs
/// down it; the ash it sheds lies along the floor, downstream of where it started.
#[test]
fn particles_follow_a_valley_and_deposit_on_its_floor() {
    let params = PyroclasticParams { sigma_pyr: 0.02, ..Default::default() };
    let (track, _, deposits) = run_on(&valley, DVec3::new(0.0, 40.0, 25.0), &params, 60.0);
    let end = *track.last().unwrap();
    assert!(end.x > 200.0, "ran down the valley: {end:?}");
    // Pulled to the valley floor (y = 0) from 40 m up its side; the side slope keeps it there.
    let max_late = track[track.len() / 2..].iter().map(|p| p.y.abs()).fold(0.0, f64::max);
    assert!(max_late < 40.0, "stays in the valley: |y| ≤ {max_late}");
    let total: f64 = deposits.iter().map(|d| d.1).sum();
    let mean_abs_y = deposits.iter().map(|(at, m)| at.y.abs() * m).sum::<f64>() / total;
    let on_floor = deposits.iter().filter(|(at, _)| at.y.abs() < 10.0).map(|d| d.1).sum::<f64>() / total;
    let downstream = deposits.iter().filter(|(at, _)| at.x > 100.0).map(|d| d.1).sum::<f64>() / total;
    assert!(mean_abs_y < 10.0, "deposit off the floor: mass-weighted |y| = {mean_abs_y} m");
    assert!(on_floor > 0.6 && downstream > 0.5, "floor share {on_floor}, beyond 100 m {downstream}");
}

#[test]
fn no_sedimentation_no_secondary_column_more_sedimentation_sooner() {
    let air = PlumeParams::default().atmosphere.profile();
    let e = env(air);
    let flat = |_: f64, _: f64| 0.0;
    let seconds_to_buoyant = |sigma: f64| -> Option<f64> {
        let params = PyroclasticParams { sigma_pyr: sigma, settle_speed: 0.0, ..Default::default() };
        let mut p = Particle {
            position: DVec3::new(0.0, 0.0, 0.0),
            velocity: DVec3::new(20.0, 0.0, 0.0),
            radius: 8.0,
            mass: 3.0 * 4.0 / 3.0 * std::f64::consts::PI * 512.0, // 3 kg/m³, denser than air
            temperature: 900.0,
            grounded: true,
        };
        for k in 0..(300.0 / 0.02) as usize {
            step_particle(&mut p, &params, &e, &flat, 0.02);
            if p.density() < air.density(p.position.z) {
                return Some(k as f64 * 0.02);
            }
        }
        None
    };
    assert_eq!(seconds_to_buoyant(0.0), None, "σ_pyr = 0: never lighter than the air");
    let slow = seconds_to_buoyant(0.02).expect("buoyant with σ = 0.02");
    let fast = seconds_to_buoyant(0.08).expect("buoyant with σ = 0.08");
    assert!(fast < slow, "larger σ_pyr → buoyant sooner ({fast} s vs {slow} s)");
}

#[test]
fn clustering_is_linear_and_groups_within_the_radius() {
    // 50,000 particles on a 2 km × 2 km sheet, 10 m above the ground, a quarter buoyant.
    let n = 50_000;
    let mut rng = derive_stream(5, 9);
    use rand::RngExt;
    let ps: Vec<Particle> = (0..n)
        .map(|_| Particle {
            position: DVec3::new(
                rng.random_range(0.0..2_000.0),
                rng.random_range(0.0..2_000.0),
                rng.random_range(0.0..20.0),
            ),
            velocity: DVec3::new(rng.random_range(-5.0..5.0), 3.0, rng.random_range(-1.0..1.0)),
            radius: 4.0,
            mass: rng.random_range(100.0..300.0),
            temperature: 800.0,
            grounded: true,
        })
        .collect();
    let buoyant: Vec<bool> = (0..n).map(|i| i % 4 == 0).collect();
    let c = find_clusters(&ps, &buoyant, 50.0, 5);
    // Each check looks at a 3×3×3 block of 50 m cells: bounded by the local density, not by N.
    assert!(c.pair_checks < 40 * n as u64, "{} pair checks for {n} particles", c.pair_checks);
    assert!(!c.members.is_empty());
    let r2 = 50.0f64 * 50.0;
    assert_eq!(c.seeds.len(), c.members.len());
    for (members, &seed) in c.members.iter().zip(&c.seeds) {
        assert!(members.iter().all(|&i| buoyant[i]));
        // All members within r_pyr of the seed.
        let seed = ps[seed].position;
        assert!(members.iter().all(|&i| ps[i].position.distance_squared(seed) <= r2));
    }
    // A particle is in one cluster at most.
    let mut all: Vec<usize> = c.members.concat();
    let len = all.len();
    all.sort_unstable();
    all.dedup();
    assert_eq!(all.len(), len);
}

/// A flow running down a 17° slope at 10 m/s turns buoyant: the secondary column keeps the
/// flow's downward momentum (it first sinks), is turned round by its buoyancy, and rises well
/// above where it formed before it spreads. (A column started with its downward speed set to 0
/// fails the momentum and sinking checks.)
#[test]
fn a_secondary_column_keeps_the_flows_momentum_and_rises() {
    let p = PlumeParams::default();
    let air = p.atmosphere.profile();
    let e = env(air);
    let down = DVec3::new(9.56, 0.0, -2.92); // 10 m/s along a 17° slope
    let ps: Vec<Particle> = (0..25)
        .map(|k| Particle {
            position: DVec3::new((k % 5) as f64 * 8.0, (k / 5) as f64 * 8.0, -0.3 * (k % 5) as f64 * 8.0),
            velocity: down,
            radius: 4.0,
            // 0.9 kg/m³: lighter than the sea-level air (1.23 kg/m³).
            mass: 0.9 * 4.0 / 3.0 * std::f64::consts::PI * 64.0,
            temperature: 700.0,
            grounded: true,
        })
        .collect();
    let members: Vec<usize> = (0..ps.len()).collect();
    let mut s = secondary_column(&ps, &members).unwrap();
    let m: f64 = ps.iter().map(|q| q.mass).sum();
    assert!((s.velocity.z * m - down.z * m).abs() < 1e-9 * m, "vertical momentum kept: {}", s.velocity.z);
    let z0 = s.position.z;
    let (mut lowest, mut t) = (z0, 0.0);
    while s.phase != Phase::Umbrella && t < 600.0 {
        s.step(&p, &e, 0.02);
        lowest = lowest.min(s.position.z);
        t += 0.02;
    }
    assert!(lowest < z0, "sank first with the flow's momentum: lowest {lowest} from {z0}");
    assert_eq!(s.phase, Phase::Umbrella, "reached an apex within 600 s");
    assert!(s.apex > z0 + 200.0, "rose: apex {} m from {z0} m", s.apex);
}

#[test]
fn bad_parameters_are_errors() {
    for bad in [
        PyroclasticParams { sigma_pyr: -1.0, ..Default::default() },
        PyroclasticParams { cluster_radius: f64::NAN, ..Default::default() },
        PyroclasticParams { deposit_density: 0.0, ..Default::default() },
        PyroclasticParams { max_travel: 0.0, ..Default::default() },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
    assert!(PyroclasticParams::default().validate().is_ok());
}
