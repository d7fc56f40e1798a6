//! Smooth motion between base ticks: the simulation moves its entities once per base tick
//! (`Time<Fixed>`, 50–64 Hz), a game draws at 60–240 Hz. [`TickInterpolationPlugin`] shows every
//! entity carrying a [`TickInterpolation`] between its last two ticks' transforms, at the
//! fraction of the tick the frame has reached (`Time<Fixed>::overstep_fraction`): what is drawn
//! lags the simulation by one tick and moves on every frame.
//!
//! The simulation never sees an interpolated transform: the transform it wrote is put back
//! before the fixed loop runs (so the state, and everything derived from it, is the same with
//! or without the plugin, at any frame rate; `volcano_render`'s `tests/interpolation.rs`), and
//! recorded after each tick (`FixedLast`). Between the fixed loop and the next frame's fixed loop
//! (`Update`, `PostUpdate`, rendering) the transform is the interpolated one. Move such
//! entities from the fixed loop: a transform written in `Update` is overwritten by the one the
//! last tick left.
//!
//! Written by hand (about forty lines): the ecosystem's transform-interpolation crates follow
//! Bevy releases and none is in this workspace's dependency set for Bevy 0.19.

use bevy::app::{App, FixedLast, Plugin, RunFixedMainLoop, RunFixedMainLoopSystems};
use bevy::ecs::prelude::*;
use bevy::reflect::{Reflect, std_traits::ReflectDefault};
use bevy::time::{Fixed, Time};
use bevy::transform::components::Transform;

/// The transforms an entity had at the end of its last two base ticks (a component; see the
/// [module docs](self)). Add it to any entity the simulation moves in the fixed loop; the render
/// plugins make it a required component of slices, s1 and umbrella spheres and pyroclastic
/// particles.
#[derive(Component, Reflect, Debug, Clone, Copy, PartialEq, Default)]
#[reflect(Component, Default, Clone)]
pub struct TickInterpolation {
    /// At the end of the tick before the last (`None` until the entity has lived through a
    /// tick).
    pub previous: Option<Transform>,
    /// At the end of the last tick: the transform the simulation wrote.
    pub current: Option<Transform>,
}

impl TickInterpolation {
    /// The transform drawn at fraction `alpha` ∈ [0, 1] of the tick after the last one:
    /// translation and scale linear, rotation spherical-linear, from `previous` to `current`.
    /// `None` before the first tick.
    pub fn at(&self, alpha: f32) -> Option<Transform> {
        let current = self.current?;
        let previous = self.previous.unwrap_or(current);
        if previous == current {
            return Some(current);
        }
        let a = if alpha.is_finite() { alpha.clamp(0.0, 1.0) } else { 1.0 };
        Some(Transform {
            translation: previous.translation.lerp(current.translation, a),
            rotation: previous.rotation.slerp(current.rotation, a),
            scale: previous.scale.lerp(current.scale, a),
        })
    }
}

/// System sets of [`TickInterpolationPlugin`] (public so a game can order against them).
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TickInterpolationSystems {
    /// Before the fixed loop: the transform the last tick wrote is put back.
    Restore,
    /// `FixedLast`, after every tick: the tick's transform is recorded.
    Record,
    /// After the fixed loop: the transform between the last two ticks is shown.
    Interpolate,
}

/// Shows [`TickInterpolation`] entities between their last two ticks (module docs).
#[derive(Debug, Default, Clone)]
pub struct TickInterpolationPlugin;

impl Plugin for TickInterpolationPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<TickInterpolation>()
            .add_systems(
                RunFixedMainLoop,
                (
                    restore
                        .in_set(TickInterpolationSystems::Restore)
                        .in_set(RunFixedMainLoopSystems::BeforeFixedMainLoop),
                    interpolate
                        .in_set(TickInterpolationSystems::Interpolate)
                        .in_set(RunFixedMainLoopSystems::AfterFixedMainLoop),
                ),
            )
            .add_systems(FixedLast, record.in_set(TickInterpolationSystems::Record));
    }
}

fn restore(mut moved: Query<(&mut Transform, &TickInterpolation)>) {
    for (mut transform, ticks) in &mut moved {
        if let Some(current) = ticks.current {
            // Only entities that were shown elsewhere are written (change detection).
            transform.set_if_neq(current);
        }
    }
}

fn record(mut moved: Query<(&Transform, &mut TickInterpolation)>) {
    for (transform, mut ticks) in &mut moved {
        let previous = ticks.current.unwrap_or(*transform);
        *ticks = TickInterpolation { previous: Some(previous), current: Some(*transform) };
    }
}

fn interpolate(fixed: Res<Time<Fixed>>, mut moved: Query<(&mut Transform, &TickInterpolation)>) {
    let alpha = fixed.overstep_fraction();
    for (mut transform, ticks) in &mut moved {
        if let Some(shown) = ticks.at(alpha) {
            transform.set_if_neq(shown);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::{Quat, Vec3};

    #[test]
    fn before_a_tick_nothing_is_shown_and_a_still_entity_stays() {
        assert_eq!(TickInterpolation::default().at(0.5), None);
        let t = Transform::from_xyz(1.0, 2.0, 3.0);
        let still = TickInterpolation { previous: Some(t), current: Some(t) };
        assert_eq!(still.at(0.3), Some(t));
    }

    #[test]
    fn the_shown_transform_goes_from_the_tick_before_to_the_last() {
        let a = Transform::from_xyz(0.0, 0.0, 0.0);
        let b = Transform::from_xyz(10.0, 0.0, 0.0)
            .with_rotation(Quat::from_rotation_y(1.0))
            .with_scale(Vec3::splat(3.0));
        let ticks = TickInterpolation { previous: Some(a), current: Some(b) };
        assert_eq!(ticks.at(0.0), Some(a));
        assert_eq!(ticks.at(1.0), Some(b));
        let mid = ticks.at(0.25).unwrap();
        assert!((mid.translation.x - 2.5).abs() < 1e-6);
        assert!((mid.scale.x - 1.5).abs() < 1e-6);
        assert!((mid.rotation.angle_between(Quat::IDENTITY) - 0.25).abs() < 1e-5);
        // Out-of-range or non-finite fractions show an end, never NaN.
        assert_eq!(ticks.at(7.0), Some(b));
        assert_eq!(ticks.at(f32::NAN), Some(b));
    }
}
