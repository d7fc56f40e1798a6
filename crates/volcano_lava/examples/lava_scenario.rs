//! Runs one lava scenario headless and prints its summary as JSON.
//! `cargo run -p volcano_lava --example lava_scenario -- obstacle [seconds] [map_dir]`

use volcano_lava::scenario::{Scenario, ScenarioConfig, ScenarioKind};

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
    let mut scenario = match Scenario::build(&config) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let start = std::time::Instant::now();
    scenario.run_until(config.seconds);
    let summary = scenario.summary();
    eprintln!("wall time {:.2} s", start.elapsed().as_secs_f64());
    println!("{}", serde_json::to_string_pretty(&summary).expect("summary serialises"));
    if let Some(dir) = args.next() {
        match volcano_lava::scenario::maps::write_maps(
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
