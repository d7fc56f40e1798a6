//! The ash light one frame behind, off the main thread ([`AshLightSettings::off_thread`]).
//!
//! Lighting the parents ([`light_parents`]: two optical-depth grids and a lookup per parent)
//! costs the main thread several milliseconds a frame with ~6,000 parents, more with the
//! particles of pyroclastic currents. So each frame takes the light computed from the previous
//! frame's parents, waiting for it if it is not done yet (a frame is deterministic: it never
//! depends on how fast the task ran), matches it to this frame's parents by their sort key
//! (eruption, kind, id: [`gather_parents`](volcano_plume::view::gather_parents)'s order, so one
//! merge pass), and starts the light of this frame's parents on the `AsyncComputeTaskPool`.
//! A parent new since then takes the light of the parent before it in that order when it is of
//! the same eruption and kind (a new s1 sphere is born beside the previous one), else full
//! light. The light lags the ash by one frame (tens of milliseconds): nothing a viewer sees.

use bevy::prelude::*;
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on};
use volcano_core::parallel::{Pool, on_pool};
use volcano_plume::view::{AshLightSettings, ParentLight, ParentSphere, light_parents};

/// A parent's place in the order of the gathered parents.
type Key = (usize, bool, bool, bool, u64);

fn key(p: &ParentSphere) -> Key {
    (p.eruption, p.flow, p.cloud, p.umbrella, p.id)
}

/// Light of a frame's parents, by their keys (ascending).
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct LitParents {
    keys: Vec<Key>,
    light: Vec<ParentLight>,
}

impl LitParents {
    fn compute(parents: &[ParentSphere], settings: &AshLightSettings) -> Self {
        Self { keys: parents.iter().map(key).collect(), light: light_parents(parents, settings) }
    }

    /// This light for `parents` (in the gathered order): each parent's own entry, else the
    /// light of the parent before it if that one is of the same eruption and kind, else
    /// [`ParentLight::CLEAR`].
    fn carry(&self, parents: &[ParentSphere]) -> Vec<ParentLight> {
        let mut j = 0;
        let mut out: Vec<ParentLight> = Vec::with_capacity(parents.len());
        for (i, p) in parents.iter().enumerate() {
            let k = key(p);
            while j < self.keys.len() && self.keys[j] < k {
                j += 1;
            }
            let light = if self.keys.get(j) == Some(&k) {
                self.light[j]
            } else {
                match i.checked_sub(1).map(|b| (key(&parents[b]), out[b])) {
                    Some((before, light))
                        if (before.0, before.1, before.2, before.3) == (k.0, k.1, k.2, k.3) =>
                    {
                        light
                    }
                    _ => ParentLight::CLEAR,
                }
            };
            out.push(light);
        }
        out
    }
}

/// The light in flight and the last one finished (a render-app-free resource of the main
/// world, used by [`update_parents`](super::update_parents)).
#[derive(Resource, Default)]
pub(super) struct AshLightTask {
    running: Option<Task<LitParents>>,
    last: LitParents,
}

impl AshLightTask {
    /// The light of `parents` for this frame (see the module docs); without the async pool or
    /// with `off_thread` false, computed now.
    pub(super) fn light(
        &mut self,
        parents: &[ParentSphere],
        settings: &AshLightSettings,
    ) -> Vec<ParentLight> {
        let pool = if settings.off_thread { AsyncComputeTaskPool::try_get() } else { None };
        let Some(pool) = pool else {
            // Kept as the last light, so switching back on carries this frame's, not an old one.
            self.running = None;
            self.last = LitParents::compute(parents, settings);
            return self.last.light.clone();
        };
        if let Some(task) = self.running.take() {
            self.last = block_on(task);
        }
        let light = self.last.carry(parents);
        let (parents, settings) = (parents.to_vec(), settings.clone());
        // Its grids and lookups run their bands on the same pool: a task the main thread may
        // wait for must not fill the compute pool that runs the app's systems.
        self.running =
            Some(pool.spawn(async move {
                on_pool(Pool::AsyncCompute, || LitParents::compute(&parents, &settings))
            }));
        light
    }
}

#[cfg(test)]
mod tests {
    use bevy::tasks::TaskPool;

    use super::*;

    fn parent(id: u64, x: f32, umbrella: bool) -> ParentSphere {
        ParentSphere {
            id,
            eruption: 0,
            center: Vec3::new(x, 2_000.0 + 0.3 * x, 0.0),
            radius: 150.0,
            rotation: Quat::IDENTITY,
            density: 2.0,
            umbrella,
            flow: false,
            cloud: false,
        }
    }

    /// A row of parents marching toward a low sun, so each one shades those behind it; in
    /// the gathered order (s1 before umbrella, then by id).
    fn frame(ids: &[u64], shift: f32) -> Vec<ParentSphere> {
        let mut v: Vec<ParentSphere> =
            ids.iter().map(|&id| parent(id, 120.0 * id as f32 + shift, id >= 50)).collect();
        v.sort_by_key(key);
        v
    }

    #[test]
    fn each_frame_gets_the_light_of_the_frame_before_matched_by_parent() {
        AsyncComputeTaskPool::get_or_init(TaskPool::default);
        let settings = AshLightSettings { sun: Vec3::new(-1.0, 0.2, 0.0), ..default() };
        let first = frame(&(0..40).chain(50..60).collect::<Vec<_>>(), 0.0);
        // The next frame: parents moved, 3 and 51 gone, 40, 41 (after 40, new too) and 60 new,
        // each after a parent of its kind.
        let second = frame(
            &(0..40)
                .filter(|&i| i != 3)
                .chain(40..42)
                .chain((50..61).filter(|&i| i != 51))
                .collect::<Vec<_>>(),
            7.0,
        );
        let mut task = AshLightTask::default();
        let lit_first = task.light(&first, &settings);
        assert!(
            lit_first.iter().all(|l| *l == ParentLight::CLEAR),
            "nothing computed before the first frame"
        );
        let lit_second = task.light(&second, &settings);
        let reference = light_parents(&first, &settings);
        let of_first = |id: u64, umbrella: bool| {
            let i = first.iter().position(|p| p.id == id && p.umbrella == umbrella).unwrap();
            reference[i]
        };
        let mut shaded = 0;
        for (i, p) in second.iter().enumerate() {
            let expected = match p.id {
                40 | 41 => of_first(39, false),
                60 => of_first(59, true),
                id => of_first(id, p.umbrella),
            };
            assert_eq!(lit_second[i], expected, "parent {}", p.id);
            shaded += usize::from(expected.sun < 0.9);
        }
        assert!(shaded > 10, "the test's parents shade each other ({shaded} shaded)");
        // The third frame gets the second's light, computed from the second's positions.
        let lit_third = task.light(&second, &settings);
        assert_eq!(lit_third, light_parents(&second, &settings));
    }

    #[test]
    fn a_new_parent_of_another_kind_or_first_of_all_is_fully_lit() {
        let last = LitParents::compute(&frame(&[5, 6, 55], 0.0), &AshLightSettings::default());
        // 1 comes first of all; 50 is the first umbrella sphere, after an s1 sphere.
        let light = last.carry(&frame(&[1, 5, 50, 55], 0.0));
        assert_eq!(light[0], ParentLight::CLEAR);
        assert_eq!(light[2], ParentLight::CLEAR);
        assert_eq!((light[1], light[3]), (last.light[0], last.light[2]));
    }

    #[test]
    fn off_the_pool_or_switched_off_the_light_is_the_frames_own() {
        let settings = AshLightSettings { off_thread: false, sun: Vec3::new(-1.0, 0.2, 0.0), ..default() };
        let parents = frame(&(0..20).collect::<Vec<_>>(), 0.0);
        let mut task = AshLightTask::default();
        assert_eq!(task.light(&parents, &settings), light_parents(&parents, &settings));
        // Switched back on, the first frame carries the light of the last one computed.
        AsyncComputeTaskPool::get_or_init(TaskPool::default);
        let on = AshLightSettings { off_thread: true, ..settings.clone() };
        assert_eq!(task.light(&parents, &on), light_parents(&parents, &settings));
    }
}
