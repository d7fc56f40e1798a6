//! The ash light off the main thread ([`AshLightSettings::off_thread`]), every few base ticks
//! ([`AshLightSettings::refresh_ticks`]).
//!
//! Lighting the parents ([`light_parents`]: two optical-depth grids and a lookup per parent)
//! costs ≈ 10 ms of the pool with ~6,000 parents, twice that with the particles of
//! pyroclastic currents. So a light starts on the `AsyncComputeTaskPool` only every
//! `refresh_ticks` base ticks (or at once when the sun turns or the grid changes), and is
//! taken up `refresh_ticks` ticks or frames after it started, whichever comes first, waiting
//! for it if it is not done yet: a frame never depends on how fast the task ran. Every frame
//! matches the last light taken up to its own parents by their sort key (eruption, kind, id:
//! [`gather_parents`](volcano_plume::view::gather_parents)'s order, so one merge pass). A
//! parent new since then takes the light of the parent before it in that order when it is of
//! the same eruption and kind (a new s1 sphere is born beside the previous one), else full
//! light. The light lags the ash by one to two refresh intervals (60–120 ms at the default 3
//! ticks of 1/50 s): the ash moves metres in that time, against grid cells of tens to hundreds
//! of metres.

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

/// A light in flight and the rendered frames since it started.
struct Running {
    task: Task<LitParents>,
    frames: u32,
}

/// The light in flight, the last one finished and when the last one started (a
/// render-app-free resource of the main world, used by [`update_parents`](super::update_parents)).
#[derive(Resource, Default)]
pub(super) struct AshLightTask {
    running: Option<Running>,
    last: LitParents,
    /// Base tick (if known) and settings of the last light started.
    started: Option<(Option<u64>, AshLightSettings)>,
    /// Lights started so far.
    starts: u64,
}

impl AshLightTask {
    /// The light of `parents` for this frame at base tick `tick` (`None`: unknown, a light
    /// every frame). A light is due when [`AshLightSettings::refresh_ticks`] ticks have
    /// passed since the last one started (or the tick went back), or the settings light
    /// differently ([`AshLightSettings::lights_like`]). Off the main thread, the running
    /// light is taken up when the next is due or `refresh_ticks` frames after it started,
    /// waiting for it if need be, so a frame never depends on how fast the task ran; frames
    /// carry the last light taken up (see the module docs). Without the async pool or with
    /// `off_thread` false, a due light is computed now.
    pub(super) fn light(
        &mut self,
        parents: &[ParentSphere],
        settings: &AshLightSettings,
        tick: Option<u64>,
    ) -> Vec<ParentLight> {
        let every = settings.refresh_ticks.max(1);
        let due = self.started.as_ref().is_none_or(|(t0, was)| {
            let ticks = tick.zip(*t0).and_then(|(t, t0)| t.checked_sub(t0));
            !was.lights_like(settings) || ticks.is_none_or(|d| d >= u64::from(every))
        });
        let pool = if settings.off_thread { AsyncComputeTaskPool::try_get() } else { None };
        if let Some(running) = &mut self.running {
            running.frames += 1;
        }
        if self.running.as_ref().is_some_and(|r| due || r.frames >= every || pool.is_none()) {
            self.last = block_on(self.running.take().expect("checked above").task);
        }
        if !due {
            return self.last.carry(parents);
        }
        self.started = Some((tick, settings.clone()));
        self.starts += 1;
        let Some(pool) = pool else {
            // Kept as the last light, so switching back on carries this light, not an old one.
            self.last = LitParents::compute(parents, settings);
            return self.last.light.clone();
        };
        let light = self.last.carry(parents);
        let (parents, settings) = (parents.to_vec(), settings.clone());
        // Its grids and lookups run their bands on the same pool: a task the main thread may
        // wait for must not fill the compute pool that runs the app's systems.
        let task = pool
            .spawn(async move { on_pool(Pool::AsyncCompute, || LitParents::compute(&parents, &settings)) });
        self.running = Some(Running { task, frames: 0 });
        light
    }

    /// Lights started so far.
    #[cfg(test)]
    fn starts(&self) -> u64 {
        self.starts
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
        let lit_first = task.light(&first, &settings, None);
        assert!(
            lit_first.iter().all(|l| *l == ParentLight::CLEAR),
            "nothing computed before the first frame"
        );
        let lit_second = task.light(&second, &settings, None);
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
        let lit_third = task.light(&second, &settings, None);
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
        assert_eq!(task.light(&parents, &settings, None), light_parents(&parents, &settings));
        // Switched back on, the first frame carries the light of the last one computed.
        AsyncComputeTaskPool::get_or_init(TaskPool::default);
        let on = AshLightSettings { off_thread: true, ..settings.clone() };
        assert_eq!(task.light(&parents, &on, None), light_parents(&parents, &settings));
    }

    /// The same row of parents at tick `t`: they drift with the ticks, so each tick's light
    /// differs from the others'.
    fn at_tick(t: u64) -> Vec<ParentSphere> {
        frame(&(0..30).collect::<Vec<_>>(), 40.0 * t as f32)
    }

    #[test]
    fn a_light_starts_every_refresh_ticks_and_is_taken_up_that_many_frames_later() {
        AsyncComputeTaskPool::get_or_init(TaskPool::default);
        let settings = AshLightSettings { sun: Vec3::new(-1.0, 0.2, 0.0), refresh_ticks: 3, ..default() };
        let own = |t: u64| light_parents(&at_tick(t), &settings);
        assert_ne!(own(0), own(3), "the ticks' lights differ");
        let mut task = AshLightTask::default();
        // One tick per frame: lights start at ticks 0, 3, 6, 9; each is taken up at the next
        // start, and the frames in between carry it.
        for t in 0..11u64 {
            let light = task.light(&at_tick(t), &settings, Some(t));
            let expected = match t {
                0..=2 => vec![ParentLight::CLEAR; 30],
                _ => own(t / 3 * 3 - 3),
            };
            assert_eq!(light, expected, "tick {t}");
        }
        assert_eq!(task.starts(), 4);
        // Two ticks per frame: a start at every other frame (ticks 12, 16, 20), each taken up
        // two frames later by the next start.
        for (frame, t) in (12..=20u64).step_by(2).enumerate() {
            task.light(&at_tick(t), &settings, Some(t));
            assert_eq!(task.starts(), 5 + frame as u64 / 2, "tick {t}");
        }
    }

    #[test]
    fn a_paused_simulation_takes_up_its_light_after_refresh_frames_and_a_sun_turn_starts_one() {
        AsyncComputeTaskPool::get_or_init(TaskPool::default);
        let sun = Vec3::new(-1.0, 0.2, 0.0);
        let settings = AshLightSettings { sun, refresh_ticks: 3, ..default() };
        let parents = at_tick(0);
        let mut task = AshLightTask::default();
        for frame in 0..6 {
            let light = task.light(&parents, &settings, Some(7));
            let expected =
                if frame < 3 { vec![ParentLight::CLEAR; 30] } else { light_parents(&parents, &settings) };
            assert_eq!(light, expected, "frame {frame}");
        }
        assert_eq!(task.starts(), 1, "nothing changed: no new light");
        // A turn under SUN_TURN_DEG keeps the light; one over it starts a new one at once,
        // taken up three frames later.
        let turn = |deg: f32| AshLightSettings {
            sun: Quat::from_rotation_z(deg.to_radians()) * sun,
            ..settings.clone()
        };
        task.light(&parents, &turn(0.4), Some(7));
        assert_eq!(task.starts(), 1);
        let turned = turn(2.0);
        for frame in 0..4 {
            let light = task.light(&parents, &turned, Some(7));
            let expected = light_parents(&parents, if frame < 3 { &settings } else { &turned });
            assert_eq!(light, expected, "frame {frame} after the turn");
        }
        assert_eq!(task.starts(), 2);
        assert_ne!(light_parents(&parents, &settings), light_parents(&parents, &turned));
    }

    #[test]
    fn on_the_main_thread_a_light_is_computed_only_when_due() {
        let settings = AshLightSettings {
            sun: Vec3::new(-1.0, 0.2, 0.0),
            refresh_ticks: 2,
            off_thread: false,
            ..default()
        };
        let mut task = AshLightTask::default();
        for t in 0..6u64 {
            let light = task.light(&at_tick(t), &settings, Some(t));
            assert_eq!(light, light_parents(&at_tick(t / 2 * 2), &settings), "tick {t}");
        }
        assert_eq!(task.starts(), 3);
        // The tick went back (a new scene): a light at once.
        assert_eq!(task.light(&at_tick(1), &settings, Some(1)), light_parents(&at_tick(1), &settings));
    }
}
