//! The pyroclastic domain's step (thesis §3.6; docs/ARCHITECTURE.md §2.1): everything the
//! pyroclastic flows of every volcano do in one step, on plain data, called by
//! `PyroclasticPlugin`, the tests and the benches alike.
//!
//! [`step`] runs, in this order:
//!
//! 1. **Hand-over**: each collapsed slice becomes `N = round(V / V_s2)` particles
//!    ([`collapse`], at most [`MAX_PARTICLES_PER_SLICE`]) from its own random stream
//!    `("collapse", index)`, booked in `collapsed` and `spawned`.
//! 2. **Particles** (in parallel over fixed chunks, [`par_map_ordered`]): each runs over the
//!    deposit surface of its volcano's terrain ([`step_particle`]); what it sheds (σ_pyr) is
//!    added to that terrain's deposit in the particles' order; a particle that settled, left
//!    the terrain or is no longer finite is removed (its mass booked as lost unless it settled).
//! 3. **Particle cap** (bookkeeping, the rule is `crate::caps`'): beyond
//!    [`FlowInputs::max_particles`] (all volcanoes together), the oldest particles (lowest id;
//!    ties in the volcanoes' order) settle where they are.
//! 4. **Deposit**: every terrain's deposit relaxes toward its angle of repose by
//!    [`FlowInputs::relax_passes`] Jacobi passes
//!    ([`DepositMap::relax`](super::ground::DepositMap::relax)).
//! 5. **Lift-off** (§3.6): per volcano, buoyant particles in id order gather into clusters
//!    ([`find_clusters`]) that become rising slices ([`secondary_column`]); buoyant particles no
//!    cluster took that have risen more than `cluster_radius` above the ground lift off with
//!    those like them within that radius, or alone. Beyond
//!    [`FlowInputs::max_secondary_per_step`] the lighter clusters lift off without a column.
//!
//! **Order.** The state's lists keep their order: what is removed leaves the others in place,
//! what is new is appended, and every sum is taken in that order, so a caller that gathers the
//! particles in a stable order gets the same bits every run. The report tells a caller keeping
//! a parallel list (the plugin: entities) which particle is which ([`VolcanoFlowsReport::kept`]).

mod inputs;
mod report;
mod state;
mod surface;
#[cfg(test)]
mod tests;

pub use inputs::{Collapsed, FlowInputs, VolcanoInputs};
pub use report::{FlowStarted, FlowsReport, SecondaryColumn, VolcanoFlowsReport};
pub use state::{FlowParticle, FlowsState, VolcanoFlows};
pub use surface::Surface;

use bevy::math::{Vec2, Vec3};
use volcano_core::parallel::Bands;
use volcano_core::{Boundary, Grid2, Terrain};

use super::deposit::add_to_nodes;
use super::plume_to_world;
use super::pyroclastic::{Particle, collapse, find_clusters, secondary_column, step_particle};
use super::slice::SliceEnv;
use super::spheres::SphereParams;

/// Largest number of particles one collapsing slice becomes (N = round(V/V_s2) is ~750 with
/// the thesis' sphere sizes; the cap only matters for extreme edits).
pub const MAX_PARTICLES_PER_SLICE: usize = 2_000;

/// The plugin's deposit relaxation: one Jacobi pass per `RELAX_PERIOD.0` of domain time, at
/// `RELAX_PERIOD.1` past each multiple (a pass at 1/8, 3/8, 5/8, 7/8 s: four a second, spread
/// rather than run together once a second, and off the whole seconds where the weather steps,
/// so the two costs never fall on one tick).
pub const RELAX_PERIOD: (std::time::Duration, std::time::Duration) =
    (std::time::Duration::from_millis(250), std::time::Duration::from_millis(125));

/// Advances every volcano's pyroclastic flows by one step of `inputs.dt` seconds (see the
/// module docs). Volcanoes and terrains are matched with the inputs by position; entries
/// beyond the shorter list are left alone, and a volcano naming a terrain that does not exist
/// has no ground.
pub fn step(state: &mut FlowsState, inputs: &FlowInputs) -> FlowsReport {
    let n = state.volcanoes.len().min(inputs.volcanoes.len());
    let terrains = &inputs.terrains[..inputs.terrains.len().min(state.grounds.len())];
    let mut report = FlowsReport {
        volcanoes: vec![VolcanoFlowsReport::default(); n],
        grounds_changed: vec![false; state.grounds.len()],
        ..Default::default()
    };
    // The ground each volcano stands on, if it exists.
    let grounds: Vec<Option<usize>> =
        inputs.volcanoes[..n].iter().map(|v| v.ground.filter(|&g| g < terrains.len())).collect();
    let mut alive: Vec<Vec<bool>> = Vec::with_capacity(n);
    for v in 0..n {
        let (flows, vin, out) = (&mut state.volcanoes[v], &inputs.volcanoes[v], &mut report.volcanoes[v]);
        out.held = flows.particles.len();
        hand_over(flows, vin, out);
        alive.push(vec![true; flows.particles.len()]);
    }
    // The maps of the terrains volcanoes stand on.
    for &g in grounds.iter().flatten() {
        if !state.grounds[g].fits(terrains[g]) {
            state.grounds[g].ensure(terrains[g]);
            report.grounds_changed[g] = true;
        }
    }
    for v in 0..n {
        step_particles(state, inputs, terrains, (v, grounds[v]), &mut alive[v], &mut report);
    }
    cap_particles(state, terrains, &grounds, inputs.max_particles, &mut alive, &mut report);
    if inputs.relax_passes > 0 {
        for (g, terrain) in terrains.iter().enumerate() {
            report.grounds_changed[g] |= state.grounds[g].relax(terrain, inputs.relax_passes as usize);
        }
    }
    for v in 0..n {
        let surface = grounds[v].and_then(|g| state.grounds[g].surface.as_ref());
        let mut removed = Vec::new();
        lift_off(
            &mut state.volcanoes[v],
            &inputs.volcanoes[v],
            surface,
            inputs.max_secondary_per_step,
            (&mut alive[v], &mut removed),
            &mut report.volcanoes[v],
        );
        report.removed.extend(removed.into_iter().map(|i| (v, i)));
        if report.volcanoes[v].secondary_retired > 0 {
            report.capped += 1;
        }
        compact(&mut state.volcanoes[v], &alive[v], &mut report.volcanoes[v]);
    }
    report
}

/// Step 1: the collapsed slices become particles, appended in order.
fn hand_over(flows: &mut VolcanoFlows, vin: &VolcanoInputs, out: &mut VolcanoFlowsReport) {
    for c in vin.collapsed {
        // s2 radius: s1 spheres have radius r/2, their children ÷5.
        let r_s2 = 0.5 * c.state.r * SphereParams::CHILD_RATIO;
        let mut stream = vin.rng.stream("collapse", c.index);
        let particles = collapse(&c.state, r_s2, MAX_PARTICLES_PER_SLICE, &mut stream);
        let mass: f64 = particles.iter().map(|p| p.mass).sum();
        flows.budget.collapsed += mass;
        flows.budget.spawned += particles.len() as u64;
        out.started.push(FlowStarted {
            position: c.vent + plume_to_world(c.state.position),
            particles: particles.len(),
            mass,
        });
        flows.particles.extend(particles.into_iter().enumerate().map(|(k, particle)| FlowParticle {
            id: (c.index << 16) | k as u64,
            vent: c.vent,
            particle,
            buoyant: false,
        }));
    }
}

/// Step 2 for volcano `v`: every particle steps (in parallel), then deposits, books and
/// removals in the particles' order.
fn step_particles(
    state: &mut FlowsState,
    inputs: &FlowInputs,
    terrains: &[&Terrain],
    (v, ground): (usize, Option<usize>),
    alive: &mut [bool],
    report: &mut FlowsReport,
) {
    let vin = &inputs.volcanoes[v];
    let flows = &mut state.volcanoes[v];
    let surface = ground.and_then(|g| state.grounds[g].surface.as_ref()).map(Surface::new);
    let terrain = ground.map(|g| terrains[g]);
    let (p, py, dt) = (vin.plume, vin.pyroclastic, inputs.dt);
    // The map the deposits go to, if there is one: its nodes are found in the parallel part.
    let map = ground.and_then(|g| state.grounds[g].mass.as_ref());
    let outcomes = par_map_ordered(&mut flows.particles, |fp| {
        let wind = |z: f64| p.wind.at(z);
        let vent = fp.vent;
        let env = SliceEnv { air: p.atmosphere.profile(), vent_altitude: vent.y as f64, wind: &wind };
        let below = |x: f64, y: f64| surface.map_or(f64::NEG_INFINITY, |s| s.below(vent, x, y));
        let report = step_particle(&mut fp.particle, py, &env, &below, dt);
        fp.buoyant = report.buoyant;
        let world = vent + plume_to_world(fp.particle.position);
        let on_map = terrain.is_some_and(|t| t.contains(world.x, world.z));
        let node = match map {
            Some(m) if on_map && report.deposited > 0.0 => {
                let at = vent + plume_to_world(report.deposit_at.extend(0.0));
                deposit_node(m, Vec2::new(at.x, at.z))
            }
            _ => 0,
        };
        (report, on_map, node)
    });
    // Deposits on the map, in the particles' order (`deposit::add_to_nodes` keeps it per node).
    let mut adds: Vec<(u32, f64)> = Vec::new();
    for (i, (fp, (step, on_map, node))) in flows.particles.iter().zip(outcomes).enumerate() {
        let budget = &mut flows.budget;
        if step.deposited > 0.0 {
            if on_map && map.is_some() {
                adds.push((node, step.deposited));
                budget.deposited += step.deposited;
            } else {
                budget.lost += step.deposited;
            }
        }
        let broken = !finite(&fp.particle);
        if step.settled || !on_map || broken {
            if !step.settled {
                // A particle no longer finite (the guard, `volcano_core::fault`) is removed with
                // what it still held booked as lost, like one that left the terrain.
                let mass = volcano_core::fault::bookable(fp.particle.mass);
                budget.lost += mass;
                if broken {
                    report.volcanoes[v].non_finite.push(mass);
                }
            }
            alive[i] = false;
            report.removed.push((v, i));
        }
    }
    if let (Some(g), false) = (ground, adds.is_empty()) {
        let deposit = &mut state.grounds[g];
        deposit.bulk_density = py.deposit_density;
        deposit.repose_angle_deg = py.repose_angle_deg;
        if let (Some(m), Some(s)) = (deposit.mass.as_mut(), deposit.surface.as_mut()) {
            let (nx, cell) = (m.nx(), m.cell());
            add_to_nodes(m.data_mut(), s.data_mut(), nx, &adds, cell, deposit.bulk_density);
            deposit.revision += adds.len() as u64;
        }
        report.grounds_changed[g] = true;
    }
}

/// The node `DepositMap::add` puts a deposit at world `(x, z)` = `p` on: the nearest, clamped
/// to the grid (row-major index).
fn deposit_node(map: &Grid2<f64>, p: Vec2) -> u32 {
    let (fx, fy) = map.to_grid(p);
    let i = (fx.round().max(0.0) as usize).min(map.nx() - 1);
    let j = (fy.round().max(0.0) as usize).min(map.ny() - 1);
    (j * map.nx() + i) as u32
}

/// Step 3: beyond `max` live particles (all volcanoes), the oldest settle where they are.
fn cap_particles(
    state: &mut FlowsState,
    terrains: &[&Terrain],
    grounds: &[Option<usize>],
    max: usize,
    alive: &mut [Vec<bool>],
    report: &mut FlowsReport,
) {
    if alive.iter().flatten().filter(|a| **a).count() <= max {
        return;
    }
    let mut all: Vec<(u64, usize, usize)> = Vec::new();
    for (v, live) in alive.iter().enumerate() {
        let ps = &state.volcanoes[v].particles;
        all.extend(live.iter().enumerate().filter(|(_, a)| **a).map(|(i, _)| (ps[i].id, v, i)));
    }
    // Stable: equal ids (of different volcanoes) keep the volcanoes' order.
    all.sort_by_key(|&(id, ..)| id);
    let excess = all.len() - max;
    for &(_, v, i) in &all[..excess] {
        alive[v][i] = false;
        report.removed.push((v, i));
        let fp = state.volcanoes[v].particles[i];
        let budget = &mut state.volcanoes[v].budget;
        let m = fp.particle.mass;
        let at = fp.vent + plume_to_world(fp.particle.position);
        let ground =
            grounds[v].filter(|&g| terrains[g].contains(at.x, at.z) && state.grounds[g].mass.is_some());
        if m.is_finite() && m > 0.0 {
            match ground {
                Some(g) => {
                    state.grounds[g].add(Vec2::new(at.x, at.z), m);
                    budget.deposited += m;
                    report.grounds_changed[g] = true;
                }
                None => budget.lost += m,
            }
            budget.capped += m;
            report.particle_kg += m;
        }
        budget.capped_particles += 1;
        report.particles_settled += 1;
    }
    report.capped += 1;
}

/// Step 5 for one volcano: buoyant particles lift off as secondary columns.
fn lift_off(
    flows: &mut VolcanoFlows,
    vin: &VolcanoInputs,
    surface: Option<&Grid2<f32>>,
    max_columns: usize,
    (alive, removed): (&mut [bool], &mut Vec<usize>),
    out: &mut VolcanoFlowsReport,
) {
    let py = vin.pyroclastic;
    // Candidates in id order (stable: the list's order for equal ids).
    let mut mine: Vec<usize> =
        (0..flows.particles.len()).filter(|&i| alive[i] && flows.particles[i].buoyant).collect();
    if mine.is_empty() {
        return;
    }
    mine.sort_by_key(|&i| flows.particles[i].id);
    let list: Vec<Particle> = mine.iter().map(|&i| flows.particles[i].particle).collect();
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
    let aloft: Vec<bool> = mine
        .iter()
        .zip(&taken)
        .map(|(&i, &t)| {
            let fp = &flows.particles[i];
            let q = fp.particle.position;
            !t && q.z - ground_below(surface, fp.vent, q.x, q.y) > py.cluster_radius
        })
        .collect();
    if aloft.contains(&true) {
        groups.extend(find_clusters(&list, &aloft, py.cluster_radius, 1).members);
    }
    let mass = |g: &[usize]| g.iter().map(|&i| list[i].mass).sum::<f64>();
    for members in heaviest_clusters(&mut groups, mass, max_columns.max(1)) {
        let m = mass(&members);
        for &i in &members {
            alive[mine[i]] = false;
            removed.push(mine[i]);
        }
        flows.budget.lifted += m;
        flows.budget.capped += m;
        out.secondary_retired += 1;
        out.secondary_retired_kg += m;
    }
    for members in &groups {
        let Some(slice) = secondary_column(&list, members) else { continue };
        for &i in members {
            alive[mine[i]] = false;
            removed.push(mine[i]);
        }
        let vent = flows.particles[mine[members[0]]].vent;
        let index = flows.emitted;
        flows.emitted += 1;
        flows.budget.lifted += slice.mass;
        flows.budget.secondary_columns += 1;
        out.columns.push(SecondaryColumn {
            index,
            vent,
            position: vent + plume_to_world(slice.position),
            state: slice,
            particles: members.len(),
        });
    }
}

/// Removes the dead particles, keeping the others' order, and records where each came from.
fn compact(flows: &mut VolcanoFlows, alive: &[bool], out: &mut VolcanoFlowsReport) {
    out.kept = (0..flows.particles.len()).filter(|&i| alive[i]).collect();
    let mut k = 0;
    flows.particles.retain(|_| {
        k += 1;
        alive[k - 1]
    });
}

/// Keeps the `max` heaviest clusters (ties: the lower first member) in their original order
/// and returns the others (in their original order). The secondary-column cap's rule
/// (`crate::caps`).
pub fn heaviest_clusters(
    groups: &mut Vec<Vec<usize>>,
    mass: impl Fn(&[usize]) -> f64,
    max: usize,
) -> Vec<Vec<usize>> {
    if groups.len() <= max {
        return Vec::new();
    }
    let mut order: Vec<(usize, f64, usize)> = groups
        .iter()
        .enumerate()
        .map(|(k, g)| (k, mass(g), g.first().copied().unwrap_or(usize::MAX)))
        .collect();
    order.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.2.cmp(&b.2)));
    let mut keep = vec![false; groups.len()];
    for &(k, ..) in &order[..max] {
        keep[k] = true;
    }
    let (kept, rest): (Vec<_>, Vec<_>) =
        std::mem::take(groups).into_iter().zip(keep).partition(|(_, keep)| *keep);
    *groups = kept.into_iter().map(|(g, _)| g).collect();
    rest.into_iter().map(|(g, _)| g).collect()
}

/// `f` over `items` on the task pool in fixed chunks of 512 ([`Bands`] of
/// `volcano_core::parallel`); results in item order, independent of the thread count. The
/// particle step's loop (and its bench's). Small chunks on purpose: on a machine whose cores
/// are shared, a chunk held by a descheduled thread is what the step waits for.
pub fn par_map_ordered<T: Send, R: Send + 'static>(
    items: &mut [T],
    f: impl Fn(&mut T) -> R + Sync,
) -> Vec<R> {
    const CHUNK: usize = 512;
    let n = items.len();
    // Bands of CHUNK one-item rows (volcano_core::parallel); one band runs inline.
    let chunks = Bands::of(CHUNK).map(items, 1, |_, chunk| chunk.iter_mut().map(&f).collect::<Vec<R>>());
    let mut out = Vec::with_capacity(n);
    for c in chunks {
        out.extend(c);
    }
    out
}

/// Height (plume frame, m above the vent at world `vent`) of the collision surface, terrain +
/// deposit, under plume-frame `(x, y)`; −∞ without a map. Plume frame (x, y horizontal, z up
/// from the vent) ↔ world (x, z = −y, y up).
pub fn ground_below(surface: Option<&Grid2<f32>>, vent: Vec3, x: f64, y: f64) -> f64 {
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
