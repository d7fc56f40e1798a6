//! [`PlumePlugin`]: the plume domain (`PlumeStep`, `Substeps(10)` = 0.002 s per step as in
//! Table 3.1). Systems gather, call the model, write back:
//!
//! - [`PlumeSystems::Prepare`]: eruption scripts apply their timelines (`follow_scripts`);
//! - [`PlumeSystems::Step`]: the domain step (`step::step_plume`): each volcano's slices, rings
//!   and umbrella spheres are gathered into a [`PlumeState`](crate::model::domain::PlumeState),
//!   stepped once by [`crate::model::domain::step`] (emission, the live-slice cap, the slices,
//!   finishing into the umbrella or a collapse, the umbrella, the umbrella cap), and written
//!   back as transforms, spawns, despawns and `Umbrella` insertions, with the messages.
//!
//! Outside the step: secondary columns handed over by the pyroclastic domain are spawned in
//! its schedule (`adopt_secondary_columns`), and s1 transforms follow their slices once per
//! base tick (`sync_sphere_transforms`, `SimSystems::End`).

mod step;
mod step_length;

use bevy::ecs::schedule::ScheduleLabel;
use bevy::math::DQuat;
use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::components::*;
use crate::model::domain::{RingSphere, ring};
use crate::model::params::{PlumeParams, Preset};
use crate::model::slice::Slice;
use crate::model::spheres::SphereParams;

pub use crate::model::domain::MAX_EMISSIONS_PER_STEP;
pub use step_length::MAX_PLUME_STEP_S;

/// Schedule of the plume domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, TypePath)]
pub struct PlumeStep;

/// The plume domain's step, in order, inside [`PlumeStep`]: games order their systems against
/// these (a system `.after(PlumeSystems::Step)` sees the stepped slices, spheres and books, with
/// spawns and despawns applied).
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PlumeSystems {
    /// Eruption scripts apply their timelines to their eruptions' parameters. A game editing
    /// an eruption for this step orders its system after this set and before `Step`.
    Prepare,
    /// One call of [`crate::model::domain::step`] per volcano, written back to the world, and
    /// the messages ([`SliceCollapsed`], [`PlumeCollapsed`], [`UmbrellaSpreading`],
    /// [`NeutralBuoyancyReached`], [`AshReleased`]).
    Step,
}

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
            // Owned by volcano_core; registering twice is harmless.
            .add_message::<volcano_core::SimFault>()
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
            .configure_sets(PlumeStep, (PlumeSystems::Prepare, PlumeSystems::Step).chain())
            .add_systems(FixedUpdate, step_length::keep_plume_steps_short.in_set(SimSystems::Begin))
            .add_systems(PlumeStep, follow_scripts.in_set(PlumeSystems::Prepare))
            .add_systems(PlumeStep, step::step_plume.in_set(PlumeSystems::Step))
            // In the pyroclastic step, right after the lift-off, so a secondary column exists
            // from the tick it formed in.
            .add_systems(
                crate::pyroclastic::PyroclasticStep,
                adopt_secondary_columns.after(crate::pyroclastic::PyroclasticSystems::Step),
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

/// Spawns a slice entity and the s1 spheres of its ring (`ring_at`: their transform until
/// `sync_sphere_transforms` places them). Returns the slice's entity and the spheres', in ring
/// order.
pub(crate) fn spawn_with_ring(
    commands: &mut Commands,
    name: String,
    (at, slice): (Transform, PlumeSlice),
    ring_at: Transform,
    ring: &[RingSphere],
) -> (Entity, Vec<Entity>) {
    let entity = commands.spawn((Name::new(name), at, slice)).id();
    let spheres = ring
        .iter()
        .map(|r| commands.spawn((ring_at, S1 { slice: entity, sphere: r.sphere, spin: 0.0, id: r.id })).id())
        .collect();
    (entity, spheres)
}

/// Spawns a slice where it is and its s1 ring (sizes and offset from the slice's own random
/// stream, [`ring`]).
pub(crate) fn spawn_slice(
    commands: &mut Commands,
    slice: PlumeSlice,
    spheres: &SphereParams,
    rng: &VolcanoRng,
    name: String,
) {
    let ring = ring(spheres, rng, slice.index);
    let at = Transform::from_translation(slice.vent + plume_to_world(slice.state.position));
    spawn_with_ring(commands, name, (at, slice), at, &ring);
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
