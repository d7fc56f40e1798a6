//! A volume rebuild that runs on Bevy's `AsyncComputeTaskPool`, or in the frame when asked to
//! or when the app has no pool: what the cloud and ash-fall rebuilds share
//! (`clouds::rebuild`, `ash_fall::rebuild`).

use bevy::tasks::futures::check_ready;
use bevy::tasks::{AsyncComputeTaskPool, Task};

/// A build in flight, or finished and not yet taken.
pub(crate) enum BuildJob<T> {
    Running(Task<T>),
    Done(Box<T>),
}

impl<T: Send + 'static> BuildJob<T> {
    /// Starts `build` on the pool when `off_thread` and the pool exists, else runs it now; the
    /// flag says whether it ran on the main thread.
    pub(crate) fn start(off_thread: bool, build: impl FnOnce() -> T + Send + 'static) -> (Self, bool) {
        match AsyncComputeTaskPool::try_get().filter(|_| off_thread) {
            Some(pool) => (Self::Running(pool.spawn(async move { build() })), false),
            None => (Self::Done(Box::new(build())), true),
        }
    }
}

/// Whether `job` runs on a worker.
pub(crate) fn is_running<T>(job: &Option<BuildJob<T>>) -> bool {
    matches!(job, Some(BuildJob::Running(_)))
}

/// Takes the result out of `slot` once its job has finished (a running one stays in place).
pub(crate) fn take_finished<T>(slot: &mut Option<BuildJob<T>>) -> Option<T> {
    match slot.take()? {
        BuildJob::Done(built) => Some(*built),
        BuildJob::Running(mut task) => {
            let built = check_ready(&mut task);
            if built.is_none() {
                *slot = Some(BuildJob::Running(task));
            }
            built
        }
    }
}
