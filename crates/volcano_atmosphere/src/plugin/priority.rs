//! Background priority for the off-thread weather step (issue 15, "no hitch").
//!
//! The weather step is 15–25 ms of CPU in one burst once per simulated second. On Bevy's
//! `AsyncComputeTaskPool` it competes on equal terms with the main thread's base tick and its
//! compute-pool loops; on two cores it took one of them from the tick (the pyroclastic
//! particle step 3.6 → 8.4 ms on the ticks right after a weather start). A paced game leaves
//! most of each 20 ms frame idle, so the step can run in those gaps if the OS prefers the
//! tick's threads. With [`WeatherPipelineSettings::background_nice`] above 0 (default 10) the
//! step and all its bands run on a pool of their own whose threads are `nice`r than the rest
//! of the game by that much.
//!
//! **Why a pool of its own and not a lower priority for the step's duration.** Lowering a
//! thread's priority is unprivileged on Linux, raising it back is not: `setpriority(2)` to a
//! lower nice value needs `CAP_SYS_NICE` or an `RLIMIT_NICE` that allows it, and the default
//! `RLIMIT_NICE` is 0 (no raising at all). A Bevy pool thread lowered for the step could
//! therefore not be given back as it was in a game run by an ordinary user. `SCHED_IDLE` is no
//! way out: leaving it for `SCHED_OTHER` is checked against the same limit (checked on this
//! machine as `nobody` with `RLIMIT_NICE` 0: nice 0 → 10 → 0 fails with `EACCES`, `SCHED_IDLE`
//! → `SCHED_OTHER` with `EPERM`; as root both pass). So the threads are lowered once, when they
//! are created, and are never given back to anyone: [`background_pool`] builds a Bevy
//! `TaskPool` per nice level (one in practice), with as many threads as the async compute pool,
//! named `Weather+N (i)`, each raising its own nice by N (relative to the nice it inherited,
//! capped at 19, so it never needs a privilege and never outranks the game). The step's bands
//! run there too (`volcano_core::parallel::Pool::Own`), never on Bevy's threads, and the pool's
//! tasks never wait for a system (the deadlock rule of `volcano_core::parallel`). Bevy's own
//! threads are never touched.
//!
//! On Linux `nice` is per thread (`setpriority(PRIO_PROCESS, gettid(), ..)`), and with
//! autogroups (a desktop's default) it weighs the game's threads against each other only, not
//! against other programs. Elsewhere this is a no-op: the step stays on Bevy's async compute
//! pool as before. The state never depends on the thread that computes it (fixed bands, results
//! in band order), so the setting changes no bit of the simulation.
//!
//! [`WeatherPipelineSettings::background_nice`]: super::pipeline::WeatherPipelineSettings::background_nice

use bevy::tasks::TaskPool;

/// The highest nice value on Linux (the lowest priority); larger levels are capped to it.
pub const MAX_NICE: u8 = 19;

/// The nice value of the calling thread (Linux; `None` elsewhere or if it cannot be read).
/// Diagnostics: [`WeatherPipelineStatus::last_step_nice`] is this, read by the thread that ran
/// the step.
///
/// [`WeatherPipelineStatus::last_step_nice`]: super::pipeline::WeatherPipelineStatus::last_step_nice
pub fn current_thread_nice() -> Option<i32> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: `__errno_location` returns this thread's errno slot, valid for the thread's
        // life; clearing it lets a legitimate nice of -1 be told from an error below.
        unsafe { *libc::__errno_location() = 0 };
        // SAFETY: `gettid` has no preconditions; `getpriority` only reads the scheduling
        // attributes of this thread (a thread id is a valid `PRIO_PROCESS` target on Linux).
        let nice = unsafe { libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t) };
        if nice == -1 && std::io::Error::last_os_error().raw_os_error().is_some_and(|e| e != 0) {
            return None;
        }
        Some(nice)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

/// Raises the calling thread's nice by `level` (capped at [`MAX_NICE`]): always allowed, and
/// never undone (the thread is the weather pool's own).
#[cfg(target_os = "linux")]
fn lower_this_thread(level: u8) {
    let Some(now) = current_thread_nice() else {
        bevy::log::warn!("weather pool: cannot read this thread's nice; left as it is");
        return;
    };
    let target = (now + i32::from(level)).min(i32::from(MAX_NICE));
    if target <= now {
        return;
    }
    // SAFETY: `gettid` has no preconditions; `setpriority` on this thread's own id only changes
    // its nice value, and no memory is passed.
    let r = unsafe { libc::setpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t, target) };
    if r != 0 {
        bevy::log::warn!(
            "weather pool: cannot lower this thread to nice {target}: {}",
            std::io::Error::last_os_error()
        );
    }
}

/// The weather's pool for nice `level` (1..=[`MAX_NICE`]), built at its first use with
/// `threads` threads (at least one) and kept for the rest of the process; `None` for level 0
/// and on systems other than Linux (the step then stays on Bevy's async compute pool).
pub(crate) fn background_pool(level: u8, threads: usize) -> Option<&'static TaskPool> {
    #[cfg(target_os = "linux")]
    {
        use std::sync::{Mutex, PoisonError};
        static POOLS: Mutex<Vec<(u8, &'static TaskPool)>> = Mutex::new(Vec::new());
        let level = level.min(MAX_NICE);
        if level == 0 {
            return None;
        }
        let mut pools = POOLS.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some((_, pool)) = pools.iter().find(|(l, _)| *l == level) {
            return Some(pool);
        }
        let pool: &'static TaskPool = Box::leak(Box::new(
            bevy::tasks::TaskPoolBuilder::new()
                .num_threads(threads.max(1))
                .thread_name(format!("Weather+{level}"))
                .on_thread_spawn(move || lower_this_thread(level))
                .build(),
        ));
        pools.push((level, pool));
        Some(pool)
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = (level, threads);
        None
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;
    use bevy::tasks::block_on;
    use volcano_core::parallel::{self, Bands};

    #[test]
    fn every_band_of_a_step_on_the_pool_runs_on_its_lowered_threads() {
        let base = current_thread_nice().unwrap();
        assert!(base < i32::from(MAX_NICE), "run the test below nice 19 (is {base})");
        let pool = background_pool(7, 2).unwrap();
        assert!(std::ptr::eq(pool, background_pool(7, 5).unwrap()), "one pool per level");
        assert!(background_pool(0, 2).is_none());
        // As `run_step` does: a task on the pool runs bands on `Pool::Own(pool)`.
        let seen = block_on(pool.spawn(async move {
            parallel::on_pool(parallel::Pool::Own(pool), || {
                Bands::of(1).map_ranges(64, |_| {
                    // Long enough for both threads to take bands.
                    std::thread::sleep(std::time::Duration::from_micros(200));
                    (std::thread::current().name().map(String::from), current_thread_nice())
                })
            })
        }));
        let want = (base + 7).min(i32::from(MAX_NICE));
        for (name, nice) in &seen {
            assert!(name.as_deref().is_some_and(|n| n.starts_with("Weather+7 (")), "band on {name:?}");
            assert_eq!(*nice, Some(want), "band on {name:?}");
        }
        // The calling thread is left as it was.
        assert_eq!(current_thread_nice(), Some(base));
    }
}
