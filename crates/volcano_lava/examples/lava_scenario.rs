//! Runs one lava scenario headless and prints its summary as JSON.
//! `cargo run -p volcano_lava --example lava_scenario -- obstacle [seconds] [map_dir]`
//! With `LAVA_PROGRESS=S` in the environment it prints, every S simulated seconds, the wall
//! time of that slice and the fold counts (how the fold layer's cost grows). `LAVA_ROLLING=1`
//! switches the folds to rolling collisions (thesis §5.5.2.3).

use volcano_lava::scenario::{LavaScenario, ScenarioConfig, ScenarioKind};

fn main() {
    let mut args = std::env::args().skip(1);
    let kind: ScenarioKind = match args.next().unwrap_or_else(|| "obstacle".into()).parse() {
        Ok(k) => k,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let mut config = ScenarioConfig::new(kind);
    if let Some(s) = args.next().and_then(|s| s.parse().ok()) {
        config.seconds = s;
    }
    let mut scenario = match LavaScenario::build(&config) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    scenario.fold_params.rolling = std::env::var("LAVA_ROLLING").is_ok_and(|v| v == "1");
    let start = std::time::Instant::now();
    let every: f64 = std::env::var("LAVA_PROGRESS").ok().and_then(|s| s.parse().ok()).unwrap_or(0.0);
    if every > 0.0 {
        let mut t = 0.0;
        while t < config.seconds {
            t = (t + every).min(config.seconds);
            let slice = std::time::Instant::now();
            scenario.run_until(t);
            eprintln!(
                "t {t:6.1} s  wall {:7.2} s  folds {:5}  particles {:6}  buried {:6}  max/cell {:4}",
                slice.elapsed().as_secs_f64(),
                scenario.folds.fold_count(),
                scenario.folds.particle_count(),
                scenario.folds.buried_count(),
                scenario.max_fold_particles_per_cell()
            );
        }
    }
    scenario.run_until(config.seconds);
    let summary = scenario.summary();
    eprintln!("wall time {:.2} s", start.elapsed().as_secs_f64());
    println!("{}", serde_json::to_string_pretty(&summary).expect("summary serialises"));
    if let Some(dir) = args.next() {
        match volcano_lava::view::write_maps(
            &scenario.field,
            &scenario.surface,
            &scenario.folds,
            dir.as_ref(),
        ) {
            Ok(paths) => eprintln!("wrote {paths:?}"),
            Err(e) => eprintln!("{e}"),
        }
    }
}
