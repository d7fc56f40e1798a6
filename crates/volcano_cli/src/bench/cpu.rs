//! The CPU bill of a bench run, from the operating system's clocks: the whole process (every
//! thread: the main thread's ticks and the task pools' weather steps, ash light, lava bands,
//! particles) and the main thread alone, so the pools' share is their difference. On Linux with
//! glibc (`getrusage`, `CLOCK_THREAD_CPUTIME_ID`); elsewhere unknown.

use serde::Serialize;

/// CPU seconds per simulated second over the timed ticks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CpuBill {
    /// Every thread of the process.
    pub process: f64,
    /// The main thread (the schedule, and the systems that run on it).
    pub main_thread: f64,
    /// The rest: the task pools' threads.
    pub pools: f64,
    /// Threads the machine offers (`std::thread::available_parallelism`).
    pub cores: usize,
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
        }
    }
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
}
