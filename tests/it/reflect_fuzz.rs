//! The running volcano fuzzed through reflection, as an inspector or a tool edits it: every
//! reflected numeric field of the simulation's components and resources (and the `Transform`s
//! of its entities), set to NaN, ±∞, zero, negative, huge or tiny values, one edit at a
//! time with a few ticks between. No edit may panic; the simulation keeps ticking.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::Duration;

use bevy::ecs::reflect::ReflectComponent;
use bevy::prelude::*;
use bevy::reflect::{PartialReflect, ReflectMut};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use volcano::prelude::*;

use crate::worlds;

/// Calls `leaf` on every numeric leaf of `value` (depth first), until it returns true.
fn walk(value: &mut dyn PartialReflect, leaf: &mut dyn FnMut(&mut dyn PartialReflect) -> bool) -> bool {
    match value.reflect_mut() {
        ReflectMut::Struct(s) => (0..s.field_len()).any(|i| s.field_at_mut(i).is_some_and(|f| walk(f, leaf))),
        ReflectMut::TupleStruct(s) => {
            (0..s.field_len()).any(|i| s.field_mut(i).is_some_and(|f| walk(f, leaf)))
        }
        ReflectMut::Tuple(s) => (0..s.field_len()).any(|i| s.field_mut(i).is_some_and(|f| walk(f, leaf))),
        ReflectMut::Array(s) => (0..s.len()).any(|i| s.get_mut(i).is_some_and(|f| walk(f, leaf))),
        ReflectMut::List(s) => (0..s.len().min(64)).any(|i| s.get_mut(i).is_some_and(|f| walk(f, leaf))),
        ReflectMut::Enum(s) => (0..s.field_len()).any(|i| s.field_at_mut(i).is_some_and(|f| walk(f, leaf))),
        ReflectMut::Opaque(v) => numeric(v) && leaf(v),
        _ => false,
    }
}

fn numeric(v: &mut dyn PartialReflect) -> bool {
    v.try_downcast_mut::<f64>().is_some()
        || v.try_downcast_mut::<f32>().is_some()
        || v.try_downcast_mut::<u32>().is_some()
        || v.try_downcast_mut::<u64>().is_some()
        || v.try_downcast_mut::<usize>().is_some()
}

/// Sets the numeric leaf `v` to one of the values a careless edit gives.
fn spoil(v: &mut dyn PartialReflect, rng: &mut ChaCha8Rng) -> String {
    const F: [f64; 10] =
        [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 0.0, -1.0, -1e9, 1e30, 1e-300, 1e9, 0.5];
    let f = F[rng.random_range(0..F.len())];
    let n: u64 = [0, 1, 3, 1 << 20, u32::MAX as u64][rng.random_range(0..5)];
    if let Some(x) = v.try_downcast_mut::<f64>() {
        *x = f;
        format!("{f} (f64)")
    } else if let Some(x) = v.try_downcast_mut::<f32>() {
        *x = f as f32;
        format!("{f} (f32)")
    } else if let Some(x) = v.try_downcast_mut::<u32>() {
        *x = n as u32;
        format!("{n} (u32)")
    } else if let Some(x) = v.try_downcast_mut::<u64>() {
        *x = n;
        format!("{n} (u64)")
    } else if let Some(x) = v.try_downcast_mut::<usize>() {
        *x = n as usize;
        format!("{n} (usize)")
    } else {
        unreachable!()
    }
}

/// What can be edited: (entity, type path); resources are components of their own entities.
fn targets(world: &World) -> Vec<(Entity, String)> {
    let registry = world.resource::<AppTypeRegistry>().read();
    let ours = |path: &str| path.starts_with("volcano") || path.ends_with("::Transform");
    let mut out = Vec::new();
    for reg in registry.iter() {
        let path = reg.type_info().type_path();
        if !ours(path) {
            continue;
        }
        // Immutable components (relationships such as `OnTerrain`) are replaced, never edited.
        let mutable = world.components().get_id(reg.type_id()).and_then(|id| world.components().get_info(id));
        if !mutable.is_some_and(|info| info.mutable()) {
            continue;
        }
        if let Some(rc) = reg.data::<ReflectComponent>() {
            for e in world.iter_entities() {
                if rc.contains(e) {
                    out.push((e.id(), path.to_owned()));
                }
            }
        }
    }
    out.sort();
    out
}

/// Applies one random edit to `target`; returns what it did, or `None` without a numeric field.
fn edit(world: &mut World, target: &(Entity, String), rng: &mut ChaCha8Rng) -> Option<String> {
    let registry = world.resource::<AppTypeRegistry>().clone();
    let registry = registry.read();
    let reg = registry.get_with_type_path(&target.1)?;
    let entity = world.get_entity_mut(target.0).ok()?;
    let mut value: Mut<dyn Reflect> = reg.data::<ReflectComponent>()?.reflect_mut(entity)?;
    let mut leaves = 0;
    walk(value.as_partial_reflect_mut(), &mut |_| {
        leaves += 1;
        false
    });
    if leaves == 0 {
        return None;
    }
    let pick = rng.random_range(0..leaves);
    let (mut k, mut did) = (0, String::new());
    walk(value.as_partial_reflect_mut(), &mut |v| {
        if k == pick {
            did = spoil(v, rng);
            return true;
        }
        k += 1;
        false
    });
    Some(format!("{} leaf {pick} of {leaves} = {did}", target.1))
}

/// A small whole volcano: terrain, atmosphere, a plinian eruption, a lava field with a
/// source and a zone.
fn world() -> App {
    let mut app = worlds::sim_app(Duration::from_millis(40));
    let terrain = worlds::small_island();
    let world = app.world_mut();
    let mut commands = world.commands();
    let source = worlds::air_and_flank_lava(&mut commands, &terrain, 0.2);
    commands.spawn(LavaZone::new(source + Vec2::new(0.0, 20.0), 5.0).unwrap());
    commands.spawn(terrain);
    commands.spawn((Volcano::new(100.0, 3).unwrap(), Eruption::plinian(), Transform::default()));
    world.flush();
    app
}

#[test]
fn reflected_edits_never_panic() {
    let mut app = world();
    for _ in 0..50 {
        app.update();
    }
    let cases: usize =
        std::env::var("VOLCANO_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000) / 4;
    let seed = std::env::var("VOLCANO_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(0x0EF1EC7);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut done = Vec::new();
    for case in 0..cases {
        // A type first (uniformly: a few hundred ring spheres must not drown the one
        // `SimControl`), then one of its entities.
        let all = targets(app.world());
        let mut types: Vec<&str> = all.iter().map(|(_, t)| t.as_str()).collect();
        types.dedup();
        let ty = types[rng.random_range(0..types.len())];
        let of: Vec<&(Entity, String)> = all.iter().filter(|(_, t)| t == ty).collect();
        let target = of[rng.random_range(0..of.len())];
        let Some(did) = edit(app.world_mut(), target, &mut rng) else { continue };
        done.push(did.clone());
        let tick = app.world().resource::<SimTick>().0;
        let clock = std::time::Instant::now();
        let ran = catch_unwind(AssertUnwindSafe(|| {
            for _ in 0..3 {
                app.update();
            }
        }));
        if std::env::var("VOLCANO_FUZZ_LIST").is_ok() && clock.elapsed().as_secs_f64() > 0.02 {
            let n = app.world().entities().count_spawned();
            eprintln!("SLOW {:.2} s after case {case} ({n} entities): {did}", clock.elapsed().as_secs_f64());
        }
        assert!(ran.is_ok(), "case {case}: {did} panicked; edits so far:\n{}", done.join("\n"));
        assert!(app.world().resource::<SimTick>().0 > tick, "case {case}: {did} stopped the ticks");
        // A speed edit is corrected to the fastest valid speed (the clock's own test checks
        // that); back to real time, so the world does not grow a hundred times faster.
        app.world_mut().resource_mut::<SimControl>().set_speed(1.0).unwrap();
    }
    eprintln!("{} edits", done.len());
    if std::env::var("VOLCANO_FUZZ_LIST").is_ok() {
        eprintln!("{}", done.join("\n"));
    }
    assert!(done.len() > cases / 2);
}

/// The edits the fuzzer found panicking: a volcano's radius made −∞ through reflection (a
/// debug-build assertion) and an atmosphere's clock made −∞ (the weather step's clamps on the
/// NaN sun). Both are refused where they enter, with a warning, and the simulation goes on; set
/// back, the weather steps again.
#[test]
fn the_edits_the_fuzzer_found_are_refused() {
    use bevy::reflect::GetPath;
    use volcano::atmosphere::Atmosphere;
    #[derive(Resource, Default)]
    struct Steps(usize);
    let mut app = world();
    app.init_resource::<Steps>()
        .add_systems(Last, |mut r: MessageReader<WeatherStepped>, mut s: ResMut<Steps>| {
            s.0 += r.read().count()
        });
    for _ in 0..50 {
        app.update();
    }
    let world = app.world_mut();
    let mut volcano = world.query::<&mut Volcano>().single_mut(world).unwrap();
    *volcano.path_mut::<f32>("vent_radius").unwrap() = f32::NEG_INFINITY;
    let mut atmo = world.query::<&mut Atmosphere>().single_mut(world).unwrap();
    let time = atmo.time_s;
    atmo.time_s = f64::NEG_INFINITY;
    let tick = world.resource::<SimTick>().0;
    for _ in 0..100 {
        app.update();
    }
    assert!(app.world().resource::<SimTick>().0 >= tick + 100);
    let steps = app.world().resource::<Steps>().0;
    let world = app.world_mut();
    world.query::<&mut Atmosphere>().single_mut(world).unwrap().time_s = time;
    for _ in 0..100 {
        app.update();
    }
    assert!(app.world().resource::<Steps>().0 > steps, "the weather steps again once the clock is fixed");
}
