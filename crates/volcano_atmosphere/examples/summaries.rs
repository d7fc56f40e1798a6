//! Runs the five shipped scenarios with their own settings and prints each summary as JSON
//! (what `volcano atmosphere --scenario NAME` will write as summary.json).
//! `cargo run --release -p volcano_atmosphere --example summaries [GRID] [NAME]`
use volcano_atmosphere::model::run::run_scenario;
use volcano_atmosphere::model::scenario::BUILTIN;

fn main() {
    let grid: Option<usize> = std::env::args().nth(1).and_then(|s| s.parse().ok());
    let only = std::env::args().nth(2);
    for (name, _) in BUILTIN {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        match run_scenario(name, None, None, grid) {
            Ok(summary) => println!("{}", serde_json::to_string_pretty(&summary).expect("serialisable")),
            Err(e) => eprintln!("{name}: {e}"),
        }
    }
}
