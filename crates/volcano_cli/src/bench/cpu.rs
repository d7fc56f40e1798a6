//! The CPU bill of a bench run, from the operating system's clocks: the whole process (every
//! thread: the main thread's ticks and the task pools' weather steps, ash light, lava bands,
//! particles) and the main thread alone, so the pools' share is their difference. On Linux with
//! glibc (`getrusage`, `CLOCK_THREAD_CPUTIME_ID`); elsewhere unknown.
//!
//! [`PoolClocks`] splits the pools' share by domain: it reads the CPU clock of each of Bevy's
//! pool threads (found by name in `/proc/self/task`), so the bench can charge what the compute
//! pool ran between two of its stamps to the domain whose systems ran between them (a domain's
//! bands and particle chunks run inside its own systems), and what the async compute pool ran
//! to the weather (its step is the only work there in a headless run).

use serde::Serialize;

/// CPU seconds per simulated second over the timed ticks.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CpuBill {
    /// Every thread of the process.
    pub process: f64,
    /// The main thread (the schedule, and the systems that run on it).
    pub main_thread: f64,
    /// The rest: the task pools' threads.
    pub pools: f64,
    /// Threads the machine offers (`std::thread::available_parallelism`).
    pub cores: usize,
    /// The pools' share by domain ([`PoolClocks`]): the compute pool's CPU while each
    /// domain's systems ran, the async compute pool's (the weather steps) added to `weather`,
    /// and `other`: the compute pool's CPU outside the domains' sets.
    pub pools_by_domain: Option<std::collections::BTreeMap<&'static str, f64>>,
}

/// CPU clock readings at one moment: (process, this thread) in seconds.
#[derive(Debug, Clone, Copy)]
pub struct Reading(f64, f64);

impl Reading {
    /// Reads both clocks (call it on the main thread); `None` where they are unknown.
    pub fn now() -> Option<Self> {
        Some(Self(process_cpu_s()?, thread_cpu_s()?))
    }

    /// The bill from `self` to `later` over `simulated_s` seconds of simulation.
    pub fn bill_to(self, later: Self, simulated_s: f64) -> CpuBill {
        let s = simulated_s.max(1e-9);
        let (process, main_thread) = ((later.0 - self.0) / s, (later.1 - self.1) / s);
        CpuBill {
            process,
            main_thread,
            pools: (process - main_thread).max(0.0),
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            pools_by_domain: None,
        }
    }
}

/// The CPU clocks of the task pools' threads.
#[derive(Debug, Clone, Default)]
pub struct PoolClocks {
    /// Threads of Bevy's `ComputeTaskPool`.
    compute: Vec<i32>,
    /// Threads of Bevy's `AsyncComputeTaskPool`.
    async_compute: Vec<i32>,
}

impl PoolClocks {
    /// The pool threads of this process, by the names Bevy gives them ("Compute Task Pool (n)",
    /// "Async Compute Task Pool (n)", cut to 15 bytes by the kernel); `None` where the clocks
    /// are unknown or no pool thread exists yet.
    pub fn find() -> Option<Self> {
        let mut clocks = Self::default();
        for entry in std::fs::read_dir("/proc/self/task").ok()?.flatten() {
            let Ok(tid) = entry.file_name().to_string_lossy().parse::<i32>() else { continue };
            let name = std::fs::read_to_string(entry.path().join("comm")).unwrap_or_default();
            if name.starts_with("Compute Task") {
                clocks.compute.push(tid);
            } else if name.starts_with("Async Compute") {
                clocks.async_compute.push(tid);
            }
        }
        clocks.compute.sort_unstable();
        clocks.async_compute.sort_unstable();
        let known = thread_cpu_s_of(*clocks.compute.first()?).is_some();
        known.then_some(clocks)
    }

    /// CPU seconds the compute pool's threads have run so far.
    pub fn compute_s(&self) -> f64 {
        self.compute.iter().filter_map(|&t| thread_cpu_s_of(t)).sum()
    }

    /// CPU seconds the async compute pool's threads have run so far.
    pub fn async_compute_s(&self) -> f64 {
        self.async_compute.iter().filter_map(|&t| thread_cpu_s_of(t)).sum()
    }
}

/// The CPU clock of thread `tid` of this process: Linux's per-thread CPU-time clock id,
/// `(!tid << 3) | 6` (`CPUCLOCK_SCHED` with the per-thread bit: the kernel's
/// `MAKE_THREAD_CPUCLOCK`, what glibc's `pthread_getcpuclockid` returns).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn thread_cpu_s_of(tid: i32) -> Option<f64> {
    let clock: libc::clockid_t = (!tid << 3) | 6;
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `clock_gettime` writes the `timespec` it is given; an id of a thread that has
    // exited makes it fail (EINVAL), which is `None` here.
    let ok = unsafe { libc::clock_gettime(clock, &mut ts) } == 0;
    ok.then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn thread_cpu_s_of(_tid: i32) -> Option<f64> {
    None
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn process_cpu_s() -> Option<f64> {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::uninit();
    // SAFETY: `getrusage` writes a whole `rusage` through the pointer when it returns 0; the
    // value is read only then.
    let usage = unsafe {
        if libc::getrusage(libc::RUSAGE_SELF, usage.as_mut_ptr()) != 0 {
            return None;
        }
        usage.assume_init()
    };
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(tv(usage.ru_utime) + tv(usage.ru_stime))
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn thread_cpu_s() -> Option<f64> {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `clock_gettime` writes the `timespec` it is given; the clock id is a constant.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
    ok.then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn process_cpu_s() -> Option<f64> {
    None
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn thread_cpu_s() -> Option<f64> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Busy work on a second thread shows in the process's bill and not in this thread's.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn work_on_another_thread_is_the_pools_share() {
        let start = Reading::now().unwrap();
        let spin = |ms: u64| {
            let until = std::time::Instant::now() + std::time::Duration::from_millis(ms);
            let mut x = 0u64;
            while std::time::Instant::now() < until {
                x = std::hint::black_box(x.wrapping_add(1));
            }
        };
        std::thread::spawn(move || spin(300)).join().unwrap();
        spin(100);
        let bill = start.bill_to(Reading::now().unwrap(), 1.0);
        assert!(bill.main_thread > 0.05 && bill.main_thread < 0.25, "{bill:?}");
        assert!(bill.pools > 0.2, "{bill:?}");
        assert!((bill.process - bill.main_thread - bill.pools).abs() < 1e-9);
    }

    /// Work on a thread named as Bevy names a compute-pool thread shows on the compute clocks.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn a_pool_threads_clock_counts_its_work() {
        let (go, wait) = std::sync::mpsc::channel::<()>();
        let (done, finished) = std::sync::mpsc::channel::<()>();
        let (ready, started) = std::sync::mpsc::channel::<()>();
        let worker = std::thread::Builder::new()
            .name("Compute Task Pool (9)".into())
            .spawn(move || {
                // The thread names itself as it starts: found only after this.
                ready.send(()).unwrap();
                wait.recv().unwrap();
                let until = std::time::Instant::now() + std::time::Duration::from_millis(200);
                let mut x = 0u64;
                while std::time::Instant::now() < until {
                    x = std::hint::black_box(x.wrapping_add(1));
                }
                done.send(()).unwrap();
                // Alive until the clocks are read.
                std::thread::sleep(std::time::Duration::from_millis(500));
            })
            .unwrap();
        started.recv().unwrap();
        let clocks = PoolClocks::find().expect("the thread is named");
        let c0 = clocks.compute_s();
        go.send(()).unwrap();
        finished.recv().unwrap();
        let c1 = clocks.compute_s();
        assert!(c1 - c0 > 0.15, "{c0} -> {c1}");
        worker.join().unwrap();
    }
}
