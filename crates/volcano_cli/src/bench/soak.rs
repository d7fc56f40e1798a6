//! The soak report of `volcano bench --report-every S`: every S simulated seconds, the entity
//! count, the process' resident memory and live heap, the main-thread tick cost over the interval (p50, p99,
//! max), the CPU of the process and of the main thread per simulated second, and what the
//! plume holds and its caps removed, so a long run shows whether entity
//! count, memory and tick cost stay bounded. Rows go to `DIR/soak.csv` as they come (a run
//! stopped early keeps what it measured) and into `bench.json`.

use std::io::Write;
use std::path::Path;

use bevy::prelude::*;
use serde::Serialize;
use volcano::plume::{PlumeCapReport, PlumeSlice, PyroParticle, Umbrella};

/// One row of the soak report.
#[derive(Debug, Clone, Serialize)]
pub struct SoakRow {
    /// Simulated time at the end of the interval (s).
    pub sim_s: f64,
    /// Wall time since the start of the run (s).
    pub wall_s: f64,
    /// Entities alive in the world.
    pub entities: u32,
    /// Resident set size of the process (MiB), from `/proc/self/status` (`VmRSS`); 0 where
    /// there is no `/proc`.
    pub rss_mib: f64,
    /// Heap in use by the program (MiB), [`heap_mib`]: beside `rss_mib` it separates live data
    /// that grows from memory the allocator keeps after it was freed.
    pub heap_mib: f64,
    /// Main-thread ms per base tick over the interval.
    pub tick_p50_ms: f64,
    /// 99th percentile over the interval.
    pub tick_p99_ms: f64,
    /// Largest over the interval.
    pub tick_max_ms: f64,
    /// Live plume slices (column and secondary columns).
    pub slices: usize,
    /// Umbrella spheres.
    pub umbrella: usize,
    /// Pyroclastic particles.
    pub particles: usize,
    /// Secondary columns formed so far.
    pub secondary_columns: u64,
    /// Slices retired by the live-slice cap so far.
    pub capped_slices: u64,
    /// Particles settled by the particle cap so far.
    pub capped_particles: u64,
    /// Clusters lifted off without a column by the secondary-column cap so far.
    pub retired_secondary: u64,
    /// CPU seconds per simulated second over the interval, every thread of the process
    /// (0 where the OS's clock is unknown).
    pub cpu_s_per_sim_s: f64,
    /// Of it, the main thread's.
    pub main_cpu_s_per_sim_s: f64,
    /// Farthest a volcano's own lava has run from its vent (m; `LavaVentStatus::runout_m`).
    pub vent_lava_runout_m: f64,
    /// Tiles its runouts store (the memory of vent lava follows them, not the terrain).
    pub vent_lava_tiles: usize,
    /// Simulated seconds the vent lava's clock is behind the scaled clock (its substep budget).
    pub vent_lava_behind_s: f64,
}

const HEADER: &str = "sim_s,wall_s,entities,rss_mib,heap_mib,tick_p50_ms,tick_p99_ms,tick_max_ms,slices,umbrella,\
                      particles,secondary_columns,capped_slices,capped_particles,retired_secondary,\
                      cpu_s_per_sim_s,main_cpu_s_per_sim_s,vent_lava_runout_m,vent_lava_tiles,vent_lava_behind_s";

/// Resident memory of this process (MiB), 0 if unknown.
pub fn rss_mib() -> f64 {
    let Ok(status) = std::fs::read_to_string("/proc/self/status") else { return 0.0 };
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1024.0)
}

/// Heap in use by the program (MiB): glibc's `mallinfo2`, the bytes in allocated chunks
/// (`uordblks`) plus the blocks it mapped on its own (`hblkhd`, large allocations), over all
/// arenas. It counts what was allocated, touched or not: a buffer that grows by doubling shows
/// as a step in the heap at each doubling and a ramp in resident memory in between, as its
/// pages are written (an hour's `ticks.csv` held in a `String` would: 4 and 8 MiB steps at
/// simulated minutes 25 and 50, resident memory +0.2 MiB a minute). Resident memory growing
/// under a flat heap is a reserved buffer being filled (the bench's own tick times, 8 B per
/// tick: ≈ 0.023 MiB per simulated minute) or memory the allocator keeps after a free.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub fn heap_mib() -> f64 {
    // SAFETY: `mallinfo2` takes no argument and returns a copy of the allocator's counters.
    let m = unsafe { libc::mallinfo2() };
    (m.uordblks + m.hblkhd) as f64 / (1024.0 * 1024.0)
}

/// Heap in use by the program (MiB): 0 without glibc.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub fn heap_mib() -> f64 {
    0.0
}

/// Collects tick times and writes a row every `every_ticks` base ticks.
pub struct Soak {
    every_ticks: u64,
    next: u64,
    times: Vec<f64>,
    /// CPU clocks at the start of the interval.
    cpu: Option<super::cpu::Reading>,
    file: std::fs::File,
    /// Rows written so far.
    pub rows: Vec<SoakRow>,
}

impl Soak {
    /// Starts `dir/soak.csv`; the first row is due `every_ticks` after tick `first`.
    pub fn create(dir: &Path, every_ticks: u64, first: u64) -> std::io::Result<Self> {
        let mut file = std::fs::File::create(dir.join("soak.csv"))?;
        writeln!(file, "{HEADER}")?;
        let cpu = super::cpu::Reading::now();
        Ok(Self { every_ticks, next: first + every_ticks, times: Vec::new(), cpu, file, rows: Vec::new() })
    }

    /// Records one base tick's main-thread time; writes a row when an interval is complete.
    pub fn tick(&mut self, app: &mut App, tick: u64, ms: f64, wall_s: f64) -> std::io::Result<()> {
        self.times.push(ms);
        if tick < self.next {
            return Ok(());
        }
        self.next += self.every_ticks;
        let mut sorted = std::mem::take(&mut self.times);
        sorted.sort_by(f64::total_cmp);
        let mut row = row(app, tick, &sorted, wall_s);
        let now = super::cpu::Reading::now();
        if let Some(bill) =
            self.cpu.zip(now).map(|(a, b)| a.bill_to(b, self.every_ticks as f64 / crate::TICK_HZ))
        {
            (row.cpu_s_per_sim_s, row.main_cpu_s_per_sim_s) = (bill.process, bill.main_thread);
        }
        self.cpu = now;
        eprintln!(
            "  {:>6.0} s: {} entities, {:.0} MiB resident, {:.0} MiB heap, tick p50 {:.2} / p99 {:.2} / max {:.2} ms, {} slices, {} particles, {:.3} CPU s/s",
            row.sim_s,
            row.entities,
            row.rss_mib,
            row.heap_mib,
            row.tick_p50_ms,
            row.tick_p99_ms,
            row.tick_max_ms,
            row.slices,
            row.particles,
            row.cpu_s_per_sim_s
        );
        let r = &row;
        writeln!(
            self.file,
            "{},{:.1},{},{:.1},{:.1},{:.3},{:.3},{:.3},{},{},{},{},{},{},{},{:.4},{:.4},{:.0},{},{:.0}",
            r.sim_s,
            r.wall_s,
            r.entities,
            r.rss_mib,
            r.heap_mib,
            r.tick_p50_ms,
            r.tick_p99_ms,
            r.tick_max_ms,
            r.slices,
            r.umbrella,
            r.particles,
            r.secondary_columns,
            r.capped_slices,
            r.capped_particles,
            r.retired_secondary,
            r.cpu_s_per_sim_s,
            r.main_cpu_s_per_sim_s,
            r.vent_lava_runout_m,
            r.vent_lava_tiles,
            r.vent_lava_behind_s
        )?;
        self.file.flush()?;
        self.rows.push(row);
        Ok(())
    }
}

fn row(app: &mut App, tick: u64, sorted: &[f64], wall_s: f64) -> SoakRow {
    let world = app.world_mut();
    let slices = world.query::<&PlumeSlice>().iter(world).count();
    let umbrella = world.query::<&Umbrella>().iter(world).count();
    let particles = world.query::<&PyroParticle>().iter(world).count();
    let caps = world.get_resource::<PlumeCapReport>().copied().unwrap_or_default();
    let flows = volcano::plume::ground::all_budgets(world);
    let vent_lava_runout_m =
        world.query::<&volcano::lava::LavaVentStatus>().iter(world).map(|s| s.runout_m).fold(0.0, f64::max);
    let vent_lava_tiles =
        world.query::<&volcano::lava::TerrainLava>().iter(world).map(|l| l.runout.tiles().len()).sum();
    let vent_lava_behind_s =
        world.query::<&volcano::lava::TerrainLava>().iter(world).map(|l| l.behind_s).fold(0.0, f64::max);
    SoakRow {
        sim_s: tick as f64 / crate::TICK_HZ,
        wall_s,
        entities: world.entities().count_spawned(),
        rss_mib: rss_mib(),
        heap_mib: heap_mib(),
        tick_p50_ms: super::quantile(sorted, 0.5),
        tick_p99_ms: super::quantile(sorted, 0.99),
        tick_max_ms: sorted.last().copied().unwrap_or(0.0),
        slices,
        umbrella,
        particles,
        secondary_columns: flows.secondary_columns,
        capped_slices: caps.slices_retired,
        capped_particles: caps.particles_settled,
        retired_secondary: caps.secondary_retired,
        cpu_s_per_sim_s: 0.0,
        main_cpu_s_per_sim_s: 0.0,
        vent_lava_runout_m,
        vent_lava_tiles,
        vent_lava_behind_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The live heap follows an allocation: 64 MiB allocated and touched show in it, and go
    /// when freed (a `heap_mib` that read nothing, or only grew, fails).
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[test]
    fn heap_follows_a_64_mib_allocation() {
        let before = heap_mib();
        let block = vec![1u8; 64 << 20];
        let during = heap_mib();
        assert!(std::hint::black_box(&block)[12345] == 1);
        drop(block);
        let after = heap_mib();
        assert!(during - before > 60.0, "heap {before:.1} → {during:.1} MiB with 64 MiB allocated");
        assert!(during - after > 60.0, "heap {during:.1} → {after:.1} MiB after the free");
    }
}
