//! CPU time read from Linux's `/proc` (shared by the `atmosphere` bench and the `simd_timing`
//! example, which include this file by path; not a bench target of its own).

/// CPU time (ms) used so far according to the `stat` file at `path`: `/proc/self/stat` for
/// the whole process (all threads), `/proc/thread-self/stat` for the calling thread. 100 ticks
/// per second, so only sums over several steps mean much; 0 where the file is missing. On a
/// loaded machine it measures the work, not the waiting.
pub fn cpu_ms(path: &str) -> f64 {
    let stat = std::fs::read_to_string(path).unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = after.split_whitespace().collect();
    // Fields 14 and 15 of the file (utime, stime) are the 12th and 13th after the name.
    let tick = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok());
    tick(11).zip(tick(12)).map(|(u, s)| (u + s) * 10.0).unwrap_or(0.0)
}
