//! [`PyroclasticPlugin`]: collapsed slices become pyroclastic particles (entities) that run
//! over the terrain, deposit ash on a [`DepositMap`], and lift off again as secondary columns
//! (thesis §3.6). Runs in its own domain, `PyroclasticStep`, once per base tick (0.02 s) after
//! the plume domain; the model substeps where particles are fast.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::components::*;
use crate::model::pyroclastic::{Particle, collapse, find_clusters, secondary_column, step_particle};
use crate::model::slice::{Phase, SliceEnv};
use crate::model::spheres::SphereParams;
use crate::plugin::spawn_slice;

/// Schedule of the pyroclastic domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct PyroclasticStep;

/// One pyroclastic sphere. Its `Transform` is kept in world space (scale = radius).
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
pub struct PyroParticle {
    /// Volcano whose collapse produced it.
    pub volcano: Entity,
    /// Model state in the vent's plume frame.
    pub particle: Particle,
    /// Vent position (world).
    pub vent: Vec3,
    /// Stable id (slice index << 16 | k), for rendering.
    pub id: u64,
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

/// Ash deposited on the ground, per terrain cell (kg, f64), over the first [`Terrain`]'s grid.
#[derive(Resource, Debug, Clone, Default)]
pub struct DepositMap {
    /// Deposited mass per cell (kg); `None` until a terrain exists.
    pub mass: Option<Grid2<f64>>,
    /// Bulk density used for thickness (kg/m³).
    pub bulk_density: f64,
}

impl DepositMap {
    /// Deposit thickness (m) at world `(x, z)`; 0 off the map.
    pub fn thickness_at(&self, x: f32, z: f32) -> f64 {
        let Some(g) = &self.mass else { return 0.0 };
        let p = Vec2::new(x, z);
        if !g.contains(p) || self.bulk_density <= 0.0 {
            return 0.0;
        }
        g.nearest(p, Boundary::Clamp) / (self.bulk_density * g.cell() * g.cell())
    }
    /// Total deposited mass (kg).
    pub fn total(&self) -> f64 {
        self.mass.as_ref().map_or(0.0, |g| g.data().iter().sum())
    }
}

/// Mass accounting of all pyroclastic flows (kg): `collapsed = airborne + deposited + lifted +
/// lost`, with airborne the mass of live particles.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct PyroclasticBudget {
    /// Mass of slices handed over to particles.
    pub collapsed: f64,
    /// Mass deposited on the terrain.
    pub deposited: f64,
    /// Mass lifted into secondary columns.
    pub lifted: f64,
    /// Mass of particles that left the terrain (or a map-less world).
    pub lost: f64,
    /// Particles spawned so far.
    pub spawned: u64,
    /// Secondary columns formed so far.
    pub secondary_columns: u64,
}

/// Pyroclastic particles, deposit and secondary columns.
#[derive(Debug, Default, Clone)]
pub struct PyroclasticPlugin;

impl Plugin for PyroclasticPlugin {
    fn build(&self, app: &mut App) {
        app.add_sim_domain::<PyroclasticStep>(SimSystems::BeforeWeather, Cadence::Substeps(1))
            .add_message::<PyroclasticFlowStarted>()
            .add_message::<SecondaryColumnFormed>()
            .init_resource::<DepositMap>()
            .init_resource::<PyroclasticBudget>()
            .register_type::<PyroParticle>()
            .register_type::<PyroclasticBudget>()
            .add_systems(PyroclasticStep, (hand_over, step_particles, lift_secondary_columns).chain());
    }
}

/// Largest number of particles one collapsing slice becomes (N = round(V/V_s2) is ~750 with
/// the thesis' sphere sizes; the cap only matters for extreme edits).
pub const MAX_PARTICLES_PER_SLICE: usize = 2_000;

/// Collapsed slices (left by the plume step) become particles.
fn hand_over(
    mut commands: Commands,
    eruptions: Query<(&Eruption, &VolcanoRng)>,
    slices: Query<(Entity, &PlumeSlice)>,
    mut budget: ResMut<PyroclasticBudget>,
    mut started: MessageWriter<PyroclasticFlowStarted>,
) {
    for (entity, slice) in &slices {
        if slice.state.phase != Phase::Collapsed {
            continue;
        }
        commands.entity(entity).despawn();
        let Ok((_, rng)) = eruptions.get(slice.volcano) else { continue };
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
                    PyroParticle { volcano, particle, vent, id: (index << 16) | k as u64 },
                )
            })
            .collect();
        commands.spawn_batch(bundles);
        debug!("slice {} collapsed into {n} pyroclastic particles", slice.index);
    }
}

#[allow(clippy::too_many_arguments)]
fn step_particles(
    time: Res<Time>,
    mut commands: Commands,
    eruptions: Query<&Eruption>,
    terrains: Query<&Terrain>,
    mut deposit: ResMut<DepositMap>,
    mut budget: ResMut<PyroclasticBudget>,
    mut particles: Query<(Entity, &mut PyroParticle, &mut Transform)>,
) {
    let dt = time.delta_secs_f64();
    let terrain = terrains.iter().next();
    if deposit.mass.is_none()
        && let Some(t) = terrain
    {
        let h = t.heights();
        deposit.mass = Grid2::new(h.nx(), h.ny(), h.cell(), h.origin(), 0.0).ok();
    }
    for (entity, mut pp, mut transform) in &mut particles {
        let Ok(eruption) = eruptions.get(pp.volcano) else {
            budget.lost += pp.particle.mass;
            commands.entity(entity).despawn();
            continue;
        };
        let p = &eruption.params;
        deposit.bulk_density = eruption.pyroclastic.deposit_density;
        let wind = |z: f64| p.wind.at(z);
        let vent = pp.vent;
        let env = SliceEnv { air: p.atmosphere.profile(), vent_altitude: vent.y as f64, wind: &wind };
        // Plume frame (x, y horizontal, z up from the vent) ↔ world (x, z = −y, y up).
        let ground = |x: f64, y: f64| match terrain {
            Some(t) => (t.height_at(vent.x + x as f32, vent.z - y as f32) - vent.y) as f64,
            None => f64::NEG_INFINITY,
        };
        let report = step_particle(&mut pp.particle, &eruption.pyroclastic, &env, &ground, dt);
        let world = vent + plume_to_world(pp.particle.position);
        let on_map = terrain.is_some_and(|t| t.contains(world.x, world.z));
        if report.deposited > 0.0 {
            let at = vent + plume_to_world(report.deposit_at.extend(0.0));
            match deposit.mass.as_mut().filter(|_| on_map) {
                Some(g) => add_deposit(g, Vec2::new(at.x, at.z), report.deposited),
                None => budget.lost += report.deposited,
            }
            if on_map {
                budget.deposited += report.deposited;
            }
        }
        if report.settled || !on_map || !finite(&pp.particle) {
            if !report.settled && pp.particle.mass.is_finite() {
                budget.lost += pp.particle.mass;
            }
            commands.entity(entity).despawn();
            continue;
        }
        transform.translation = world;
        transform.scale = Vec3::splat(pp.particle.radius as f32);
    }
}

fn finite(p: &Particle) -> bool {
    p.position.is_finite() && p.velocity.is_finite() && p.mass.is_finite()
}

/// Adds mass to the nearest cell.
fn add_deposit(g: &mut Grid2<f64>, p: Vec2, mass: f64) {
    let (fx, fy) = g.to_grid(p);
    let i = (fx.round().max(0.0) as usize).min(g.nx() - 1);
    let j = (fy.round().max(0.0) as usize).min(g.ny() - 1);
    let v = g.get(i, j);
    g.set(i, j, v + mass);
}

/// Buoyant particles, per volcano, gather into clusters that become rising slices.
#[allow(clippy::too_many_arguments)]
fn lift_secondary_columns(
    mut commands: Commands,
    mut eruptions: Query<(Entity, &Eruption, &mut EmissionState, &VolcanoRng)>,
    particles: Query<(Entity, &PyroParticle)>,
    mut budget: ResMut<PyroclasticBudget>,
    mut formed: MessageWriter<SecondaryColumnFormed>,
) {
    for (volcano, eruption, mut emission, rng) in &mut eruptions {
        // Fixed order (spawn order) for determinism.
        let mut mine: Vec<(Entity, &PyroParticle)> =
            particles.iter().filter(|(_, p)| p.volcano == volcano).collect();
        if mine.is_empty() {
            continue;
        }
        mine.sort_by_key(|(_, p)| p.id);
        let p = &eruption.params;
        let air = p.atmosphere.profile();
        let vent_alt = mine[0].1.vent.y as f64;
        let list: Vec<Particle> = mine.iter().map(|(_, p)| p.particle).collect();
        let buoyant: Vec<bool> =
            list.iter().map(|q| q.density() < air.density(vent_alt + q.position.z)).collect();
        if !buoyant.iter().any(|b| *b) {
            continue;
        }
        let py = &eruption.pyroclastic;
        let clusters = find_clusters(&list, &buoyant, py.cluster_radius, py.min_cluster as usize);
        for members in &clusters.members {
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
            let slice = PlumeSlice { volcano, index, vent, state, ring_phase: 0.0 };
            spawn_slice(&mut commands, slice, &eruption.spheres, rng, format!("Secondary column {index}"));
        }
    }
}

/// Gameplay queries: "is this point inside a pyroclastic flow?", "how thick is the deposit
/// here?". Linear in the number of particles (≈50 µs for 50,000), fine for a few queries per
/// frame.
#[derive(SystemParam)]
pub struct PyroclasticQuery<'w, 's> {
    deposit: Res<'w, DepositMap>,
    particles: Query<'w, 's, &'static Transform, With<PyroParticle>>,
}

impl PyroclasticQuery<'_, '_> {
    /// Whether world point `p` is within `margin` metres of any pyroclastic particle.
    pub fn in_flow(&self, p: Vec3, margin: f32) -> bool {
        self.particles.iter().any(|t| t.translation.distance(p) <= t.scale.x + margin)
    }
    /// Deposit thickness (m) at world `(x, z)`.
    pub fn deposit_thickness(&self, x: f32, z: f32) -> f64 {
        self.deposit.thickness_at(x, z)
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
