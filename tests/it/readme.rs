//! The README's game is `examples/hello_volcano.rs`, byte for byte, and it runs: its `setup`
//! system on `MinimalPlugins` + `VolcanoSimPlugins` builds the world it promises (a terrain, a
//! volcano whose vent sits on it) and the column rises. `cargo test` also builds the example
//! itself with `DefaultPlugins`; only opening its window needs a display.

use std::path::Path;
use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::prelude::*;

#[allow(dead_code, reason = "its `main` opens a window; the test runs `setup` headless")]
#[path = "../../examples/hello_volcano.rs"]
mod hello_volcano;

/// The first ```` ```rust ```` block of `markdown` (its lines between the fences).
fn first_rust_block(markdown: &str) -> Option<String> {
    let mut lines = markdown.lines();
    lines.by_ref().find(|l| l.trim_end() == "```rust")?;
    let mut block = String::new();
    for line in lines {
        if line.trim_end() == "```" {
            return Some(block);
        }
        block.push_str(line);
        block.push('\n');
    }
    None
}

#[test]
fn the_readme_game_is_the_hello_volcano_example() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let example = std::fs::read_to_string(root.join("examples/hello_volcano.rs")).unwrap();
    let block = first_rust_block(&readme).expect("README.md has a ```rust block");
    assert!(
        block == example,
        "README.md's first ```rust block differs from examples/hello_volcano.rs: copy the file into it"
    );
}

#[test]
fn first_rust_block_reads_between_the_fences() {
    let md = "text\n```sh\nls\n```\n```rust\nfn a() {}\n\nfn b() {}\n```\n```rust\nfn c() {}\n```\n";
    assert_eq!(first_rust_block(md).as_deref(), Some("fn a() {}\n\nfn b() {}\n"));
    assert_eq!(first_rust_block("```rust\nfn open() {}\n"), None, "an unclosed block");
}

#[test]
fn the_readme_game_runs_headless() {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(100)))
        .add_systems(Startup, hello_volcano::setup);
    for _ in 0..30 {
        app.update();
    }
    let world = app.world_mut();
    let terrain = world.query::<&Terrain>().single(world).expect("one terrain").clone();
    let vent = world.query::<&VentPosition>().single(world).expect("one volcano with a vent").0;
    assert!((vent.y - terrain.height_at(vent.x, vent.z)).abs() < 1e-3, "vent at {vent}");
    assert!(vent.y > terrain.height_range().0 + 500.0, "the vent is on the summit, not the plain: {vent}");
    // Slice positions are in the plume frame: z up above the vent.
    let slices: Vec<f64> = world.query::<&PlumeSlice>().iter(world).map(|s| s.state.position.z).collect();
    assert!(slices.len() > 5, "{} slices after 3 s of eruption", slices.len());
    let top = slices.iter().cloned().fold(0.0, f64::max);
    assert!(top > 100.0, "the column rises: its highest slice is {top:.0} m above the vent");
}
