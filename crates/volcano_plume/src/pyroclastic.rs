//! [`PyroclasticPlugin`]: collapsed slices become pyroclastic particles (entities) that run
//! over the terrain, deposit ash on a [`DepositMap`], and lift off again as secondary columns
//! (thesis §3.6). Runs in its own domain, `PyroclasticStep`, once per base tick (0.02 s) after
//! the plume domain; the model substeps where particles are fast. The domain's whole step is
//! the model's [`crate::model::flows::step`]: one system gathers the particles, books and
//! deposit maps, calls it and writes back (docs/ARCHITECTURE.md §2.1).

use bevy::ecs::entity::EntityHashMap;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::components::*;
use crate::ground::{DepositMap, PyroclasticBudget};
use crate::model::flows::{
    self, Collapsed, FlowInputs, FlowParticle, FlowsState, VolcanoFlows, VolcanoInputs,
};
use crate::model::pyroclastic::Particle;

/// Schedule of the pyroclastic domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, TypePath)]
pub struct PyroclasticStep;

/// The pyroclastic domain's step, in order, inside [`PyroclasticStep`]: games order their
/// systems against these.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PyroclasticSystems {
    /// Before the step (empty; for a game's systems, e.g. to edit particles or send
    /// [`SliceCollapsed`] of its own).
    Prepare,
    /// The model step ([`crate::model::flows::step`]): collapsed slices ([`SliceCollapsed`])
    /// become particles, particles move, deposit and are capped, the deposit relaxes, buoyant
    /// particles lift off; then the entities, books and maps are written back and
    /// [`PyroclasticFlowStarted`], [`SecondaryColumnFormed`] and [`SecondaryColumnRising`] sent.
    Step,
}

/// One pyroclastic sphere. Its `Transform` is kept in world space (scale = radius).
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub struct PyroParticle {
    /// Volcano whose collapse produced it.
    #[entities]
    pub volcano: Entity,
    /// Model state in the vent's plume frame.
    pub particle: Particle,
    /// Vent position (world).
    pub vent: Vec3,
    /// Stable id (slice index << 16 | k), for rendering.
    pub id: u64,
    /// Lighter than the air after its last step (a secondary-column candidate).
    pub buoyant: bool,
}

/// A collapsing slice turned into pyroclastic particles.
#[derive(Message, Debug, Clone, Copy, PartialEq)]
pub struct PyroclasticFlowStarted {
    /// Emitting volcano.
    pub volcano: Entity,
    /// World position of the collapse.
    pub position: Vec3,
    /// Particles spawned.
    pub particles: usize,
    /// Their total mass (kg).
    pub mass: f64,
}

/// Buoyant particles lifted off as a new rising slice.
#[derive(Message, Debug, Clone, Copy, PartialEq)]
pub struct SecondaryColumnFormed {
    /// Volcano whose flow it came from.
    pub volcano: Entity,
    /// World position of the new slice.
    pub position: Vec3,
    /// Its mass (kg).
    pub mass: f64,
    /// Particles it replaced.
    pub particles: usize,
}

/// Pyroclastic particles, deposit and secondary columns.
#[derive(Debug, Default, Clone)]
pub struct PyroclasticPlugin;

impl Plugin for PyroclasticPlugin {
    fn build(&self, app: &mut App) {
        app.add_sim_domain::<PyroclasticStep>(SimSystems::Pyroclastic, Cadence::Substeps(1))
            .add_message::<PyroclasticFlowStarted>()
            .add_message::<SecondaryColumnFormed>()
            .add_message::<SliceCollapsed>()
            .add_message::<SecondaryColumnRising>()
            // Owned by volcano_core; registering twice is harmless.
            .add_message::<volcano_core::SimFault>()
            // Every terrain keeps the deposit of the volcanoes standing on it.
            .register_required_components::<Terrain, DepositMap>()
            .register_type::<PyroParticle>()
            .register_type::<DepositMap>()
            .register_type::<PyroclasticBudget>()
            .configure_sets(PyroclasticStep, (PyroclasticSystems::Prepare, PyroclasticSystems::Step).chain())
            .add_systems(PyroclasticStep, step_flows.in_set(PyroclasticSystems::Step))
            .add_systems(PreUpdate, prepare_deposit_maps);
    }
}

/// Creates the deposit maps of the terrains erupting volcanoes stand on as soon as they stand
/// there ([`DepositMap::ensure`], its pages written), outside the simulation's ticks: the step
/// would create them in its first tick, and the first deposit relaxation would map their
/// memory in some later one.
fn prepare_deposit_maps(
    volcanoes: Query<&OnTerrain, (With<Eruption>, Changed<OnTerrain>)>,
    mut grounds: Query<(&Terrain, &mut DepositMap)>,
) {
    for on in &volcanoes {
        if let Ok((terrain, mut map)) = grounds.get_mut(on.0)
            && !map.fits(terrain)
        {
            map.ensure(terrain);
        }
    }
}

pub use crate::model::flows::MAX_PARTICLES_PER_SLICE;

type Eruptions<'a> = (
    Entity,
    &'a Eruption,
    &'a VolcanoRng,
    &'a mut PyroclasticBudget,
    &'a mut EmissionState,
    Option<&'a OnTerrain>,
);

/// The domain's step: gathers every erupting volcano's particles (in id order, as the model
/// keeps them), books and collapsed slices and every terrain's deposit map, runs
/// [`flows::step`] and writes back:
/// particle entities updated, spawned or despawned, books and maps put back, messages sent,
/// what the caps did added to [`crate::caps::PlumeCapReport`]. Particles whose volcano is gone
/// (or has no eruption) are despawned unbooked.
#[allow(clippy::too_many_arguments)]
fn step_flows(
    time: Res<Time>,
    caps: Res<crate::caps::PlumeCaps>,
    mut cap_report: ResMut<crate::caps::PlumeCapReport>,
    mut commands: Commands,
    mut collapsed: MessageReader<SliceCollapsed>,
    mut eruptions: Query<Eruptions>,
    mut grounds: Query<(Entity, &Terrain, &mut DepositMap)>,
    mut particles: Query<(Entity, &mut PyroParticle, &mut Transform)>,
    mut started: MessageWriter<PyroclasticFlowStarted>,
    mut formed: MessageWriter<SecondaryColumnFormed>,
    mut rising: MessageWriter<SecondaryColumnRising>,
    mut faults: MessageWriter<volcano_core::SimFault>,
) {
    let handed: Vec<&PlumeSlice> = collapsed.read().map(|SliceCollapsed(s)| s).collect();
    // Terrains and their maps (taken out, put back below: no copy, no change flag unless
    // the step changed the map).
    let mut maps: Vec<(Entity, &Terrain, Mut<DepositMap>)> = grounds.iter_mut().collect();
    let terrain_index: EntityHashMap<usize> = maps.iter().enumerate().map(|(g, (e, ..))| (*e, g)).collect();
    let terrains: Vec<&Terrain> = maps.iter().map(|(_, t, _)| *t).collect();
    let mut state = FlowsState {
        volcanoes: Vec::new(),
        grounds: maps.iter_mut().map(|(_, _, m)| std::mem::take(m.bypass_change_detection())).collect(),
    };
    // Volcanoes, their collapsed slices and their particles (in query order).
    let mut volcanoes: Vec<_> = eruptions.iter_mut().collect();
    // Looked up once per particle: Bevy's entity hash, not SipHash.
    let index: EntityHashMap<usize> = volcanoes.iter().enumerate().map(|(v, e)| (e.0, v)).collect();
    let mut collapses: Vec<Vec<Collapsed>> = vec![Vec::new(); volcanoes.len()];
    for slice in handed {
        if let Some(&v) = index.get(&slice.volcano) {
            collapses[v].push(Collapsed { index: slice.index, vent: slice.vent, state: slice.state.clone() });
        }
    }
    state.volcanoes = volcanoes
        .iter()
        .map(|(_, _, _, budget, emission, _)| VolcanoFlows {
            particles: Vec::new(),
            budget: **budget,
            emitted: emission.emitted,
        })
        .collect();
    // The particle entities in query order (read here, written back below by a second pass in
    // the same order: nothing spawns or despawns in between, the commands wait).
    let count = particles.iter().len();
    let mut entities: Vec<Entity> = Vec::with_capacity(count);
    // Per volcano, the query positions of its particles, in the state's order.
    let mut owned: Vec<Vec<usize>> = vec![Vec::new(); volcanoes.len()];
    // One erupting volcano (the usual case) owns every particle: its lists are sized once
    // instead of growing (30,000 particles: a dozen reallocations and 7 MB copied a tick).
    if let ([own], [flows]) = (owned.as_mut_slice(), state.volcanoes.as_mut_slice()) {
        own.reserve(count);
        flows.particles.reserve(count);
    }
    // Consecutive particles mostly belong to the same volcano: looked up once per run.
    let mut last: Option<(Entity, Option<usize>)> = None;
    for (k, (entity, pp, _)) in particles.iter().enumerate() {
        entities.push(entity);
        let found = match last {
            Some((e, found)) if e == pp.volcano => found,
            _ => {
                let found = index.get(&pp.volcano).copied();
                last = Some((pp.volcano, found));
                found
            }
        };
        let Some(v) = found else {
            // Its volcano is gone (or has no eruption): nothing books it.
            commands.entity(entity).despawn();
            continue;
        };
        owned[v].push(k);
        state.volcanoes[v].particles.push(FlowParticle {
            id: pp.id,
            vent: pp.vent,
            particle: pp.particle,
            buoyant: pp.buoyant,
        });
    }
    // The model keeps each volcano's particles in id order (a new one gets the next id, a
    // removal keeps the order); the query's order drifts from it as despawns swap-remove.
    // Stepped in the query's order, two particles depositing on one node in one step would be
    // summed in another order than the model alone sums them (1 ulp apart). So, in id order.
    for (own, flows) in owned.iter_mut().zip(&mut state.volcanoes) {
        if !flows.particles.is_sorted_by_key(|p| p.id) {
            // Keys (id − lowest id) << 32 | position, sorted by the run-adaptive stable sort:
            // the query's order is the id order broken only where a despawn moved the last
            // entity into its hole. Measured (perf, `volcano bench --scene eruption_collapse
            // --seconds 60`): 2.1 % of the samples; 3.4 % with (id, position) pairs as keys,
            // 3.7 % for an unstable sort by an indirect key. Live ids spanning 2³² or more
            // (2¹⁶ slices between the oldest live particle's and the newest's) fall back to
            // the pairs.
            let order = id_order(&flows.particles);
            *own = order.iter().map(|&i| own[i]).collect();
            flows.particles = order.iter().map(|&i| flows.particles[i]).collect();
        }
    }
    let inputs: Vec<VolcanoInputs> = volcanoes
        .iter()
        .zip(&collapses)
        .map(|((_, eruption, rng, _, _, on), collapsed)| VolcanoInputs {
            plume: &eruption.params,
            pyroclastic: &eruption.pyroclastic,
            rng,
            ground: on.and_then(|o| terrain_index.get(&o.0).copied()),
            collapsed,
        })
        .collect();
    let caps = crate::caps::checked(&caps);
    let report = flows::step(
        &mut state,
        &FlowInputs {
            dt: time.delta_secs_f64(),
            relax_passes: volcano_core::clock::crossings(
                time.elapsed(),
                time.delta(),
                flows::RELAX_PERIOD.0,
                flows::RELAX_PERIOD.1,
            )
            .min(64) as u32,
            max_particles: caps.max_particles as usize,
            max_secondary_per_step: caps.max_secondary_per_step as usize,
            volcanoes: &inputs,
            terrains: &terrains,
        },
    );
    // Write back: maps, books, particles, messages.
    for (((_, _, map), deposit), changed) in maps.iter_mut().zip(state.grounds).zip(&report.grounds_changed) {
        *map.bypass_change_detection() = deposit;
        if *changed {
            map.set_changed();
        }
    }
    // The held particles the step kept: where each went, by query position (volcano, place in
    // its list), written back in one pass over the query in the order it was read.
    let mut dest = vec![(u32::MAX, 0u32); entities.len()];
    for (v, out) in report.volcanoes.iter().enumerate() {
        for (j, &from) in out.kept.iter().enumerate() {
            if from < out.held {
                dest[owned[v][from]] = (v as u32, j as u32);
            }
        }
    }
    for ((_, mut pp, mut transform), &(v, j)) in particles.iter_mut().zip(&dest) {
        if v == u32::MAX {
            continue;
        }
        let fp = &state.volcanoes[v as usize].particles[j as usize];
        pp.particle = fp.particle;
        pp.buoyant = fp.buoyant;
        transform.translation = fp.vent + plume_to_world(fp.particle.position);
        transform.scale = Vec3::splat(fp.particle.radius as f32);
    }
    for (v, (flows, out)) in state.volcanoes.into_iter().zip(&report.volcanoes).enumerate() {
        let (volcano, _, _, budget, emission, _) = &mut volcanoes[v];
        let volcano = *volcano;
        budget.set_if_neq(flows.budget);
        crate::faults::report(&mut faults, volcano, SimDomain::Pyroclastic, &out.non_finite);
        if emission.emitted != flows.emitted {
            emission.emitted = flows.emitted;
        }
        let mut new = Vec::new();
        // The particles it spawned (the held ones were written above).
        for (fp, _) in flows.particles.iter().zip(&out.kept).filter(|(_, from)| **from >= out.held) {
            let world = fp.vent + plume_to_world(fp.particle.position);
            let scale = Vec3::splat(fp.particle.radius as f32);
            let pp = PyroParticle {
                volcano,
                particle: fp.particle,
                vent: fp.vent,
                id: fp.id,
                buoyant: fp.buoyant,
            };
            new.push((Transform::from_translation(world).with_scale(scale), pp));
        }
        commands.spawn_batch(new);
        for s in &out.started {
            started.write(PyroclasticFlowStarted {
                volcano,
                position: s.position,
                particles: s.particles,
                mass: s.mass,
            });
        }
        for c in &out.columns {
            formed.write(SecondaryColumnFormed {
                volcano,
                position: c.position,
                mass: c.state.mass,
                particles: c.particles,
            });
            rising.write(SecondaryColumnRising(PlumeSlice {
                volcano,
                index: c.index,
                vent: c.vent,
                state: c.state.clone(),
                ring_phase: 0.0,
                ash_pending: 0.0,
                secondary: true,
            }));
        }
        if out.secondary_retired > 0 {
            warn_once!(
                "eruption {volcano}: more than {} secondary columns in one step; the lighter clusters lift off \
                 without a simulated column (PlumeCaps::max_secondary_per_step, PlumeCapReport)",
                caps.max_secondary_per_step
            );
            cap_report.secondary_retired += out.secondary_retired;
            cap_report.secondary_retired_kg += out.secondary_retired_kg;
        }
    }
    for &(v, i) in &report.removed {
        // Particles spawned and removed in the same step were never entities.
        if let Some(&k) = owned.get(v).and_then(|o| o.get(i)) {
            commands.entity(entities[k]).despawn();
        }
    }
    if report.particles_settled > 0 {
        warn_once!(
            "more than {} pyroclastic particles: the oldest settle where they are (PlumeCaps::max_particles, \
             PlumeCapReport)",
            caps.max_particles
        );
        cap_report.particles_settled += report.particles_settled;
        cap_report.particle_kg += report.particle_kg;
    }
    cap_report.capped_steps += report.capped;
}

/// Positions of `particles` in id order (ids are unique).
fn id_order(particles: &[FlowParticle]) -> Vec<usize> {
    let lowest = particles.iter().map(|p| p.id).min().unwrap_or(0);
    let packed = particles.len() <= u32::MAX as usize
        && particles.iter().all(|p| p.id - lowest <= u64::from(u32::MAX));
    if packed {
        let mut keys: Vec<u64> =
            particles.iter().enumerate().map(|(i, p)| (p.id - lowest) << 32 | i as u64).collect();
        keys.sort();
        keys.iter().map(|k| (k & u64::from(u32::MAX)) as usize).collect()
    } else {
        let mut keys: Vec<(u64, usize)> = particles.iter().enumerate().map(|(i, p)| (p.id, i)).collect();
        keys.sort();
        keys.iter().map(|&(_, i)| i).collect()
    }
}

/// Gameplay queries: "is this point inside a pyroclastic flow?", "how thick is the deposit
/// here?". Linear in the number of particles (≈50 µs for 50,000), fine for a few queries per
/// frame.
#[derive(SystemParam)]
pub struct PyroclasticQuery<'w, 's> {
    grounds: Query<'w, 's, (&'static Terrain, &'static DepositMap)>,
    particles: Query<'w, 's, &'static Transform, With<PyroParticle>>,
}

impl PyroclasticQuery<'_, '_> {
    /// Whether world point `p` is within `margin` metres of any pyroclastic particle.
    pub fn in_flow(&self, p: Vec3, margin: f32) -> bool {
        self.particles.iter().any(|t| t.translation.distance(p) <= t.scale.x + margin)
    }
    /// Deposit thickness (m) at world `(x, z)`, on the first terrain whose footprint holds it.
    pub fn deposit_thickness(&self, x: f32, z: f32) -> f64 {
        self.grounds.iter().find(|(t, _)| t.contains(x, z)).map_or(0.0, |(_, d)| d.thickness_at(x, z))
    }
    /// Live particles.
    pub fn particle_count(&self) -> usize {
        self.particles.iter().count()
    }
}

/// Total mass of live particles (kg), for budgets.
pub fn airborne_mass(world: &mut World) -> f64 {
    world.query::<&PyroParticle>().iter(world).map(|p| p.particle.mass).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn particles(ids: &[u64]) -> Vec<FlowParticle> {
        ids.iter()
            .map(|&id| FlowParticle {
                id,
                vent: Vec3::ZERO,
                particle: Particle {
                    position: bevy::math::DVec3::ZERO,
                    velocity: bevy::math::DVec3::ZERO,
                    radius: 1.0,
                    mass: 1.0,
                    temperature: 300.0,
                    grounded: false,
                },
                buoyant: false,
            })
            .collect()
    }

    #[test]
    fn id_order_sorts_packed_and_wide_spans_alike() {
        // A despawn's swap-remove: the last particle moved into a hole.
        let swapped = particles(&[3 << 16, 9 << 16, (5 << 16) | 2, (5 << 16) | 1, 7 << 16]);
        assert_eq!(id_order(&swapped), vec![0, 3, 2, 4, 1]);
        // Ids 2³² and more apart take the pairs: the same order.
        let wide = particles(&[1 << 40, 5, (1 << 40) + 1, 7]);
        assert_eq!(id_order(&wide), vec![1, 3, 0, 2]);
        assert!(id_order(&[]).is_empty());
    }
}
