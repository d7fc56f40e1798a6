//! The whole volcano gives the same bits on 1, 2 and 4 worker threads: a collapsing eruption
//! (plume, umbrella, pyroclastic flows and their deposit), the weather and its coupling to the
//! plume, and a lava field of eight row bands. Bevy's task pools are made once per process, so
//! each thread count runs in a child process of this test binary (the ignored test below),
//! which prints one fingerprint per domain; the parent compares them.

use std::hash::{Hash, Hasher};
use std::time::Duration;

use bevy::prelude::*;
use bevy::tasks::{AsyncComputeTaskPool, ComputeTaskPool, TaskPoolBuilder};
use volcano::atmosphere::AirLayer;
use volcano::lava::LavaState;
use volcano::plume::{DepositMap, PlumeAshBudget, PlumeSlice, PyroParticle, PyroclasticBudget, Umbrella};
use volcano::prelude::*;

use crate::worlds;

const THREADS: &str = "VOLCANO_TEST_THREADS";

/// FNV-1a over the `Debug` text of each item (in a stable order): `Debug` prints every `f64`
/// so that it parses back to the same bits.
fn fingerprint<T: std::fmt::Debug>(items: impl IntoIterator<Item = T>) -> (usize, u64) {
    let mut h = std::hash::DefaultHasher::new();
    let mut n = 0;
    for item in items {
        format!("{item:?}").hash(&mut h);
        n += 1;
    }
    (n, h.finish())
}

fn simulate() -> Vec<(&'static str, (usize, u64))> {
    let mut app = worlds::sim_app(Duration::from_millis(100));
    let terrain = worlds::collapsing_cone();
    let world = app.world_mut();
    let mut commands = world.commands();
    worlds::air_over(&mut commands, &terrain, 32);
    // Eight row bands of lava (256 rows).
    let source = Vec2::new(1_800.0, 300.0);
    let placement = volcano::lava::Placement {
        nx: 96,
        ny: 256,
        ..volcano::lava::Placement::downslope_of(&terrain, source, 96, 1.0).unwrap()
    };
    worlds::lava(&mut commands, &terrain, placement, source, 0.5);
    commands.spawn(terrain);
    commands.spawn((Volcano::new(100.0, 5).unwrap(), worlds::collapsing_eruption(), Transform::default()));
    world.flush();
    while app.world().resource::<SimTick>().0 < 50 * 14 {
        app.update();
    }
    volcano::atmosphere::join_weather(app.world_mut());
    let world = app.world_mut();
    let mut particles: Vec<PyroParticle> = world.query::<&PyroParticle>().iter(world).cloned().collect();
    particles.sort_by_key(|p| p.id);
    assert!(!particles.is_empty(), "the collapse made particles");
    let mut slices: Vec<PlumeSlice> = world.query::<&PlumeSlice>().iter(world).cloned().collect();
    slices.sort_by_key(|s| s.index);
    let mut umbrella: Vec<Umbrella> = world.query::<&Umbrella>().iter(world).cloned().collect();
    umbrella.sort_by_key(|u| u.id);
    let mut layers: Vec<(usize, String)> =
        world.query::<&AirLayer>().iter(world).map(|l| (l.index, format!("{:?}", *l.fields))).collect();
    layers.sort();
    let lava: Vec<String> = world
        .query::<&LavaState>()
        .iter(world)
        .map(|s| format!("{:?} {:?} {:?}", s.flow, s.surface.crust, s.folds.particles))
        .collect();
    let deposits: Vec<String> =
        world.query::<&DepositMap>().iter(world).map(|d| format!("{:?}", d.mass)).collect();
    let books: Vec<String> = world
        .query::<(&PlumeAshBudget, &PyroclasticBudget)>()
        .iter(world)
        .map(|b| format!("{b:?}"))
        .collect();
    let coupling: Vec<CouplingBudget> = world.query::<&CouplingBudget>().iter(world).cloned().collect();
    vec![
        ("pyroclastic", fingerprint(particles.iter().map(|p| (p.id, p.particle)))),
        ("deposit", fingerprint(deposits)),
        ("plume", fingerprint(slices.iter().map(|s| (s.index, &s.state)))),
        ("umbrella", fingerprint(umbrella.iter().map(|u| (u.id, u.sphere, u.ash)))),
        ("books", fingerprint(books)),
        ("atmosphere", fingerprint(layers)),
        ("coupling", fingerprint(coupling)),
        ("lava", fingerprint(lava)),
    ]
}

/// The child: sets up the pools with the thread count it was given and prints the fingerprints.
#[test]
#[ignore = "run by threads_do_not_change_the_results in a child process"]
fn child_prints_fingerprints() {
    let n: usize = std::env::var(THREADS).expect("set by the parent test").parse().unwrap();
    ComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(n).build());
    AsyncComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(n).build());
    for (domain, (count, hash)) in simulate() {
        println!("FINGERPRINT {domain} {count} {hash:016x}");
    }
}

#[test]
fn threads_do_not_change_the_results() {
    let exe = std::env::current_exe().unwrap();
    let runs: Vec<(usize, Vec<String>)> = [1, 2, 4]
        .into_iter()
        .map(|n| {
            let out = std::process::Command::new(&exe)
                .args([
                    "thread_counts::child_prints_fingerprints",
                    "--exact",
                    "--ignored",
                    "--nocapture",
                    "--test-threads=1",
                ])
                .env(THREADS, n.to_string())
                .output()
                .unwrap();
            let text = String::from_utf8_lossy(&out.stdout).into_owned();
            assert!(out.status.success(), "{n} threads: {text}\n{}", String::from_utf8_lossy(&out.stderr));
            let prints: Vec<String> = text
                .lines()
                .filter_map(|l| l.split_once("FINGERPRINT "))
                .map(|(_, f)| f.to_owned())
                .collect();
            assert_eq!(prints.len(), 8, "{n} threads: {text}");
            (n, prints)
        })
        .collect();
    for (n, prints) in &runs[1..] {
        for (a, b) in runs[0].1.iter().zip(prints) {
            assert_eq!(a, b, "1 thread vs {n} threads");
        }
    }
    eprintln!("{:?}", runs[0].1);
}
