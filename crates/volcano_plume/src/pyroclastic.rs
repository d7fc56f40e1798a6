//! [`PyroclasticPlugin`]: collapsed slices become pyroclastic particles (entities) that run
//! over the terrain, deposit ash on a [`DepositMap`], and lift off again as secondary columns
//! (thesis §3.6). Runs in its own domain, `PyroclasticStep`, once per base tick (0.02 s) after
//! the plume domain; the model substeps where particles are fast.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::components::*;
use crate::model::deposit;
use crate::model::pyroclastic::{Particle, collapse, find_clusters, secondary_column, step_particle};
use crate::model::slice::SliceEnv;
use crate::model::spheres::SphereParams;

/// Schedule of the pyroclastic domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default)]
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
pub struct PyroParticle {
    /// Volcano whose collapse produced it.
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

/// Ash deposited on the ground, per terrain node (kg, f64), over the first [`Terrain`]'s grid.
/// Particles run over `surface` (terrain + deposit), and the deposit relaxes to its angle of
/// repose once per second ([`crate::model::deposit`]).
#[derive(Resource, Debug, Clone, Default)]
pub struct DepositMap {
    /// Deposited mass per node (kg); `None` until a terrain exists.
    pub mass: Option<Grid2<f64>>,
    /// Terrain height plus deposit thickness (m), what particles collide with.
    pub surface: Option<Grid2<f32>>,
    /// Bulk density used for thickness (kg/m³).
    pub bulk_density: f64,
    /// Bumped whenever the deposit changes (renderers redraw when it moves).
    pub revision: u64,
    scratch: Vec<f64>,
}

impl DepositMap {
    /// Deposit thickness (m) at world `(x, z)`; 0 off the map.
    pub fn thickness_at(&self, x: f32, z: f32) -> f64 {
        let Some(g) = &self.mass else { return 0.0 };
        let p = Vec2::new(x, z);
        if !g.contains(p) || self.bulk_density <= 0.0 {
            return 0.0;
        }
        deposit::thickness(g.nearest(p, Boundary::Clamp), g.cell(), self.bulk_density)
    }
    /// Deposit thickness (m) at node `(i, j)` of the terrain grid; 0 outside.
    pub fn thickness_at_node(&self, i: usize, j: usize) -> f64 {
        match &self.mass {
            Some(g) if i < g.nx() && j < g.ny() => {
                deposit::thickness(g.get(i, j), g.cell(), self.bulk_density)
            }
            _ => 0.0,
        }
    }
    /// Total deposited mass (kg).
    pub fn total(&self) -> f64 {
        self.mass.as_ref().map_or(0.0, |g| g.data().iter().sum())
    }
    /// Creates the grids over `terrain` if they do not exist yet.
    fn ensure(&mut self, terrain: &Terrain) {
        if self.mass.is_none() {
            let h = terrain.heights();
            self.mass = Grid2::new(h.nx(), h.ny(), h.cell(), h.origin(), 0.0).ok();
            self.surface = Some(h.clone());
        }
    }
    /// Adds `mass` kg at world `(x, z)` = `p` on `terrain`'s deposit (creating the map over it
    /// if needed; `bulk_density` kg/m³ is used if the map has none yet). Returns false, adding
    /// nothing, where `p` is off the terrain. Used for ash fall from the coupled atmosphere.
    pub fn add_on(&mut self, terrain: &Terrain, p: Vec2, mass: f64, bulk_density: f64) -> bool {
        if mass.is_nan() || mass <= 0.0 || !terrain.contains(p.x, p.y) {
            return false;
        }
        self.ensure(terrain);
        if self.bulk_density <= 0.0 {
            self.bulk_density = bulk_density;
        }
        self.add(p, mass);
        true
    }
    /// Adds mass to the nearest node and raises the surface there.
    pub(crate) fn add(&mut self, p: Vec2, mass: f64) {
        let (Some(g), Some(s)) = (self.mass.as_mut(), self.surface.as_mut()) else { return };
        let (fx, fy) = g.to_grid(p);
        let i = (fx.round().max(0.0) as usize).min(g.nx() - 1);
        let j = (fy.round().max(0.0) as usize).min(g.ny() - 1);
        g.set(i, j, g.get(i, j) + mass);
        let rise = deposit::thickness(mass, g.cell(), self.bulk_density) as f32;
        s.set(i, j, s.get(i, j) + rise);
        self.revision += 1;
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
    /// Of `deposited`, `lost` and `lifted`, the mass the caps removed (particles settled by
    /// [`crate::caps::PlumeCaps::max_particles`], clusters lifted without a column by
    /// [`crate::caps::PlumeCaps::max_secondary_per_step`]).
    pub capped: f64,
    /// Particles settled by that cap.
    pub capped_particles: u64,
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
            .init_resource::<DepositMap>()
            .init_resource::<PyroclasticBudget>()
            .register_type::<PyroParticle>()
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
    eruptions: Query<&VolcanoRng>,
    mut budget: ResMut<PyroclasticBudget>,
    mut started: MessageWriter<PyroclasticFlowStarted>,
) {
    for SliceCollapsed(slice) in collapsed.read() {
        let Ok(rng) = eruptions.get(slice.volcano) else { continue };
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

/// One step of every particle, in parallel over fixed chunks; deposits, budget and despawns
/// are then applied in query order, so the result does not depend on the thread count.
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
    if let Some(t) = terrain {
        deposit.ensure(t);
    }
    let mut items: Vec<_> = particles.iter_mut().collect();
    let outcomes = {
        let surface = deposit.surface.as_ref();
        par_map_ordered(&mut items, |(_, pp, transform)| {
            let eruption = eruptions.get(pp.volcano).ok()?;
            let p = &eruption.params;
            let wind = |z: f64| p.wind.at(z);
            let vent = pp.vent;
            let env = SliceEnv { air: p.atmosphere.profile(), vent_altitude: vent.y as f64, wind: &wind };
            let ground = |x: f64, y: f64| ground_below(surface, vent, x, y);
            let report = step_particle(&mut pp.particle, &eruption.pyroclastic, &env, &ground, dt);
            pp.buoyant = report.buoyant;
            let world = vent + plume_to_world(pp.particle.position);
            transform.translation = world;
            transform.scale = Vec3::splat(pp.particle.radius as f32);
            let on_map = terrain.is_some_and(|t| t.contains(world.x, world.z));
            Some((report, on_map, eruption.pyroclastic.deposit_density))
        })
    };
    for ((entity, pp, _), outcome) in items.iter().zip(outcomes) {
        let Some((report, on_map, density)) = outcome else {
            budget.lost += pp.particle.mass;
            commands.entity(*entity).despawn();
            continue;
        };
        deposit.bulk_density = density;
        if report.deposited > 0.0 {
            if on_map && deposit.mass.is_some() {
                let at = pp.vent + plume_to_world(report.deposit_at.extend(0.0));
                deposit.add(Vec2::new(at.x, at.z), report.deposited);
                budget.deposited += report.deposited;
            } else {
                budget.lost += report.deposited;
            }
        }
        if report.settled || !on_map || !finite(&pp.particle) {
            if !report.settled && pp.particle.mass.is_finite() {
                budget.lost += pp.particle.mass;
            }
            commands.entity(*entity).despawn();
        }
    }
}

/// `f` over `items` on the compute task pool in fixed chunks of 512; results in item order.
/// Used for the particle step (and its bench) so the outcome is independent of the threads.
pub fn par_map_ordered<T: Send, R: Send + 'static>(
    items: &mut [T],
    f: impl Fn(&mut T) -> R + Sync,
) -> Vec<R> {
    const CHUNK: usize = 512;
    if items.len() <= CHUNK {
        return items.iter_mut().map(&f).collect();
    }
    let pool = bevy::tasks::ComputeTaskPool::get_or_init(bevy::tasks::TaskPool::default);
    let f = &f;
    let chunks = pool.scope(|scope| {
        for chunk in items.chunks_mut(CHUNK) {
            scope.spawn(async move { chunk.iter_mut().map(f).collect::<Vec<R>>() });
        }
    });
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
/// the deposit relaxes to its angle of repose (a few Jacobi passes) and the collision surface
/// follows.
fn relax_deposit(
    time: Res<Time>,
    eruptions: Query<&Eruption>,
    terrains: Query<&Terrain>,
    mut map: ResMut<DepositMap>,
) {
    const PASSES: usize = 4;
    let map = &mut *map;
    if !volcano_core::clock::crossed_period(time.elapsed(), time.delta(), std::time::Duration::from_secs(1)) {
        return;
    }
    let (Some(terrain), Some(mass), Some(surface)) =
        (terrains.iter().next(), map.mass.as_mut(), map.surface.as_mut())
    else {
        return;
    };
    let angle = eruptions.iter().next().map_or(34.0, |e| e.pyroclastic.repose_angle_deg);
    let tan = angle.to_radians().tan();
    let h = terrain.heights();
    if h.nx() != mass.nx() || h.ny() != mass.ny() {
        return;
    }
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

/// Buoyant particles, per volcano, gather into clusters that become rising slices. Buoyant
/// particles no cluster took that have risen more than r_pyr above the ground have left their
/// flow: they lift off with the others like them within r_pyr (the same seed rule, any
/// number), or alone, instead of hanging in the air for ever.
#[allow(clippy::too_many_arguments)]
fn lift_secondary_columns(
    caps: Res<crate::caps::PlumeCaps>,
    mut report: ResMut<crate::caps::PlumeCapReport>,
    mut commands: Commands,
    mut eruptions: Query<(Entity, &Eruption, &mut EmissionState)>,
    particles: Query<(Entity, &PyroParticle)>,
    deposit: Res<DepositMap>,
    mut budget: ResMut<PyroclasticBudget>,
    mut formed: MessageWriter<SecondaryColumnFormed>,
    mut rising: MessageWriter<SecondaryColumnRising>,
) {
    for (volcano, eruption, mut emission) in &mut eruptions {
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
        let surface = deposit.surface.as_ref();
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
    terrains: Query<&Terrain>,
    mut deposit: ResMut<DepositMap>,
    mut budget: ResMut<PyroclasticBudget>,
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
    let terrain = terrains.iter().next();
    for &(entity, pp) in &all[..n - max] {
        let m = pp.particle.mass;
        let at = pp.vent + plume_to_world(pp.particle.position);
        let on_map = terrain.is_some_and(|t| t.contains(at.x, at.z)) && deposit.mass.is_some();
        if m.is_finite() && m > 0.0 {
            if on_map {
                deposit.add(Vec2::new(at.x, at.z), m);
                budget.deposited += m;
            } else {
                budget.lost += m;
            }
            budget.capped += m;
            report.particle_kg += m;
        }
        budget.capped_particles += 1;
        report.particles_settled += 1;
        commands.entity(entity).despawn();
    }
    report.capped_steps += 1;
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
