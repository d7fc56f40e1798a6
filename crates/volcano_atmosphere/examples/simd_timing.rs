//! Single-threaded A/B of the multigrid's AVX2 row loops in one process (not a benchmark;
//! see benches/): a scenario at GRID² (default 512), all bands inline, steps alternating in
//! rounds between the AVX2 and the scalar loops (the same bits either way, `tests/simd.rs`),
//! thread CPU time per step; prints the minimum and median of each.
//! `cargo run --release -p volcano_atmosphere --example simd_timing -- [GRID] [ROUNDS]`
use volcano_atmosphere::WeatherScenario;
use volcano_atmosphere::model::multigrid::use_simd;
use volcano_atmosphere::model::step::{Workspace, step};
use volcano_core::parallel;

#[path = "../benches/support/cpu_time.rs"]
mod cpu_time;

/// CPU time (ms) of the calling thread.
fn thread_cpu_ms() -> f64 {
    cpu_time::cpu_ms("/proc/thread-self/stat")
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(512);
    let rounds: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(4);
    for name in ["convection", "mixed"] {
        let sc = WeatherScenario::builtin(name).unwrap();
        let mut state = sc.build(Some(n)).unwrap();
        let mut work = Workspace::new(&state).unwrap();
        let steps = 3;
        let mut times = [Vec::new(), Vec::new()];
        parallel::run_inline(|| {
            for _ in 0..3 {
                step(&mut state, &sc.params, &mut work, 30.0).unwrap();
            }
            for _ in 0..rounds {
                for (which, simd) in [(0, true), (1, false)] {
                    use_simd(simd);
                    let t0 = thread_cpu_ms();
                    for _ in 0..steps {
                        step(&mut state, &sc.params, &mut work, 30.0).unwrap();
                    }
                    times[which].push((thread_cpu_ms() - t0) / steps as f64);
                }
            }
        });
        use_simd(true);
        for (label, t) in ["AVX2", "scalar"].iter().zip(times.iter_mut()) {
            t.sort_by(f64::total_cmp);
            println!(
                "{name} {n}²: {label}: CPU per step min {:.0} ms, median {:.0} ms ({} rounds of {steps} steps)",
                t[0],
                t[t.len() / 2],
                t.len()
            );
        }
    }
}
