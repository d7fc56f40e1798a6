//! [`PlumePlugin`]: the plume domain (`PlumeStep`, `Substeps(10)` = 0.002 s per step as in
//! Table 3.1). Systems gather, call the model, write back.

use bevy::ecs::entity::EntityHashSet;
use bevy::ecs::schedule::ScheduleLabel;
use bevy::math::{DQuat, DVec3};
use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::components::*;
use crate::model::params::{Dynamics, PlumeParams, Preset};
use crate::model::slice::{Phase, Slice, SliceEnv};
use crate::model::spheres::{SphereParams, s1_ring};
use crate::model::umbrella::{Spread, UmbrellaSphere, buoyancy_frequency, gravity_current_coefficient};

/// Schedule of the plume domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, TypePath)]
pub struct PlumeStep;

/// Explosive plumes: slices, s1 spheres, umbrella, messages.
#[derive(Debug, Default, Clone)]
pub struct PlumePlugin;

impl Plugin for PlumePlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<crate::pyroclastic::PyroclasticPlugin>() {
            app.add_plugins(crate::pyroclastic::PyroclasticPlugin);
        }
        app.add_sim_domain::<PlumeStep>(SimSystems::Plume, Cadence::Substeps(10))
            .add_message::<PlumeCollapsed>()
            .add_message::<SliceCollapsed>()
            .add_message::<SecondaryColumnRising>()
            .add_message::<NeutralBuoyancyReached>()
            .add_message::<UmbrellaSpreading>()
            .add_message::<AshReleased>()
            .init_resource::<crate::caps::PlumeCaps>()
            .init_resource::<crate::caps::PlumeCapReport>()
            .register_type::<crate::caps::PlumeCaps>()
            .register_type::<crate::caps::PlumeCapReport>()
            .register_type::<Eruption>()
            .register_type::<EmissionState>()
            .register_type::<EruptionScript>()
            .register_type::<PlumeAshBudget>()
            .register_type::<PlumeAmbient>()
            .register_type::<PlumeSlice>()
            .register_type::<S1>()
            .register_type::<Umbrella>()
            .add_systems(
                PlumeStep,
                (
                    follow_scripts,
                    emit_slices,
                    crate::caps::cap_live_slices,
                    step_slices,
                    step_umbrella,
                    crate::caps::cap_umbrella,
                )
                    .chain(),
            )
            // In the pyroclastic step, right after the lift-off, so a secondary column exists
            // from the tick it formed in.
            .add_systems(
                crate::pyroclastic::PyroclasticStep,
                adopt_secondary_columns.after(crate::pyroclastic::PyroclasticSystems::LiftOff),
            )
            .add_systems(FixedUpdate, sync_sphere_transforms.in_set(SimSystems::End));
    }
}

/// Applies each [`EruptionScript`]'s timeline at the script's time, then advances its clock.
/// A change the eruption would reject is not applied (reported once).
fn follow_scripts(time: Res<Time>, mut scripts: Query<(&mut EruptionScript, &mut Eruption)>) {
    let dt = time.delta_secs_f64();
    for (mut script, mut eruption) in &mut scripts {
        let state = script.timeline.sample(script.elapsed_s);
        if state.preset.is_some() && state.preset != script.applied_preset {
            let old = &eruption.params;
            let fresh = PlumeParams {
                atmosphere: old.atmosphere,
                vent_altitude: old.vent_altitude,
                wind: old.wind.clone(),
                relative_humidity: old.relative_humidity,
                ..state.preset.map(Preset::params).unwrap_or_default()
            };
            eruption.params = fresh;
            script.applied_preset = state.preset;
        }
        let mut params = eruption.params.clone();
        match state.apply(&mut params) {
            Ok(()) if params != eruption.params => eruption.params = params,
            Ok(()) => {}
            Err(e) => {
                warn_once!("EruptionScript at {:.1} s: {e}; the eruption keeps its vent", script.elapsed_s)
            }
        }
        if let Some(active) = state.active
            && eruption.active != active
        {
            eruption.active = active;
        }
        script.elapsed_s += dt;
    }
}

fn emit_slices(
    time: Res<Time>,
    mut commands: Commands,
    mut volcanoes: Query<(
        Entity,
        &Eruption,
        &mut EmissionState,
        &mut PlumeAshBudget,
        &VentPosition,
        &VolcanoRng,
    )>,
) {
    let dt = time.delta_secs_f64();
    for (entity, eruption, mut emission, mut ash, vent, rng) in &mut volcanoes {
        if !eruption.active || eruption.validate().is_err() {
            continue;
        }
        emission.since_last += dt;
        let interval = eruption.params.emission_interval();
        // At most a few per step so a huge edit cannot flood the world; what is due beyond
        // that is carried to the next steps and reported (`EmissionState::backlog`).
        let mut budget = MAX_EMISSIONS_PER_STEP;
        while emission.since_last >= interval && budget > 0 {
            emission.since_last -= interval;
            budget -= 1;
            let index = emission.emitted;
            emission.emitted += 1;
            let state = Slice::at_vent(&eruption.params);
            ash.emitted_kg += state.solid_mass;
            let slice = PlumeSlice {
                volcano: entity,
                index,
                vent: vent.0,
                state,
                ring_phase: 0.0,
                ash_pending: 0.0,
                secondary: false,
            };
            spawn_slice(&mut commands, slice, &eruption.spheres, rng, format!("Plume slice {index}"));
        }
        let backlog = (emission.since_last / interval).floor() as u64;
        if backlog > 0 && emission.backlog == 0 {
            warn!(
                "eruption {entity}: slices are due every {interval:.2e} s, more than {MAX_EMISSIONS_PER_STEP} per \
                 {dt:.2e} s step; {backlog} carried to the next steps (EmissionState::backlog)"
            );
        }
        emission.backlog = backlog;
        emission.capped_steps += u64::from(backlog > 0);
    }
}

/// Most slices an eruption emits per plume step.
pub const MAX_EMISSIONS_PER_STEP: u32 = 4;

/// Spawns a slice and its s1 ring (sizes and offset from the slice's own random stream).
pub(crate) fn spawn_slice(
    commands: &mut Commands,
    slice: PlumeSlice,
    spheres: &SphereParams,
    rng: &VolcanoRng,
    name: String,
) {
    let index = slice.index;
    let ring = s1_ring(spheres, &mut rng.stream("slice", index));
    let at = Transform::from_translation(slice.vent + plume_to_world(slice.state.position));
    let slice = commands.spawn((Name::new(name), at, slice)).id();
    for (k, sphere) in ring.into_iter().enumerate() {
        commands.spawn((at, S1 { slice, sphere, spin: 0.0, id: (index << 8) | k as u64 }));
    }
}

#[allow(clippy::too_many_arguments)]
fn step_slices(
    time: Res<Time>,
    mut commands: Commands,
    mut eruptions: Query<(Entity, &Eruption, Option<&PlumeAmbient>, &mut PlumeAshBudget)>,
    mut slices: Query<(Entity, &mut PlumeSlice, &mut Transform), Without<S1>>,
    spheres: Query<(Entity, &S1)>,
    mut collapsed: MessageWriter<PlumeCollapsed>,
    mut hand_over: MessageWriter<SliceCollapsed>,
    mut neutral: MessageWriter<NeutralBuoyancyReached>,
    mut umbrella: MessageWriter<UmbrellaSpreading>,
) {
    let dt = time.delta_secs_f64();
    // Validate each eruption once per step, not once per slice.
    let invalid: EntityHashSet =
        eruptions.iter().filter(|(_, e, _, _)| e.validate().is_err()).map(|(e, ..)| e).collect();
    let mut finished: Vec<(Entity, Phase, PlumeSlice)> = Vec::new();
    for (entity, mut slice, mut transform) in &mut slices {
        let Ok((_, eruption, ambient, _)) = eruptions.get(slice.volcano) else {
            // Its volcano is gone: the slice and its spheres go with it.
            despawn_with_ring(&mut commands, entity, &spheres);
            continue;
        };
        if invalid.contains(&slice.volcano) {
            // An invalid live edit: freeze the column until the parameters are fixed.
            continue;
        }
        let p = &eruption.params;
        let vent_altitude = slice.vent.y as f64;
        let report = match ambient {
            // Coupled: the layers' air and wind around the column (§4.3.3).
            Some(PlumeAmbient(a)) => {
                let wind = |z: f64| a.wind_at(vent_altitude + z);
                slice.state.step(p, &SliceEnv { air: a, vent_altitude, wind: &wind }, dt)
            }
            None => {
                let wind = |z: f64| p.wind.at(z);
                slice.state.step(p, &SliceEnv { air: &p.air(), vent_altitude, wind: &wind }, dt)
            }
        };
        slice.ash_pending += report.sedimented;
        // Spin of the ring spheres: Ω = v / r_s about the ring tangent (mean size r_s = r/2).
        slice.ring_phase += slice.state.velocity.length() / (0.5 * slice.state.r).max(1e-9) * dt;
        if report.reached_neutral {
            neutral.write(NeutralBuoyancyReached {
                volcano: slice.volcano,
                altitude: slice.state.neutral_altitude.unwrap_or(0.0),
                speed: slice.state.neutral_speed.unwrap_or(0.0),
            });
        }
        transform.translation = slice.vent + plume_to_world(slice.state.position);
        transform.rotation = orientation(&slice.state);
        if !slice.state.is_finite() {
            warn!("plume slice {} became non-finite and was removed", slice.index);
            if let Ok((.., mut ash)) = eruptions.get_mut(slice.volcano) {
                ash.lost_kg += slice.ash_pending + slice.state.solid_mass.max(0.0);
            }
            despawn_with_ring(&mut commands, entity, &spheres);
            continue;
        }
        if matches!(slice.state.phase, Phase::Collapsed | Phase::Umbrella) {
            finished.push((entity, slice.state.phase, slice.clone()));
        }
    }
    for (entity, phase, slice) in finished {
        let s = &slice.state;
        let world = slice.vent + plume_to_world(s.position);
        if phase == Phase::Umbrella {
            umbrella.write(UmbrellaSpreading {
                volcano: slice.volcano,
                apex: s.apex,
                neutral: s.neutral_altitude.unwrap_or(s.apex),
            });
        } else {
            collapsed.write(PlumeCollapsed { volcano: slice.volcano, position: world, mass: s.mass });
        }
        let ring: Vec<(Entity, &S1)> = spheres.iter().filter(|(_, s1)| s1.slice == entity).collect();
        // The slice's ash: shared among its umbrella spheres, or handed to the flows.
        let solid = s.solid_mass.max(0.0);
        if let Ok((.., mut ash)) = eruptions.get_mut(slice.volcano) {
            if phase == Phase::Collapsed {
                ash.to_flows_kg += solid + slice.ash_pending;
            } else if ring.is_empty() {
                ash.lost_kg += solid + slice.ash_pending;
            }
        }
        let share = 1.0 / ring.len().max(1) as f64;
        let spread = umbrella_spread(&slice, eruptions.get(slice.volcano).ok().map(|(_, e, a, _)| (e, a)));
        for (k, &(sphere_entity, s1)) in ring.iter().enumerate() {
            if phase == Phase::Umbrella {
                // Spread radially around the column axis from where the sphere sits on the
                // (possibly tilted) vortex ring (the umbrella law's clamp d ≥ r moves it at v
                // until d = r); a gravity current's spheres start on the axis.
                let kin = UmbrellaSphere::detach(s, s1.sphere.local_offset(s.r), spread);
                commands.entity(sphere_entity).remove::<S1>().insert(Umbrella {
                    volcano: slice.volcano,
                    sphere: kin,
                    radius: s1.sphere.radius(s.r),
                    density: s.density,
                    age: 0.0,
                    vent: slice.vent,
                    id: s1.id,
                    ash: solid * share,
                    // What the slice shed and the coupling has not taken yet rides on the first.
                    ash_pending: if k == 0 { slice.ash_pending } else { 0.0 },
                });
            } else {
                commands.entity(sphere_entity).despawn();
            }
        }
        commands.entity(entity).despawn();
        if phase == Phase::Collapsed {
            hand_over.write(SliceCollapsed(slice));
        }
    }
}

/// Removes a slice and the s1 spheres of its ring.
fn despawn_with_ring(commands: &mut Commands, slice: Entity, spheres: &Query<(Entity, &S1)>) {
    commands.entity(slice).despawn();
    for (sphere, s1) in spheres.iter() {
        if s1.slice == slice {
            commands.entity(sphere).despawn();
        }
    }
}

/// Spawns the secondary columns the pyroclastic domain handed over (with their s1 rings from
/// their own random streams), right after its lift-off.
fn adopt_secondary_columns(
    mut commands: Commands,
    mut rising: MessageReader<SecondaryColumnRising>,
    eruptions: Query<(&Eruption, &VolcanoRng)>,
) {
    for SecondaryColumnRising(slice) in rising.read() {
        if let Ok((eruption, rng)) = eruptions.get(slice.volcano) {
            let name = format!("Secondary column {}", slice.index);
            spawn_slice(&mut commands, slice.clone(), &eruption.spheres, rng, name);
        }
    }
}

/// How a slice's umbrella spheres spread: the thesis' law, or for a column slice a gravity
/// current fed by the column's volume rate at the top (the slice's volume over the emission
/// interval) in the air's buoyancy frequency at the neutral level.
fn umbrella_spread(slice: &PlumeSlice, eruption: Option<(&Eruption, Option<&PlumeAmbient>)>) -> Spread {
    let Some((eruption, ambient)) = eruption else { return Spread::Thesis };
    let p = &eruption.params;
    if p.dynamics != Dynamics::Column {
        return Spread::Thesis;
    }
    let s = &slice.state;
    let z = slice.vent.y as f64 + s.neutral_altitude.unwrap_or(s.apex);
    let (n, floored) = match ambient {
        Some(PlumeAmbient(a)) => buoyancy_frequency(a, z),
        None => buoyancy_frequency(&p.air(), z),
    };
    if floored {
        debug!("umbrella at {z:.0} m: unstable air, buoyancy frequency raised to its floor");
    }
    let q = s.volume() / p.emission_interval();
    Spread::GravityCurrent { c: gravity_current_coefficient(p.umbrella_lambda, n, q) }
}

fn step_umbrella(
    time: Res<Time>,
    mut commands: Commands,
    mut eruptions: Query<(&Eruption, Option<&PlumeAmbient>, &mut PlumeAshBudget)>,
    mut spheres: Query<(Entity, &mut Umbrella, &mut Transform)>,
    mut released: MessageWriter<AshReleased>,
) {
    let dt = time.delta_secs_f64();
    for (entity, mut u, mut transform) in &mut spheres {
        let Ok((eruption, ambient, mut budget)) = eruptions.get_mut(u.volcano) else {
            // Its eruption is gone: nobody books its ash any more.
            commands.entity(entity).despawn();
            continue;
        };
        u.sphere.step(dt);
        // The spreading cloud drifts with the wind at its altitude (the column axis moves).
        let altitude = u.sphere.altitude();
        let wind = match ambient {
            Some(PlumeAmbient(a)) => a.wind_at(u.vent.y as f64 + altitude),
            None => eruption.params.wind.at(altitude),
        };
        u.sphere.axis += wind * dt;
        u.age += dt;
        // Ash fallout from the spreading cloud, exact for any step: a share 1 − exp(−Δt/τ).
        let fallout = u.ash * (1.0 - (-dt / eruption.umbrella_fallout_s).exp());
        u.ash -= fallout;
        u.ash_pending += fallout;
        let lifetime = eruption.umbrella_lifetime;
        let h = u.sphere.horizontal();
        transform.translation = u.vent + plume_to_world(DVec3::new(h.x, h.y, u.sphere.altitude()));
        transform.scale = Vec3::splat(u.radius as f32);
        if u.age > lifetime {
            let mass = u.ash + u.ash_pending;
            if mass > 0.0 {
                budget.released_kg += mass;
                released.write(AshReleased { volcano: u.volcano, position: transform.translation, mass });
            }
            commands.entity(entity).despawn();
        }
    }
}

/// Places s1 spheres on their slice's ring in world space (scale = radius) and turns them by
/// their spin.
fn sync_sphere_transforms(
    slices: Query<(&PlumeSlice, &Transform), Without<S1>>,
    mut spheres: Query<(&mut S1, &mut Transform), Without<PlumeSlice>>,
) {
    for (mut s1, mut transform) in &mut spheres {
        if let Ok((slice, slice_tf)) = slices.get(s1.slice) {
            s1.spin = (slice.ring_phase / s1.sphere.size_factor.max(1e-9)) % std::f64::consts::TAU;
            let r = slice.state.r;
            let local = s1.sphere.local_offset(r);
            // Slice frame: local z along the trajectory; local x/y in the slice plane.
            let world_offset = slice_tf.rotation * plume_to_world(local);
            transform.translation = slice_tf.translation + world_offset;
            let spin_axis = slice_tf.rotation * plume_to_world(s1.sphere.spin_axis());
            transform.rotation = Quat::from_axis_angle(spin_axis.normalize_or(Vec3::X), s1.spin as f32);
            transform.scale = Vec3::splat(s1.sphere.radius(r) as f32);
        }
    }
}

/// Rotation taking the plume axis (world +y) to the direction of motion: slices stay
/// orthogonal to their trajectory (§3.4.3).
/// The model's [`Slice::rotation`] taken to world axes (plume frame → world is a quarter turn
/// about x), so the ring drawn and the umbrella it detaches into agree.
fn orientation(state: &Slice) -> Quat {
    let to_world = DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2);
    (to_world * state.rotation() * to_world.inverse()).as_quat()
}
