//! `volcano bench`: a scene's whole simulation headless, one base tick per app update, timed
//! on the main thread (whole-scene numbers against the frame budget). Writes `DIR/bench.json`:
//! the main thread's time per base tick (p50, p99, max), the mean on ticks where a weather step
//! started or was written back beside the mean on the others, each domain's mean and its p50, p99 and max per tick, and
//! the same split by domain on weather ticks and on the others (where a weather tick's extra
//! time goes; `rest` is what ran outside the domains' sets).
//!
//! The domains are timed by stamps between the chained `SimSystems` sets (a system ordered
//! after one set and before the next), so a domain's time is everything its set ran on the
//! main thread, including the parallel loops it waited for. What the renderer does each frame
//! (instances, meshes, cloud volumes) is not in these numbers.
//!
//! `--quality` runs the scene at a `VolcanoQuality` level, `--seconds` sets the length in
//! simulated seconds, `--report-every S` adds the soak report (module `soak`), and
//! `--realtime` paces the ticks at 50 Hz of wall time, as a game runs them (unpaced, a 2 ms
//! tick leaves a weather step 0.1 s of wall time instead of a second).
//!
//! `DIR/ticks.csv` has every timed tick: its number, main-thread ms, whether a weather step
//! started or was written back on it, and the same split by domain (to see where a p99 or a
//! max comes from, e.g. by the tick's place in the weather period), written as the ticks come
//! (nothing of it is kept in memory; what is kept per tick is its 8-byte time for the
//! percentiles, ≈ 1.4 MB over a simulated hour, reserved before the first timed tick: see
//! [`TickTimes`]).

use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use serde::Serialize;
use volcano::prelude::*;
use volcano_atmosphere::WeatherPipelineStatus;

mod cpu;
mod soak;

/// The chained sets in order; a stamp sits between each pair.
const SETS: [SimSystems; 8] = SimSystems::ORDER;

/// Instants taken between consecutive sets during the current base tick.
#[derive(Resource, Default)]
struct Stamps {
    at: [Option<Instant>; SETS.len() - 1],
    /// Summed time of each set between the first and last stamp (index = set index).
    total: [Duration; SETS.len()],
    /// The pool threads' clocks, once the pools exist (`None`: not split by domain).
    clocks: Option<cpu::PoolClocks>,
    /// The compute pool's CPU seconds at each stamp of the current tick.
    pool_at: [Option<f64>; SETS.len() - 1],
    /// The compute pool's CPU seconds while each set ran (index = set index).
    pool_total: [f64; SETS.len()],
}

fn stamp<const I: usize>(mut s: ResMut<Stamps>) {
    let now = Instant::now();
    if let Some(prev) = I.checked_sub(1).and_then(|p| s.at[p]) {
        s.total[I] += now - prev;
    }
    s.at[I] = Some(now);
    if let Some(cpu) = s.clocks.as_ref().map(cpu::PoolClocks::compute_s) {
        if let Some(prev) = I.checked_sub(1).and_then(|p| s.pool_at[p]) {
            s.pool_total[I] += cpu - prev;
        }
        s.pool_at[I] = Some(cpu);
    }
}

/// Quantiles and means of the run, in milliseconds.
#[derive(Debug, Serialize)]
pub struct TickStats {
    /// Median main-thread time per base tick.
    pub p50: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
}

/// What `bench.json` holds.
#[derive(Debug, Serialize)]
pub struct BenchReport {
    /// Scene name.
    pub scene: String,
    /// Base ticks timed (after the warm-up).
    pub ticks: u64,
    /// Base ticks run before timing (not in the statistics).
    pub warmup_ticks: u64,
    /// `dev` or `release` (debug assertions on or off).
    pub profile: &'static str,
    /// Main-thread time per base tick.
    pub tick_ms: TickStats,
    /// Mean over ticks on which a weather step was started or written back.
    pub weather_tick_ms_mean: f64,
    /// Mean over the other ticks.
    pub other_tick_ms_mean: f64,
    /// Weather write-backs during the timed ticks that had to wait for the worker. The run is
    /// not paced to real time (ticks follow each other as fast as they run), so the worker has
    /// less wall time than in a game, where a weather step has a whole second.
    pub weather_waits: u64,
    /// Mean main-thread ms of starting a weather step (`WeatherPipelineStatus::last_start_ms`:
    /// copying the ground, sharing the layers, spawning the task) and of writing one back
    /// (`last_apply_ms`, the join included), over the timed weather ticks.
    pub weather_start_ms_mean: f64,
    /// See `weather_start_ms_mean`.
    pub weather_apply_ms_mean: f64,
    /// The slowest timed tick: its number, whether it was a weather tick, and its split by
    /// domain (ms, as in `weather_tick_domains`), to tell what a `max` is made of.
    pub slowest_tick: SlowestTick,
    /// Mean ms per base tick of each domain's set (`coupling` = the sets just before and after
    /// the weather).
    pub domains: std::collections::BTreeMap<&'static str, f64>,
    /// Each domain's main-thread ms per base tick: p50, p99, max.
    pub domain_tick_ms: std::collections::BTreeMap<&'static str, TickStats>,
    /// Each domain's mean ms on the ticks where a weather step started or was written back,
    /// and `rest`: the tick's time outside the domains' sets.
    pub weather_tick_domains: std::collections::BTreeMap<&'static str, f64>,
    /// The same on the other ticks.
    pub other_tick_domains: std::collections::BTreeMap<&'static str, f64>,
    /// Wall time of the whole run (s).
    pub wall_s: f64,
    /// The quality level, if one was set.
    pub quality: Option<String>,
    /// Whether ticks were paced at the tick rate (`--realtime`).
    pub realtime: bool,
    /// The soak report (`--report-every`), one row per interval.
    pub soak: Vec<soak::SoakRow>,
    /// CPU seconds per simulated second over the timed ticks: the whole process, the main
    /// thread and the pools (`null` where the OS's clocks are unknown).
    pub cpu_s_per_sim_s: Option<cpu::CpuBill>,
}

/// The slowest tick of a run (see [`BenchReport::slowest_tick`]).
#[derive(Debug, Default, Serialize)]
pub struct SlowestTick {
    /// Base tick number (`SimTick`).
    pub tick: u64,
    /// Main-thread ms.
    pub ms: f64,
    /// A weather step started or was written back on it.
    pub weather: bool,
    /// Ms per domain's set, and `rest`.
    pub domains: std::collections::BTreeMap<&'static str, f64>,
}

/// How long and how `volcano bench` runs.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Scene name.
    pub scene: String,
    /// Base ticks timed.
    pub ticks: u64,
    /// Base ticks run first, untimed.
    pub warmup: u64,
    /// Quality level, if any.
    pub quality: Option<VolcanoQuality>,
    /// Soak report interval in base ticks (0: none).
    pub report_every_ticks: u64,
    /// Start each timed base tick on the wall clock of a game running at the tick rate (50 Hz:
    /// tick n at n × 20 ms, sleeping in between) instead of back to back; the weather step then
    /// has a second of wall time, as in a game, instead of the ≈ 0.1 s an unpaced run leaves it.
    pub realtime: bool,
}

/// Ms per domain from ms per set (in `SETS` order): plume, pyroclastic, coupling (the sets
/// just before and after the weather), weather, lava.
fn by_domain(sets: &[f64; SETS.len()]) -> [(&'static str, f64); 5] {
    [
        ("plume", sets[1]),
        ("pyroclastic", sets[2]),
        ("coupling", sets[3] + sets[5]),
        ("weather", sets[4]),
        ("lava", sets[6]),
    ]
}

/// Main-thread times of the timed ticks: every one kept for the percentiles (8 B per tick, and
/// 8 B per domain), in a
/// vector reserved for the whole run before the first tick, so that its doublings (1 MiB at
/// tick 131,072 of an hour) do not show as steps in the soak report's heap column; the means
/// of weather ticks and of the others are running sums.
struct TickTimes {
    /// Every tick's ms, in tick order (sorted at the end).
    all: Vec<f64>,
    /// Summed ms and count of the ticks where a weather step started or was written back.
    weather: (f64, usize),
    /// The same on the other ticks.
    other: (f64, usize),
    /// Each domain's ms per tick, in `by_domain` order (sorted at the end).
    domains: [Vec<f64>; 5],
}

impl TickTimes {
    /// Most ticks reserved up front: four simulated hours (5.8 MB). A longer `--ticks` grows
    /// the vector past it as it goes (a huge count must not be one allocation it cannot get).
    const MAX_RESERVED: u64 = 4 * 3_600 * 50;

    fn with_capacity(ticks: u64) -> Self {
        let reserve = ticks.min(Self::MAX_RESERVED) as usize;
        Self {
            all: Vec::with_capacity(reserve),
            weather: (0.0, 0),
            other: (0.0, 0),
            domains: std::array::from_fn(|_| Vec::with_capacity(reserve)),
        }
    }

    fn push(&mut self, ms: f64, weather: bool, domains: &[(&'static str, f64); 5]) {
        for (v, d) in self.domains.iter_mut().zip(domains) {
            v.push(d.1);
        }
        self.all.push(ms);
        let kind = if weather { &mut self.weather } else { &mut self.other };
        kind.0 += ms;
        kind.1 += 1;
    }

    /// Mean ms over a kind's ticks, 0 if none.
    fn mean((sum, n): (f64, usize)) -> f64 {
        if n == 0 { 0.0 } else { sum / n as f64 }
    }
}

pub(crate) fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// Runs the scene for `warmup + ticks` base ticks and writes `dir/bench.json`.
pub fn run(opts: &BenchOptions, dir: &Path) -> ExitCode {
    let (scene, ticks, warmup) = (opts.scene.as_str(), opts.ticks, opts.warmup);
    if ticks == 0 || ticks > 1_000_000 || warmup > 1_000_000 {
        eprintln!(
            "error: --ticks (or --seconds × 50) must be in 1..=1000000 and --warmup-ticks at most 1000000"
        );
        return ExitCode::from(2);
    }
    let plugin = match VolcanoScenePlugin::builtin(scene) {
        Ok(p) => p.headless(),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if let Err(e) = std::fs::create_dir_all(dir) {
        eprintln!("error: cannot create {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let mut app = App::new();
    if let Some(q) = opts.quality {
        // Before the plugins' startup: the scene reads it when it spawns its atmosphere.
        app.insert_resource(q);
    }
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins, plugin))
        .insert_resource(Time::<Fixed>::from_hz(crate::TICK_HZ))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(1.0 / crate::TICK_HZ)))
        .init_resource::<Stamps>()
        .add_systems(
            FixedUpdate,
            (
                stamp::<0>.after(SETS[0]).before(SETS[1]),
                stamp::<1>.after(SETS[1]).before(SETS[2]),
                stamp::<2>.after(SETS[2]).before(SETS[3]),
                stamp::<3>.after(SETS[3]).before(SETS[4]),
                stamp::<4>.after(SETS[4]).before(SETS[5]),
                stamp::<5>.after(SETS[5]).before(SETS[6]),
                stamp::<6>.after(SETS[6]).before(SETS[7]),
            ),
        );
    let started = Instant::now();
    let tick = |app: &App| app.world().resource::<SimTick>().0;
    // Weather steps started, written back, and written back after waiting, over every
    // atmosphere.
    let weather = |app: &mut App| {
        let world = app.world_mut();
        let mut q = world.query::<&WeatherPipelineStatus>();
        q.iter(world).fold((0, 0, 0), |(a, b, c), s| (a + s.started, b + s.applied, c + s.waited))
    };
    // The main-thread cost of the last start and write-back, summed over every atmosphere.
    let pipeline_ms = |app: &mut App| {
        let world = app.world_mut();
        let mut q = world.query::<&WeatherPipelineStatus>();
        q.iter(world).fold((0.0, 0.0), |(a, b), s| (a + s.last_start_ms, b + s.last_apply_ms))
    };
    let (mut start_ms, mut apply_ms) = (Vec::new(), Vec::new());
    // Written as the ticks come, not kept: an hour's rows held in a string would grow the
    // process by ≈ 11 MB, a resident-memory creep in the soak report.
    let mut rows = match std::fs::File::create(dir.join("ticks.csv")) {
        Ok(f) => std::io::BufWriter::new(f),
        Err(e) => return ticks_csv_failed(e),
    };
    if let Err(e) = writeln!(rows, "tick,ms,weather,plume,pyroclastic,coupling,weather_set,lava,rest") {
        return ticks_csv_failed(e);
    }
    // (tick, ms, weather tick, ms per set) of the slowest tick.
    let mut slowest = (0, 0.0, false, [0.0; SETS.len()]);
    // Startup (terrain, pre-spin) and the zero-delta first update are not timed.
    app.update();
    while tick(&app) < warmup {
        app.update();
    }
    {
        let mut stamps = app.world_mut().resource_mut::<Stamps>();
        stamps.total = Default::default();
        // The pools exist once the app has run.
        stamps.clocks = cpu::PoolClocks::find();
        stamps.pool_at = Default::default();
        stamps.pool_total = Default::default();
    }
    let pool_start =
        app.world().resource::<Stamps>().clocks.as_ref().map(|c| (c.compute_s(), c.async_compute_s()));
    let mut times = TickTimes::with_capacity(ticks);
    // Summed set times (ms) on weather ticks and on the others.
    let (mut weather_sets, mut other_sets) = ([0.0; SETS.len()], [0.0; SETS.len()]);
    let first = tick(&app);
    let waits_before = weather(&mut app).2;
    let cpu_start = cpu::Reading::now();
    let mut soak = match opts.report_every_ticks {
        0 => None,
        every => match soak::Soak::create(dir, every, first) {
            Ok(s) => Some(s),
            Err(e) => {
                eprintln!("error: cannot write soak.csv: {e}");
                return ExitCode::FAILURE;
            }
        },
    };
    let mut next_report = first + 3_000;
    let (pace_start, mut paced) = (Instant::now(), 0u32);
    while tick(&app) < first + ticks {
        if opts.realtime {
            // Untimed: the idle part of a 50 Hz frame.
            let due = pace_start + Duration::from_secs_f64(f64::from(paced) / crate::TICK_HZ);
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
            paced += 1;
        }
        let before = (tick(&app), weather(&mut app));
        let sets_before = app.world().resource::<Stamps>().total;
        let t0 = Instant::now();
        app.update();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let after = (tick(&app), weather(&mut app));
        if after.0 == before.0 {
            continue;
        }
        let sets_after = app.world().resource::<Stamps>().total;
        // Ms of each set in this tick.
        let sets: [f64; SETS.len()] =
            std::array::from_fn(|i| (sets_after[i] - sets_before[i]).as_secs_f64() * 1e3);
        // A weather step started or was written back on this tick.
        let weather_tick = after.1 != before.1;
        if after.1.0 != before.1.0 {
            start_ms.push(pipeline_ms(&mut app).0);
        }
        if after.1.1 != before.1.1 {
            apply_ms.push(pipeline_ms(&mut app).1);
        }
        if ms > slowest.1 {
            slowest = (after.0, ms, weather_tick, sets);
        }
        let d = by_domain(&sets);
        let rest = ms - d.iter().map(|x| x.1).sum::<f64>();
        if let Err(e) = writeln!(
            rows,
            "{},{ms:.4},{},{:.4},{:.4},{:.4},{:.4},{:.4},{rest:.4}",
            after.0,
            u8::from(weather_tick),
            d[0].1,
            d[1].1,
            d[2].1,
            d[3].1,
            d[4].1
        ) {
            return ticks_csv_failed(e);
        }
        times.push(ms, weather_tick, &d);
        let sums = if weather_tick { &mut weather_sets } else { &mut other_sets };
        for (sum, x) in sums.iter_mut().zip(&sets) {
            *sum += x;
        }
        if let Some(s) = soak.as_mut()
            && let Err(e) = s.tick(&mut app, after.0, ms, started.elapsed().as_secs_f64())
        {
            eprintln!("error: cannot write soak.csv: {e}");
            return ExitCode::FAILURE;
        }
        if soak.is_none() && after.0 >= next_report {
            eprintln!("  {} / {ticks} ticks", after.0 - first);
            next_report += 3_000;
        }
    }
    let timed = (tick(&app) - first).max(1) as f64;
    let simulated_s = (tick(&app) - first) as f64 / crate::TICK_HZ;
    let mut cpu_bill = cpu_start.zip(cpu::Reading::now()).map(|(a, b)| a.bill_to(b, simulated_s));
    let stamps = app.world().resource::<Stamps>();
    if let (Some(bill), Some((c0, a0)), Some(clocks)) =
        (cpu_bill.as_mut(), pool_start, stamps.clocks.as_ref())
    {
        let per_s = |x: f64| x / simulated_s.max(1e-9);
        let mut split: std::collections::BTreeMap<&'static str, f64> =
            by_domain(&stamps.pool_total).map(|(name, x)| (name, per_s(x))).into_iter().collect();
        let in_sets: f64 = stamps.pool_total.iter().sum();
        *split.entry("weather").or_default() += per_s(clocks.async_compute_s() - a0);
        split.insert("other", per_s((clocks.compute_s() - c0 - in_sets).max(0.0)));
        bill.pools_by_domain = Some(split);
    }
    let weather_waits = weather(&mut app).2 - waits_before;
    let total = app.world().resource::<Stamps>().total;
    let stats = |sorted: &[f64]| TickStats {
        p50: quantile(sorted, 0.5),
        p99: quantile(sorted, 0.99),
        max: sorted.last().copied().unwrap_or(0.0),
    };
    let names = by_domain(&[0.0; SETS.len()]).map(|(name, _)| name);
    let domain_tick_ms = names
        .into_iter()
        .zip(times.domains.iter_mut())
        .map(|(name, v)| {
            v.sort_by(f64::total_cmp);
            (name, stats(v))
        })
        .collect();
    let sorted = &mut times.all;
    sorted.sort_by(f64::total_cmp);
    let mean = |v: &[f64]| if v.is_empty() { 0.0 } else { v.iter().sum::<f64>() / v.len() as f64 };
    // Per domain on one kind of tick: set sums over `n` ticks of `tick_ms` mean.
    let split = |sets: &[f64; SETS.len()], n: usize, tick_ms: f64| {
        let n = n.max(1) as f64;
        let d = by_domain(sets).map(|(name, x)| (name, x / n));
        let rest = tick_ms - d.iter().map(|x| x.1).sum::<f64>();
        d.into_iter().chain([("rest", rest)]).collect::<std::collections::BTreeMap<_, _>>()
    };
    let report = BenchReport {
        scene: scene.to_string(),
        ticks: tick(&app) - first,
        warmup_ticks: first,
        profile: if cfg!(debug_assertions) { "dev" } else { "release" },
        tick_ms: stats(sorted),
        weather_tick_ms_mean: TickTimes::mean(times.weather),
        other_tick_ms_mean: TickTimes::mean(times.other),
        weather_waits,
        weather_start_ms_mean: mean(&start_ms),
        weather_apply_ms_mean: mean(&apply_ms),
        slowest_tick: SlowestTick {
            tick: slowest.0,
            ms: slowest.1,
            weather: slowest.2,
            domains: split(&slowest.3, 1, slowest.1),
        },
        domains: by_domain(&total.map(|t| t.as_secs_f64() * 1e3))
            .map(|(name, x)| (name, x / timed))
            .into_iter()
            .collect(),
        domain_tick_ms,
        weather_tick_domains: split(&weather_sets, times.weather.1, TickTimes::mean(times.weather)),
        other_tick_domains: split(&other_sets, times.other.1, TickTimes::mean(times.other)),
        wall_s: started.elapsed().as_secs_f64(),
        quality: opts.quality.map(|q| format!("{q:?}")),
        realtime: opts.realtime,
        soak: soak.map(|s| s.rows).unwrap_or_default(),
        cpu_s_per_sim_s: cpu_bill,
    };
    if let Err(e) = rows.flush() {
        return ticks_csv_failed(e);
    }
    let json = serde_json::to_string_pretty(&report).unwrap_or_default();
    if let Err(e) = std::fs::write(dir.join("bench.json"), &json) {
        eprintln!("error: cannot write bench.json: {e}");
        return ExitCode::FAILURE;
    }
    println!("{json}");
    ExitCode::SUCCESS
}

/// Reports a failed write of `ticks.csv`.
fn ticks_csv_failed(e: std::io::Error) -> ExitCode {
    eprintln!("error: cannot write ticks.csv: {e}");
    ExitCode::FAILURE
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An hour's ticks fit in what was reserved before the first (no reallocation: the soak
    /// report's heap column does not step), and the means split weather ticks from the others.
    #[test]
    fn tick_times_hold_an_hour_without_growing() {
        let ticks = 3_600 * 50;
        let mut times = TickTimes::with_capacity(ticks);
        let (at, capacity) = (times.all.as_ptr(), times.all.capacity());
        for i in 0..ticks {
            // Every 25th tick is a weather tick of 3 ms, the others take 1 ms.
            let weather = i % 25 == 0;
            let lava =
                [("plume", 0.0), ("pyroclastic", 0.0), ("coupling", 0.0), ("weather", 0.0), ("lava", 0.5)];
            times.push(if weather { 3.0 } else { 1.0 }, weather, &lava);
        }
        assert_eq!(times.all.len(), ticks as usize);
        assert_eq!((times.all.as_ptr(), times.all.capacity()), (at, capacity), "the vector was reallocated");
        assert!(times.domains.iter().all(|d| d.len() == ticks as usize && d.capacity() == capacity));
        assert_eq!((times.weather.1, times.other.1), (7_200, 172_800));
        assert_eq!((TickTimes::mean(times.weather), TickTimes::mean(times.other)), (3.0, 1.0));
        assert_eq!(TickTimes::mean((0.0, 0)), 0.0);
        // An absurd tick count reserves the cap, not what was asked.
        assert_eq!(TickTimes::with_capacity(u64::MAX).all.capacity(), TickTimes::MAX_RESERVED as usize);
    }
}
