//! [`PyroclasticPlugin`]: collapsed slices become pyroclastic particles (entities) that run
//! over the terrain, deposit ash on a [`DepositMap`], and lift off again as secondary columns
//! (thesis §3.6). Runs in its own domain, `PyroclasticStep`, once per base tick (0.02 s) after
//! the plume domain; the model substeps where particles are fast.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use volcano_core::parallel::Bands;
use volcano_core::prelude::*;

use crate::components::*;
use crate::ground::{DepositMap, PyroclasticBudget};
use crate::model::deposit;
use crate::model::pyroclastic::{Particle, collapse, find_clusters, secondary_column, step_particle};
use crate::model::slice::SliceEnv;
use crate::model::spheres::SphereParams;

/// Schedule of the pyroclastic domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, TypePath)]
pub struct PyroclasticStep;

/// The pyroclastic domain's step, in order, inside [`PyroclasticStep`]: games and the plume
/// domain order their systems against these.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PyroclasticSystems {
    /// Collapsed slices ([`SliceCollapsed`]) become particles.
    HandOver,
    /// Particles move, deposit and are capped; the deposit relaxes.
    Step,
    /// Buoyant particles lift off as secondary columns ([`SecondaryColumnRising`]).
    LiftOff,
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
            // Every terrain keeps the deposit of the volcanoes standing on it.
            .register_required_components::<Terrain, DepositMap>()
            .register_type::<PyroParticle>()
            .register_type::<DepositMap>()
            .register_type::<PyroclasticBudget>()
            .add_systems(
                PyroclasticStep,
                (
                    hand_over.in_set(PyroclasticSystems::HandOver),
                    (step_particles, cap_particles, relax_deposit).chain().in_set(PyroclasticSystems::Step),
                    lift_secondary_columns.in_set(PyroclasticSystems::LiftOff),
                )
                    .chain(),
            );
    }
}

/// Largest number of particles one collapsing slice becomes (N = round(V/V_s2) is ~750 with
/// the thesis' sphere sizes; the cap only matters for extreme edits).
pub const MAX_PARTICLES_PER_SLICE: usize = 2_000;

/// Collapsed slices (handed over by the plume step as [`SliceCollapsed`]) become particles.
fn hand_over(
    mut commands: Commands,
    mut collapsed: MessageReader<SliceCollapsed>,
    mut eruptions: Query<(&VolcanoRng, &mut PyroclasticBudget)>,
    mut started: MessageWriter<PyroclasticFlowStarted>,
) {
    for SliceCollapsed(slice) in collapsed.read() {
        let Ok((rng, mut budget)) = eruptions.get_mut(slice.volcano) else { continue };
        // s2 radius: s1 spheres have radius r/2, their children ÷5.
        let r_s2 = 0.5 * slice.state.r * SphereParams::CHILD_RATIO;
        let mut stream = rng.stream("collapse", slice.index);
        let particles = collapse(&slice.state, r_s2, MAX_PARTICLES_PER_SLICE, &mut stream);
        let mass: f64 = particles.iter().map(|p| p.mass).sum();
        budget.collapsed += mass;
        budget.spawned += particles.len() as u64;
        started.write(PyroclasticFlowStarted {
            volcano: slice.volcano,
            position: slice.vent + plume_to_world(slice.state.position),
            particles: particles.len(),
            mass,
        });
        let n = particles.len();
        let (vent, volcano, index) = (slice.vent, slice.volcano, slice.index);
        let bundles: Vec<_> = particles
            .into_iter()
            .enumerate()
            .map(|(k, particle)| {
                let world = vent + plume_to_world(particle.position);
                (
                    Transform::from_translation(world).with_scale(Vec3::splat(particle.radius as f32)),
                    PyroParticle { volcano, particle, vent, id: (index << 16) | k as u64, buoyant: false },
                )
            })
            .collect();
        commands.spawn_batch(bundles);
        debug!("slice {} collapsed into {n} pyroclastic particles", slice.index);
    }
}

/// One step of every particle, in parallel over fixed chunks; deposits, budgets and despawns
/// are then applied in query order, so the result does not depend on the thread count. A
/// particle runs over the deposit surface of its volcano's terrain ([`OnTerrain`]) and
/// deposits there; off that terrain it is lost.
fn step_particles(
    time: Res<Time>,
    mut commands: Commands,
    eruptions: Query<(&Eruption, Option<&OnTerrain>)>,
    mut budgets: Query<&mut PyroclasticBudget>,
    mut grounds: Query<(&Terrain, &mut DepositMap)>,
    mut particles: Query<(Entity, &mut PyroParticle, &mut Transform)>,
) {
    let dt = time.delta_secs_f64();
    if particles.is_empty() {
        return;
    }
    // The maps of the terrains volcanoes stand on (read without flagging a change).
    for (_, on) in &eruptions {
        if let Some(OnTerrain(t)) = on
            && let Ok((terrain, mut deposit)) = grounds.get_mut(*t)
            && !deposit.fits(terrain)
        {
            deposit.ensure(terrain);
        }
    }
    let mut items: Vec<_> = particles.iter_mut().collect();
    let outcomes = {
        let grounds = &grounds;
        par_map_ordered(&mut items, |(_, pp, transform)| {
            let (eruption, on) = eruptions.get(pp.volcano).ok()?;
            let terrain = on.map(|o| o.0);
            let ground = terrain.and_then(|t| grounds.get(t).ok());
            let surface = ground.and_then(|(_, d)| d.surface.as_ref());
            let p = &eruption.params;
            let wind = |z: f64| p.wind.at(z);
            let vent = pp.vent;
            let env = SliceEnv { air: p.atmosphere.profile(), vent_altitude: vent.y as f64, wind: &wind };
            let below = |x: f64, y: f64| ground_below(surface, vent, x, y);
            let report = step_particle(&mut pp.particle, &eruption.pyroclastic, &env, &below, dt);
            pp.buoyant = report.buoyant;
            let world = vent + plume_to_world(pp.particle.position);
            transform.translation = world;
            transform.scale = Vec3::splat(pp.particle.radius as f32);
            let on_map = ground.is_some_and(|(t, _)| t.contains(world.x, world.z));
            let py = &eruption.pyroclastic;
            Some((report, on_map.then_some(terrain).flatten(), (py.deposit_density, py.repose_angle_deg)))
        })
    };
    for ((entity, pp, _), outcome) in items.iter().zip(outcomes) {
        let Ok(mut budget) = budgets.get_mut(pp.volcano) else {
            // Its volcano is gone (or has no eruption): nothing books it.
            commands.entity(*entity).despawn();
            continue;
        };
        let Some((report, terrain, (density, repose))) = outcome else {
            budget.lost += pp.particle.mass;
            commands.entity(*entity).despawn();
            continue;
        };
        if report.deposited > 0.0 {
            match terrain.and_then(|t| grounds.get_mut(t).ok()) {
                Some((_, mut deposit)) if deposit.mass.is_some() => {
                    deposit.bulk_density = density;
                    deposit.repose_angle_deg = repose;
                    let at = pp.vent + plume_to_world(report.deposit_at.extend(0.0));
                    deposit.add(Vec2::new(at.x, at.z), report.deposited);
                    budget.deposited += report.deposited;
                }
                _ => budget.lost += report.deposited,
            }
        }
        if report.settled || terrain.is_none() || !finite(&pp.particle) {
            if !report.settled && pp.particle.mass.is_finite() {
                budget.lost += pp.particle.mass;
            }
            commands.entity(*entity).despawn();
        }
    }
}

/// `f` over `items` on the compute task pool in fixed chunks of 512 ([`Bands`] of
/// `volcano_core::parallel`); results in item order.
/// Used for the particle step (and its bench) so the outcome is independent of the threads.
pub fn par_map_ordered<T: Send, R: Send + 'static>(
    items: &mut [T],
    f: impl Fn(&mut T) -> R + Sync,
) -> Vec<R> {
    const CHUNK: usize = 512;
    // Bands of CHUNK one-item rows (volcano_core::parallel); one band runs inline.
    let chunks = Bands::of(CHUNK).map(items, 1, |_, chunk| chunk.iter_mut().map(&f).collect::<Vec<R>>());
    chunks.into_iter().flatten().collect()
}

/// Height (plume frame, m above the vent at world `vent`) of the collision surface, terrain +
/// deposit, under plume-frame `(x, y)`; −∞ without a map. Plume frame (x, y horizontal, z up
/// from the vent) ↔ world (x, z = −y, y up).
fn ground_below(surface: Option<&Grid2<f32>>, vent: Vec3, x: f64, y: f64) -> f64 {
    match surface {
        Some(s) => {
            (s.sample(Vec2::new(vent.x + x as f32, vent.z - y as f32), Boundary::Clamp) - vent.y) as f64
        }
        None => f64::NEG_INFINITY,
    }
}

fn finite(p: &Particle) -> bool {
    p.position.is_finite() && p.velocity.is_finite() && p.mass.is_finite()
}

/// Once per simulated second of the pyroclastic clock (every 50 steps at 50 Hz, 64 at 64 Hz)
/// every terrain's deposit relaxes to its angle of repose (a few Jacobi passes) and the
/// collision surface follows.
fn relax_deposit(time: Res<Time>, mut grounds: Query<(&Terrain, &mut DepositMap)>) {
    const PASSES: usize = 4;
    if !volcano_core::clock::crossed_period(time.elapsed(), time.delta(), std::time::Duration::from_secs(1)) {
        return;
    }
    for (terrain, mut map) in &mut grounds {
        let h = terrain.heights();
        if map.mass.as_ref().is_none_or(|m| h.nx() != m.nx() || h.ny() != m.ny()) {
            continue;
        }
        let map = &mut *map;
        let (Some(mass), Some(surface)) = (map.mass.as_mut(), map.surface.as_mut()) else { continue };
        // A map that only received ash fall has no eruption's angle yet.
        let angle = if map.repose_angle_deg > 0.0 {
            map.repose_angle_deg
        } else {
            crate::PyroclasticParams::default().repose_angle_deg
        };
        let tan = angle.to_radians().tan();
        let (dims, cell) = ((mass.nx(), mass.ny()), mass.cell());
        let mut moved = 0.0;
        for _ in 0..PASSES {
            moved += deposit::relax_to_repose(
                h.data(),
                mass.data_mut(),
                dims,
                cell,
                map.bulk_density,
                tan,
                &mut map.scratch,
            );
        }
        if moved > 0.0 {
            deposit::deposit_surface(h.data(), mass.data(), cell, map.bulk_density, surface.data_mut());
            map.revision += 1;
        }
    }
}

/// Buoyant particles, per volcano, gather into clusters that become rising slices. Buoyant
/// particles no cluster took that have risen more than r_pyr above the ground have left their
/// flow: they lift off with the others like them within r_pyr (the same seed rule, any
/// number), or alone, instead of hanging in the air for ever.
#[allow(clippy::too_many_arguments)]
fn lift_secondary_columns(
    caps: Res<crate::caps::PlumeCaps>,
    mut report: ResMut<crate::caps::PlumeCapReport>,
    mut commands: Commands,
    mut eruptions: Query<(Entity, &Eruption, &mut EmissionState, &mut PyroclasticBudget, Option<&OnTerrain>)>,
    particles: Query<(Entity, &PyroParticle)>,
    grounds: Query<&DepositMap>,
    mut formed: MessageWriter<SecondaryColumnFormed>,
    mut rising: MessageWriter<SecondaryColumnRising>,
) {
    for (volcano, eruption, mut emission, mut budget, on) in &mut eruptions {
        // Candidates in a fixed order (spawn order) for determinism.
        let mut mine: Vec<(Entity, &PyroParticle)> =
            particles.iter().filter(|(_, p)| p.buoyant && p.volcano == volcano).collect();
        let py = &eruption.pyroclastic;
        if mine.is_empty() {
            continue;
        }
        mine.sort_by_key(|(_, p)| p.id);
        let list: Vec<Particle> = mine.iter().map(|(_, p)| p.particle).collect();
        let mut groups = if mine.len() >= py.min_cluster.max(1) as usize {
            let all = vec![true; list.len()];
            find_clusters(&list, &all, py.cluster_radius, py.min_cluster as usize).members
        } else {
            Vec::new()
        };
        let mut taken = vec![false; list.len()];
        for &i in groups.iter().flatten() {
            taken[i] = true;
        }
        let surface = on.and_then(|o| grounds.get(o.0).ok()).and_then(|d| d.surface.as_ref());
        let aloft: Vec<bool> = mine
            .iter()
            .zip(&taken)
            .map(|((_, pp), &t)| {
                let q = pp.particle.position;
                !t && q.z - ground_below(surface, pp.vent, q.x, q.y) > py.cluster_radius
            })
            .collect();
        if aloft.contains(&true) {
            groups.extend(find_clusters(&list, &aloft, py.cluster_radius, 1).members);
        }
        let max = crate::caps::checked(&caps).max_secondary_per_step as usize;
        let mass = |g: &[usize]| g.iter().map(|&i| list[i].mass).sum::<f64>();
        let rest = crate::caps::heaviest_clusters(&mut groups, mass, max);
        if !rest.is_empty() {
            warn_once!(
                "eruption {volcano}: more than {max} secondary columns in one step; the lighter clusters \
                 lift off without a simulated column (PlumeCaps::max_secondary_per_step, PlumeCapReport)"
            );
            for members in &rest {
                let m = mass(members);
                for &i in members {
                    commands.entity(mine[i].0).despawn();
                }
                budget.lifted += m;
                budget.capped += m;
                report.secondary_retired += 1;
                report.secondary_retired_kg += m;
            }
            report.capped_steps += 1;
        }
        for members in &groups {
            let Some(state) = secondary_column(&list, members) else { continue };
            for &i in members {
                commands.entity(mine[i].0).despawn();
            }
            let vent = mine[members[0]].1.vent;
            let index = emission.emitted;
            emission.emitted += 1;
            budget.lifted += state.mass;
            budget.secondary_columns += 1;
            let world = vent + plume_to_world(state.position);
            formed.write(SecondaryColumnFormed {
                volcano,
                position: world,
                mass: state.mass,
                particles: members.len(),
            });
            let slice = PlumeSlice {
                volcano,
                index,
                vent,
                state,
                ring_phase: 0.0,
                ash_pending: 0.0,
                secondary: true,
            };
            rising.write(SecondaryColumnRising(slice));
        }
    }
}

/// Settles the oldest pyroclastic particles beyond [`PlumeCaps::max_particles`] (see
/// [`crate::caps`]).
fn cap_particles(
    caps: Res<crate::caps::PlumeCaps>,
    mut commands: Commands,
    volcanoes: Query<Option<&OnTerrain>>,
    mut budgets: Query<&mut PyroclasticBudget>,
    mut grounds: Query<(&Terrain, &mut DepositMap)>,
    particles: Query<(Entity, &PyroParticle)>,
    mut report: ResMut<crate::caps::PlumeCapReport>,
) {
    let max = crate::caps::checked(&caps).max_particles as usize;
    let n = particles.iter().len();
    if n <= max {
        return;
    }
    warn_once!(
        "more than {max} pyroclastic particles: the oldest settle where they are (PlumeCaps::max_particles, \
         PlumeCapReport)"
    );
    let mut all: Vec<(Entity, &PyroParticle)> = particles.iter().collect();
    all.sort_by_key(|(_, p)| p.id);
    for &(entity, pp) in &all[..n - max] {
        commands.entity(entity).despawn();
        let Ok(mut budget) = budgets.get_mut(pp.volcano) else { continue };
        let m = pp.particle.mass;
        let at = pp.vent + plume_to_world(pp.particle.position);
        let terrain = volcanoes.get(pp.volcano).ok().flatten().map(|o| o.0);
        let ground = terrain
            .and_then(|t| grounds.get_mut(t).ok())
            .filter(|(t, d)| t.contains(at.x, at.z) && d.mass.is_some());
        if m.is_finite() && m > 0.0 {
            match ground {
                Some((_, mut deposit)) => {
                    deposit.add(Vec2::new(at.x, at.z), m);
                    budget.deposited += m;
                }
                None => budget.lost += m,
            }
            budget.capped += m;
            report.particle_kg += m;
        }
        budget.capped_particles += 1;
        report.particles_settled += 1;
    }
    report.capped_steps += 1;
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
