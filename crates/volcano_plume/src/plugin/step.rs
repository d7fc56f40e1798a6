//! The plume domain's step system ([`super::PlumeSystems::Step`]): gathers each volcano's
//! slices and umbrella spheres into a [`PlumeState`] (in query order), calls [`domain::step`]
//! once per volcano with the s1 entities as its [`RingSource`] (one pass over them in a step
//! where slices leave the column, none otherwise), and writes the results back in the order
//! the domain step produced them: the emitted slices are spawned first, then the live-slice
//! cap's retirements, then the slices in query order (state, transform, neutral-buoyancy
//! messages, removals, then the finished slices: umbrella spheres or a collapse), then the
//! umbrella spheres in query order (the detached ones last), then the umbrella cap's
//! retirements. That fixed order fixes the entities' storage order, and with it the order of
//! every later step's sums and messages.

use std::cell::RefCell;
use std::collections::HashSet;
use std::time::Duration;

use bevy::ecs::entity::EntityHashMap;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use volcano_core::clock::crossings;
use volcano_core::prelude::*;

use super::{orientation, spawn_with_ring};
use crate::caps::{PlumeCapReport, PlumeCaps, checked};
use crate::components::*;
use crate::faults;
use crate::model::domain::{
    self, AshBooks, CloudSphere, Emission, Emitter, LiveSlice, Outcome, PlumeAir, PlumeInputs, PlumeReport,
    PlumeState, RingSource, RingSphere, SliceFate, SphereFate, StepCaps,
};

/// The messages the plume step writes.
#[derive(SystemParam)]
pub(super) struct PlumeMessages<'w> {
    collapsed: MessageWriter<'w, PlumeCollapsed>,
    hand_over: MessageWriter<'w, SliceCollapsed>,
    neutral: MessageWriter<'w, NeutralBuoyancyReached>,
    umbrella: MessageWriter<'w, UmbrellaSpreading>,
    released: MessageWriter<'w, AshReleased>,
    faults: MessageWriter<'w, volcano_core::SimFault>,
}

/// One volcano's plume as gathered, the entities behind it, and what its step did.
struct Gathered {
    volcano: Entity,
    state: PlumeState,
    report: PlumeReport,
    /// Entities of the slices by position (the gathered ones, then the emitted ones).
    slices: Vec<Entity>,
    /// Emission indices of the gathered slices.
    indices: Vec<u64>,
    /// How many slices were gathered (the rest were emitted in this step).
    gathered_slices: usize,
    /// The s1 entities the step asked for ([`RingSource`]), with their place in the query.
    found: Vec<(usize, Entity)>,
    /// Ring spheres by position in [`PlumeState::rings`]: indices into the step's list of s1
    /// entities (those of the emitted slices, then those found).
    rings: Vec<usize>,
    /// Entities of the umbrella spheres by position (the gathered ones, then the detached).
    spheres: Vec<Entity>,
    /// How many umbrella spheres were gathered.
    gathered_spheres: usize,
}

/// An s1 sphere's entity and its place in the s1 query (`None`: spawned in this step, not in
/// the world yet).
type RingEntity = (Entity, Option<usize>);

/// A slice or umbrella sphere in the order the step meets it: its entity and, unless its
/// volcano is gone, the volcano's slot and its position there.
type Entry = (Entity, Option<(usize, usize)>);

type Eruptions<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Eruption,
        &'static mut EmissionState,
        &'static mut PlumeAshBudget,
        Option<&'static VentPosition>,
        Option<&'static VolcanoRng>,
        Option<&'static PlumeAmbient>,
    ),
>;
type Slices<'w, 's> = Query<
    'w,
    's,
    (Entity, &'static mut PlumeSlice, &'static mut Transform),
    (Without<S1>, Without<Umbrella>),
>;
type Rings<'w, 's> =
    Query<'w, 's, (Entity, &'static S1, &'static mut Transform), (Without<PlumeSlice>, Without<Umbrella>)>;
type Spheres<'w, 's> = Query<
    'w,
    's,
    (Entity, &'static mut Umbrella, &'static mut Transform),
    (Without<S1>, Without<PlumeSlice>),
>;

/// The plume step: gather, [`domain::step`] per volcano, write back, messages.
#[allow(clippy::too_many_arguments)]
pub(super) fn step_plume(
    time: Res<Time>,
    fixed: Res<Time<Fixed>>,
    caps: Res<PlumeCaps>,
    mut cap_report: ResMut<PlumeCapReport>,
    mut commands: Commands,
    mut eruptions: Eruptions,
    mut slices: Slices,
    mut rings: Rings,
    mut spheres: Spheres,
    mut out: PlumeMessages,
) {
    let dt = time.delta_secs_f64();
    // The umbrella steps once per base tick of domain time, on the step that crosses it, not
    // in each of the column's substeps (`PlumeInputs::umbrella_dt`): its spheres are gathered
    // and written back only then. A step longer than a tick (a slower cadence, a higher
    // speed) crosses several and steps the umbrella by all of them.
    let period = fixed.timestep();
    let crossed = crossings(time.elapsed(), time.delta(), period, Duration::ZERO);
    let umbrella_dt = crossed as f64 * period.as_secs_f64();
    let caps = checked(&caps);
    let step_caps = StepCaps {
        max_live_slices: caps.max_live_slices as usize,
        max_umbrella_spheres: caps.max_umbrella_spheres as usize,
    };

    // Gather, in query order.
    let mut plumes: Vec<Gathered> = Vec::new();
    let mut slot: EntityHashMap<usize> = EntityHashMap::default();
    for (volcano, _, emission, budget, ..) in &eruptions {
        slot.insert(volcano, plumes.len());
        plumes.push(gathered(volcano, emission, budget));
    }
    // Consecutive entities mostly belong to the same volcano: look the slot up once per run.
    let mut last: Option<(Entity, Option<usize>)> = None;
    let mut slot_of = |volcano: Entity| match last {
        Some((v, found)) if v == volcano => found,
        _ => {
            let found = slot.get(&volcano).copied();
            last = Some((volcano, found));
            found
        }
    };
    let mut slice_order: Vec<Entry> = Vec::new();
    for (entity, s, _) in &slices {
        let Some(v) = slot_of(s.volcano) else {
            slice_order.push((entity, None));
            continue;
        };
        let g = &mut plumes[v];
        slice_order.push((entity, Some((v, g.slices.len()))));
        g.slices.push(entity);
        g.indices.push(s.index);
        g.state.slices.push(LiveSlice {
            index: s.index,
            vent: s.vent,
            state: s.state.clone(),
            ring_phase: s.ring_phase,
            ash_pending: s.ash_pending,
            secondary: s.secondary,
        });
    }
    let mut sphere_order: Vec<Entry> = Vec::new();
    let gathered_spheres = if umbrella_dt > 0.0 { Some(&spheres) } else { None };
    for (entity, u, _) in gathered_spheres.into_iter().flatten() {
        let Some(v) = slot_of(u.volcano) else {
            sphere_order.push((entity, None));
            continue;
        };
        let g = &mut plumes[v];
        sphere_order.push((entity, Some((v, g.spheres.len()))));
        g.spheres.push(entity);
        g.state.umbrella.push(CloudSphere {
            id: u.id,
            sphere: u.sphere,
            radius: u.radius,
            density: u.density,
            age: u.age,
            vent: u.vent,
            ash: u.ash,
            ash_pending: u.ash_pending,
        });
    }

    // One step per volcano.
    for g in &mut plumes {
        g.gathered_slices = g.slices.len();
        g.gathered_spheres = g.spheres.len();
        let Ok((_, eruption, _, _, vent, rng, ambient)) = eruptions.get(g.volcano) else { continue };
        let found = RefCell::new(Vec::new());
        let (held, indices) = (&g.slices, &g.indices);
        let source = |want: &[u64]| find_rings(&rings, held, indices, want, &mut found.borrow_mut());
        let inputs = PlumeInputs {
            params: &eruption.params,
            spheres: &eruption.spheres,
            active: eruption.active,
            // An invalid live edit freezes the column until the parameters are fixed.
            frozen: eruption.validate().is_err(),
            emitter: vent.zip(rng).map(|(vent, rng)| Emitter { vent: vent.0, rng }),
            umbrella_lifetime: eruption.umbrella_lifetime,
            umbrella_fallout_s: eruption.umbrella_fallout_s,
            air: ambient.map_or(PlumeAir::Own, |a| PlumeAir::Coupled(&a.0)),
            caps: step_caps,
            rings: Some(RingSource(&source)),
            dt,
            umbrella_dt,
        };
        g.report = domain::step(&mut g.state, &inputs);
        g.found = found.into_inner();
    }

    // Write back. The emitted slices first, as the emission spawned them before all else.
    let mut all_rings: Vec<RingEntity> = Vec::new();
    for g in &mut plumes {
        for em in &g.report.emitted {
            let at = Transform::from_translation(world(&em.slice));
            let (transform, live) = match g.report.slice_fates[em.at] {
                SliceFate::Kept(j) => {
                    let s = &g.state.slices[j];
                    (
                        Transform {
                            translation: world(s),
                            rotation: orientation(&s.state),
                            scale: Vec3::ONE,
                        },
                        s,
                    )
                }
                // Gone in its first step: spawned as it left, removed below.
                _ => (at, &em.slice),
            };
            let name = format!("Plume slice {}", em.slice.index);
            let (entity, ring) =
                spawn_with_ring(&mut commands, name, (transform, component(g.volcano, live)), at, &em.ring);
            g.slices.push(entity);
            debug_assert_eq!(g.rings.len(), em.first_ring, "emitted rings are numbered in order");
            for e in ring {
                g.rings.push(all_rings.len());
                all_rings.push((e, None));
            }
        }
        // The rings the step asked for follow the emitted ones.
        for &(q, e) in &g.found {
            g.rings.push(all_rings.len());
            all_rings.push((e, Some(q)));
        }
    }
    let mut by_entity: Vec<usize> = (0..plumes.len()).collect();
    by_entity.sort_by_key(|&v| plumes[v].volcano);

    // The live-slice cap (volcanoes in entity order), then the rings of what it retired.
    let mut retired_rings: Vec<RingEntity> = Vec::new();
    for g in by_entity.iter().map(|&v| &plumes[v]).filter(|g| !g.report.retired.is_empty()) {
        warn_once!(
            "eruption {}: more than {} live slices; the excess is retired with its ash released into the \
             air (PlumeCaps::max_live_slices, PlumeCapReport)",
            g.volcano,
            caps.max_live_slices
        );
        for r in &g.report.retired {
            let entity = g.slices[r.at];
            if r.ash_kg > 0.0 {
                let position = slices.get(entity).map_or_else(|_| world(&r.slice), |(_, _, t)| t.translation);
                out.released.write(AshReleased { volcano: g.volcano, position, mass: r.ash_kg });
            }
            cap_report.slices_retired += 1;
            cap_report.slice_ash_released_kg += r.ash_kg;
            commands.entity(entity).despawn();
            retired_rings.extend(r.ring.iter().map(|&i| all_rings[g.rings[i]]));
        }
    }
    if by_entity.iter().any(|&v| !plumes[v].report.retired.is_empty()) {
        // In the s1 query's order.
        retired_rings.sort_unstable_by_key(|&(_, q)| q);
        for (sphere, _) in retired_rings {
            commands.entity(sphere).despawn();
        }
        cap_report.capped_steps += 1;
    }

    // The slices' new states (the query's order is the gathered one: nothing moved since).
    for ((entity, mut slice, mut transform), &(gathered, at)) in slices.iter_mut().zip(&slice_order) {
        debug_assert_eq!(entity, gathered);
        let Some((v, k)) = at else { continue };
        let r = &plumes[v].report;
        if let SliceFate::Kept(j) = r.slice_fates[k]
            && r.stepped
        {
            let s = &plumes[v].state.slices[j];
            slice.state = s.state.clone();
            slice.ring_phase = s.ring_phase;
            slice.ash_pending = s.ash_pending;
            transform.translation = world(s);
            transform.rotation = orientation(&s.state);
        }
    }

    // The slices' events in query order, then the emitted ones'.
    let emitted: Vec<Entry> = (plumes.iter().enumerate())
        .flat_map(|(v, g)| g.report.emitted.iter().map(move |e| (g.slices[e.at], Some((v, e.at)))))
        .collect();
    let mut neutral_seen = vec![0usize; plumes.len()];
    let mut finished: Vec<(usize, usize, Entity)> = Vec::new();
    for (entity, at) in slice_order.into_iter().chain(emitted) {
        let Some((v, k)) = at else {
            // Its volcano is gone: the slice and its spheres go with it.
            commands.entity(entity).despawn();
            for (sphere, s1, _) in &rings {
                if s1.slice == entity {
                    commands.entity(sphere).despawn();
                }
            }
            continue;
        };
        let g = &plumes[v];
        let r = &g.report;
        if let Some(ev) = r.neutral.get(neutral_seen[v])
            && ev.at == k
        {
            out.neutral.write(NeutralBuoyancyReached {
                volcano: g.volcano,
                altitude: ev.altitude,
                speed: ev.speed,
            });
            neutral_seen[v] += 1;
        }
        match r.slice_fates[k] {
            SliceFate::Kept(_) | SliceFate::Retired(_) => {}
            SliceFate::NonFinite(i) => {
                let removed = &r.non_finite[i];
                commands.entity(entity).despawn();
                for &ring in &removed.ring {
                    commands.entity(all_rings[g.rings[ring]].0).despawn();
                }
            }
            SliceFate::Finished(i) => finished.push((v, i, entity)),
        }
    }

    // The finished slices, in the same order: messages, their spheres into the umbrella or
    // despawned, the hand-over to the pyroclastic domain.
    let mut detached: Vec<Entry> = Vec::new();
    for (v, i, entity) in finished {
        let g = &plumes[v];
        let f = &g.report.finished[i];
        let s = &f.removed.slice;
        match f.outcome {
            Outcome::Umbrella => {
                out.umbrella.write(UmbrellaSpreading {
                    volcano: g.volcano,
                    apex: s.state.apex,
                    neutral: s.state.neutral_altitude.unwrap_or(s.state.apex),
                });
            }
            Outcome::Collapsed => {
                out.collapsed.write(PlumeCollapsed {
                    volcano: g.volcano,
                    position: world(s),
                    mass: s.state.mass,
                });
            }
        }
        if f.buoyancy_floored {
            let z = s.vent.y as f64 + s.state.neutral_altitude.unwrap_or(s.state.apex);
            debug!("umbrella at {z:.0} m: unstable air, buoyancy frequency raised to its floor");
        }
        for (m, &ring) in f.removed.ring.iter().enumerate() {
            let (sphere, q) = all_rings[g.rings[ring]];
            if f.outcome == Outcome::Collapsed {
                commands.entity(sphere).despawn();
                continue;
            }
            let u = f.spheres.start + m;
            let cloud = match g.report.sphere_fates[u] {
                SphereFate::Kept(j) => &g.state.umbrella[j],
                SphereFate::Expired(e) => &g.report.expired[e].sphere,
                SphereFate::Retired(e) => &g.report.umbrella_retired[e].sphere,
                SphereFate::NonFinite(e) => &g.report.umbrella_non_finite[e].sphere,
            };
            let (translation, scale) = (cloud_world(cloud), Vec3::splat(cloud.radius as f32));
            let umbrella = umbrella_component(g.volcano, cloud);
            if q.is_none() {
                // Not in the world yet: spawned at the slice's first position, unturned.
                let transform = Transform { translation, rotation: Quat::IDENTITY, scale };
                commands.entity(sphere).remove::<S1>().insert((umbrella, transform));
            } else {
                if let Ok((_, _, mut transform)) = rings.get_mut(sphere) {
                    transform.translation = translation;
                    transform.scale = scale;
                }
                commands.entity(sphere).remove::<S1>().insert(umbrella);
            }
            detached.push((sphere, Some((v, u))));
        }
        commands.entity(entity).despawn();
        if f.outcome == Outcome::Collapsed {
            out.hand_over.write(SliceCollapsed(component(g.volcano, s)));
        }
    }
    for &(sphere, at) in &detached {
        if let Some((v, u)) = at {
            debug_assert_eq!(plumes[v].spheres.len(), u, "detached spheres are numbered in order");
            plumes[v].spheres.push(sphere);
        }
    }

    // The umbrella spheres' new states (in the gathered order), then their events in query
    // order, the detached ones last.
    for ((entity, mut u, mut transform), &(gathered, at)) in spheres.iter_mut().zip(&sphere_order) {
        debug_assert_eq!(entity, gathered);
        let Some((v, k)) = at else { continue };
        if let SphereFate::Kept(j) = plumes[v].report.sphere_fates[k] {
            let c = &plumes[v].state.umbrella[j];
            u.sphere = c.sphere;
            u.age = c.age;
            u.ash = c.ash;
            u.ash_pending = c.ash_pending;
            transform.translation = cloud_world(c);
            transform.scale = Vec3::splat(c.radius as f32);
        }
    }
    for (entity, at) in sphere_order.into_iter().chain(detached) {
        let Some((v, k)) = at else {
            // Its eruption is gone: nobody books its ash any more.
            commands.entity(entity).despawn();
            continue;
        };
        let g = &plumes[v];
        match g.report.sphere_fates[k] {
            SphereFate::Expired(e) => {
                let r = &g.report.expired[e];
                if r.ash_kg > 0.0 {
                    let position = cloud_world(&r.sphere);
                    out.released.write(AshReleased { volcano: g.volcano, position, mass: r.ash_kg });
                }
                commands.entity(entity).despawn();
            }
            SphereFate::NonFinite(_) => commands.entity(entity).despawn(),
            SphereFate::Kept(_) | SphereFate::Retired(_) => {}
        }
    }

    // The guard's removals (volcanoes in entity order).
    for g in by_entity.iter().map(|&v| &plumes[v]) {
        let slices: Vec<f64> = g.report.non_finite.iter().map(|r| r.ash_kg).collect();
        faults::report(&mut out.faults, g.volcano, SimDomain::Plume, &slices);
        let spheres: Vec<f64> = g.report.umbrella_non_finite.iter().map(|r| r.ash_kg).collect();
        faults::report(&mut out.faults, g.volcano, SimDomain::Umbrella, &spheres);
    }

    // The umbrella cap (volcanoes in entity order).
    for g in by_entity.iter().map(|&v| &plumes[v]).filter(|g| !g.report.umbrella_retired.is_empty()) {
        warn_once!(
            "eruption {}: more than {} umbrella spheres; the oldest expire early with their ash released \
             (PlumeCaps::max_umbrella_spheres, PlumeCapReport)",
            g.volcano,
            caps.max_umbrella_spheres
        );
        for r in &g.report.umbrella_retired {
            if r.ash_kg > 0.0 {
                let position = cloud_world(&r.sphere);
                out.released.write(AshReleased { volcano: g.volcano, position, mass: r.ash_kg });
            }
            cap_report.umbrella_retired += 1;
            cap_report.umbrella_ash_released_kg += r.ash_kg;
            commands.entity(g.spheres[r.at]).despawn();
        }
        cap_report.capped_steps += 1;
    }

    // The books.
    for g in &plumes {
        let Ok((_, eruption, mut emission, mut budget, ..)) = eruptions.get_mut(g.volcano) else { continue };
        let e = g.state.emission;
        emission.set_if_neq(EmissionState {
            since_last: e.since_last,
            emitted: e.emitted,
            backlog: e.backlog,
            capped_steps: e.capped_steps,
        });
        let a = g.state.ash;
        budget.set_if_neq(PlumeAshBudget {
            emitted_kg: a.emitted_kg,
            to_flows_kg: a.to_flows_kg,
            lost_kg: a.lost_kg,
            released_kg: a.released_kg,
            capped_kg: a.capped_kg,
        });
        if g.report.backlog_began {
            let interval = eruption.params.emission_interval();
            warn!(
                "eruption {}: slices are due every {interval:.2e} s, more than {} per {dt:.2e} s step; {} \
                 carried to the next steps (EmissionState::backlog)",
                g.volcano,
                domain::MAX_EMISSIONS_PER_STEP,
                e.backlog
            );
        }
    }
}

/// A volcano's plume before the step: its books, no slices yet.
fn gathered(volcano: Entity, emission: &EmissionState, budget: &PlumeAshBudget) -> Gathered {
    let state = PlumeState {
        emission: Emission {
            since_last: emission.since_last,
            emitted: emission.emitted,
            backlog: emission.backlog,
            capped_steps: emission.capped_steps,
        },
        ash: AshBooks {
            emitted_kg: budget.emitted_kg,
            to_flows_kg: budget.to_flows_kg,
            lost_kg: budget.lost_kg,
            released_kg: budget.released_kg,
            capped_kg: budget.capped_kg,
        },
        ..Default::default()
    };
    Gathered {
        volcano,
        state,
        report: PlumeReport::default(),
        slices: Vec::new(),
        indices: Vec::new(),
        gathered_slices: 0,
        found: Vec::new(),
        rings: Vec::new(),
        spheres: Vec::new(),
        gathered_spheres: 0,
    }
}

/// The [`RingSource`] of one volcano: the s1 spheres of the slices with these indices (`held`
/// and `indices`: the volcano's gathered slices), in the s1 query's order, in one pass; their
/// entities and places in the query go to `found`, in the same order.
fn find_rings(
    rings: &Rings,
    held: &[Entity],
    indices: &[u64],
    want: &[u64],
    found: &mut Vec<(usize, Entity)>,
) -> Vec<RingSphere> {
    let want: HashSet<u64> = want.iter().copied().collect();
    let of: EntityHashMap<u64> =
        held.iter().zip(indices).filter(|(_, i)| want.contains(i)).map(|(&e, &i)| (e, i)).collect();
    let mut out = Vec::new();
    for (q, (entity, s1, _)) in rings.iter().enumerate() {
        if let Some(&index) = of.get(&s1.slice) {
            out.push(RingSphere { slice: index, id: s1.id, sphere: s1.sphere });
            found.push((q, entity));
        }
    }
    out
}

/// World position of a slice's centre.
fn world(s: &LiveSlice) -> Vec3 {
    s.vent + plume_to_world(s.state.position)
}

/// World position of an umbrella sphere.
fn cloud_world(c: &CloudSphere) -> Vec3 {
    c.vent + plume_to_world(c.position())
}

/// The slice component of a model slice.
fn component(volcano: Entity, s: &LiveSlice) -> PlumeSlice {
    PlumeSlice {
        volcano,
        index: s.index,
        vent: s.vent,
        state: s.state.clone(),
        ring_phase: s.ring_phase,
        ash_pending: s.ash_pending,
        secondary: s.secondary,
    }
}

/// The umbrella component of a model sphere.
fn umbrella_component(volcano: Entity, c: &CloudSphere) -> Umbrella {
    Umbrella {
        volcano,
        sphere: c.sphere,
        radius: c.radius,
        density: c.density,
        age: c.age,
        vent: c.vent,
        id: c.id,
        ash: c.ash,
        ash_pending: c.ash_pending,
    }
}
