//! The pyroclastic domain step's report and books: a collapse running down a cone closes its
//! mass books and its deposit, the particle cap settles the oldest of all volcanoes, a volcano
//! without ground loses what it hands over, the secondary-column cap keeps the heaviest.

use bevy::math::{DVec3, Vec3};
use volcano_core::{StratovolcanoParams, Terrain, VolcanoRng};

use super::*;
use crate::model::params::Preset;
use crate::model::pyroclastic::PyroclasticParams;
use crate::model::slice::{Phase, Slice};

fn cone() -> Terrain {
    StratovolcanoParams {
        resolution: 64,
        cell: 100.0,
        crater_radius: 80.0,
        crater_depth: 10.0,
        ..Default::default()
    }
    .generate()
    .unwrap()
}

/// A collapsing slice 300 m above the vent, falling.
fn collapsing(index: u64, vent: Vec3) -> Collapsed {
    let mut state = Slice::at_vent(&Preset::PyroclasticShowcase.params());
    state.position = DVec3::new(0.0, 0.0, 300.0);
    state.velocity = DVec3::new(0.0, 0.0, -20.0);
    state.phase = Phase::Collapsed;
    Collapsed { index, vent, state }
}

fn particle(id: u64, x: f64, mass: f64) -> FlowParticle {
    FlowParticle {
        id,
        vent: Vec3::ZERO,
        particle: Particle {
            position: DVec3::new(x, 0.0, 5_000.0),
            velocity: DVec3::ZERO,
            radius: 10.0,
            mass,
            temperature: 900.0,
            grounded: false,
        },
        buoyant: false,
    }
}

#[test]
fn a_collapse_runs_down_and_closes_its_books() {
    let terrain = cone();
    let vent = Vec3::new(0.0, terrain.height_at(0.0, 0.0), 0.0);
    let (p, py, rng) =
        (Preset::PyroclasticShowcase.params(), PyroclasticParams::default(), VolcanoRng::new(3));
    let mut state =
        FlowsState { volcanoes: vec![VolcanoFlows::default()], grounds: vec![Default::default()] };
    let terrains = [&terrain];
    let handed = [collapsing(7, vent)];
    let mut deposited_steps = 0;
    for tick in 0..1_500 {
        let collapsed: &[Collapsed] = if tick == 0 { &handed } else { &[] };
        let volcanoes =
            [VolcanoInputs { plume: &p, pyroclastic: &py, rng: &rng, ground: Some(0), collapsed }];
        let held = state.volcanoes[0].particles.len();
        let report = step(
            &mut state,
            &FlowInputs {
                dt: 0.02,
                relax_passes: if tick % 50 == 49 { 4 } else { 0 },
                max_particles: 1_000_000,
                max_secondary_per_step: 1_000,
                volcanoes: &volcanoes,
                terrains: &terrains,
            },
        );
        let out = &report.volcanoes[0];
        assert_eq!(out.held, held);
        if tick == 0 {
            assert_eq!(out.started.len(), 1);
            assert!(out.started[0].particles > 100, "{:?}", out.started[0]);
            assert!((out.started[0].mass - handed[0].state.mass).abs() <= 1e-9 * handed[0].state.mass);
        }
        // The survivors are listed in order, each once, among those held and spawned.
        let spawned: usize = out.started.iter().map(|s| s.particles).sum();
        assert!(out.kept.windows(2).all(|w| w[0] < w[1]));
        assert!(out.kept.last().is_none_or(|&k| k < held + spawned));
        assert_eq!(out.kept.len(), state.volcanoes[0].particles.len());
        deposited_steps += usize::from(report.grounds_changed[0]);
    }
    let b = state.volcanoes[0].budget;
    let airborne = state.airborne_kg();
    assert!(b.deposited > 0.0 && deposited_steps > 0, "{b:?}");
    let total = airborne + b.deposited + b.lifted + b.lost;
    assert!((total - b.collapsed).abs() <= 1e-9 * b.collapsed, "{b:?}, airborne {airborne}");
    let map = state.grounds[0].total();
    assert!((map - b.deposited).abs() <= 1e-9 * b.deposited, "map {map} vs books {}", b.deposited);
    // Secondary columns took the volcano's next slice numbers.
    assert_eq!(state.volcanoes[0].emitted, b.secondary_columns);
}

#[test]
fn the_particle_cap_settles_the_oldest_of_every_volcano() {
    let terrain = cone();
    let (p, py, rng) =
        (Preset::PyroclasticShowcase.params(), PyroclasticParams::default(), VolcanoRng::new(1));
    // Volcano 0 holds ids 5 and 1, volcano 1 ids 3 and 2: with room for 2, ids 1 and 2 settle.
    let mut state = FlowsState {
        volcanoes: vec![
            VolcanoFlows {
                particles: vec![particle(5, 0.0, 1e4), particle(1, 100.0, 2e4)],
                ..Default::default()
            },
            VolcanoFlows {
                particles: vec![particle(3, 0.0, 3e4), particle(2, 200.0, 4e4)],
                ..Default::default()
            },
        ],
        grounds: vec![Default::default()],
    };
    let v = |ground| VolcanoInputs { plume: &p, pyroclastic: &py, rng: &rng, ground, collapsed: &[] };
    let volcanoes = [v(Some(0)), v(Some(0))];
    let report = step(
        &mut state,
        &FlowInputs {
            dt: 0.02,
            relax_passes: 0,
            max_particles: 2,
            max_secondary_per_step: 1_000,
            volcanoes: &volcanoes,
            terrains: &[&terrain],
        },
    );
    let ids: Vec<Vec<u64>> =
        state.volcanoes.iter().map(|f| f.particles.iter().map(|q| q.id).collect()).collect();
    assert_eq!(ids, vec![vec![5], vec![3]]);
    assert_eq!((report.volcanoes[0].kept.clone(), report.volcanoes[1].kept.clone()), (vec![0], vec![0]));
    assert_eq!(report.particles_settled, 2);
    assert_eq!(report.capped, 1);
    // Settled on the ground where they were: deposited, on the map, booked as capped.
    let (b0, b1) = (state.volcanoes[0].budget, state.volcanoes[1].budget);
    assert!(b0.deposited == 2e4 && b1.deposited == 4e4, "{b0:?} {b1:?}");
    assert_eq!((b0.capped_particles, b1.capped_particles), (1, 1));
    assert_eq!(state.grounds[0].total(), 6e4);
    assert_eq!(report.particle_kg, 6e4);
}

#[test]
fn a_volcano_without_ground_loses_what_it_hands_over() {
    let (p, py, rng) =
        (Preset::PyroclasticShowcase.params(), PyroclasticParams::default(), VolcanoRng::new(2));
    let handed = [collapsing(4, Vec3::ZERO)];
    // Ground index 3 does not exist: no ground.
    let volcanoes =
        [VolcanoInputs { plume: &p, pyroclastic: &py, rng: &rng, ground: Some(3), collapsed: &handed }];
    let mut state = FlowsState { volcanoes: vec![VolcanoFlows::default()], grounds: Vec::new() };
    let report = step(
        &mut state,
        &FlowInputs {
            dt: 0.02,
            relax_passes: 4,
            max_particles: 1_000_000,
            max_secondary_per_step: 1,
            volcanoes: &volcanoes,
            terrains: &[],
        },
    );
    let b = state.volcanoes[0].budget;
    assert!(state.volcanoes[0].particles.is_empty() && report.volcanoes[0].kept.is_empty());
    assert!(b.collapsed > 0.0 && (b.lost - b.collapsed).abs() <= 1e-9 * b.collapsed, "{b:?}");
}

#[test]
fn the_heaviest_clusters_are_kept_in_order() {
    let mut groups = vec![vec![0], vec![1, 2], vec![3], vec![4, 5, 6], vec![7]];
    let mass = |g: &[usize]| g.len() as f64;
    assert_eq!(heaviest_clusters(&mut groups, mass, 3), vec![vec![3], vec![7]]);
    // Masses 1, 2, 1, 3, 1: keeps 2 and 3, then the first of the 1s.
    assert_eq!(groups, vec![vec![0], vec![1, 2], vec![4, 5, 6]]);
    assert!(heaviest_clusters(&mut groups, mass, 3).is_empty());
}
