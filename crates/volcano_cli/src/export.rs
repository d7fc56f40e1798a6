//! `volcano plume --export DIR --frames N`: runs the plume plugin headless and writes one
//! binary PLY point file per frame with `x, y, z, radius, density` for every sphere of every
//! scale (s1 on slices, umbrella spheres, and their procedural s2/s3 children). Coordinates are
//! Bevy's world frame: metres, **y up**, vent at the origin (in Blender's PLY import choose
//! "Y up"; Houdini is y-up already).

use std::io::{BufWriter, Write};
use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use bevy::math::{DQuat, DVec3};
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::plume::model::spheres::detail_spheres;
use volcano::plume::{Eruption, PlumeParams, PlumeSlice, S1, Umbrella};
use volcano::prelude::*;

/// One exported sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointRecord {
    /// Centre (world, y up).
    pub center: DVec3,
    /// Radius (m).
    pub radius: f64,
    /// Density (kg/m³).
    pub density: f64,
}

/// Writes a binary little-endian PLY of `points`.
pub fn write_ply(path: &Path, points: &[PointRecord]) -> std::io::Result<()> {
    let mut f = BufWriter::new(std::fs::File::create(path)?);
    write!(
        f,
        "ply\nformat binary_little_endian 1.0\ncomment volcano plume spheres, metres, y up\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float radius\nproperty float density\nend_header\n",
        points.len()
    )?;
    for p in points {
        for v in [p.center.x, p.center.y, p.center.z, p.radius, p.density] {
            f.write_all(&(v as f32).to_le_bytes())?;
        }
    }
    f.flush()
}

fn gather(world: &mut World, seed: u64, eruption: &Eruption) -> Vec<PointRecord> {
    let mut out = Vec::new();
    let push_family = |id: u64, t: &Transform, radius: f64, density: f64, out: &mut Vec<PointRecord>| {
        let center = t.translation.as_dvec3();
        out.push(PointRecord { center, radius, density });
        let rot = DQuat::from_xyzw(
            t.rotation.x as f64,
            t.rotation.y as f64,
            t.rotation.z as f64,
            t.rotation.w as f64,
        );
        out.extend(detail_spheres(&eruption.spheres, seed, id, center, radius, rot).map(|d| PointRecord {
            center: d.center,
            radius: d.radius,
            density,
        }));
    };
    let slices: std::collections::HashMap<Entity, f64> =
        world.query::<(Entity, &PlumeSlice)>().iter(world).map(|(e, s)| (e, s.state.density)).collect();
    let mut q = world.query::<(&S1, &Transform)>();
    let mut s1: Vec<_> = q.iter(world).map(|(s, t)| (s.id, s.slice, *t)).collect();
    s1.sort_by_key(|e| e.0);
    for (id, slice, t) in s1 {
        let density = slices.get(&slice).copied().unwrap_or(0.0);
        push_family(id, &t, t.scale.x as f64, density, &mut out);
    }
    let mut q = world.query::<(&Umbrella, &Transform)>();
    let mut um: Vec<_> = q.iter(world).map(|(u, t)| (u.id, u.radius, u.density, *t)).collect();
    um.sort_by_key(|e| e.0);
    for (id, radius, density, t) in um {
        push_family(id, &t, radius, density, &mut out);
    }
    out
}

/// Runs the eruption `params` on a flat plain and writes `frames` PLY files, one every
/// `frame_seconds` (rounded to whole 20 ms base ticks), after `start_seconds`.
pub fn export(
    params: &PlumeParams,
    dir: &Path,
    frames: u32,
    frame_seconds: f64,
    start_seconds: f64,
) -> ExitCode {
    let eruption = match Eruption::new(params.clone(), Default::default()) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    if !(frame_seconds.is_finite()
        && frame_seconds > 0.0
        && start_seconds.is_finite()
        && start_seconds >= 0.0)
        || frames == 0
    {
        eprintln!("error: --frames must be ≥ 1, --frame-seconds > 0, --start-seconds ≥ 0");
        return ExitCode::from(2);
    }
    if let Err(e) = std::fs::create_dir_all(dir) {
        eprintln!("error: cannot create {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let ticks_per_frame = ((frame_seconds * 50.0).round() as u64).max(1);
    let start_ticks = (start_seconds * 50.0).round() as u64;
    let seed = 1;
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins))
        .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_millis(20)));
    app.world_mut()
        .spawn(Terrain::flat(3, 1_000.0, params.vent_altitude as f32).expect("valid flat terrain"));
    app.world_mut().spawn((
        Volcano::new(params.r0 as f32, seed).unwrap_or_default(),
        eruption.clone(),
        Transform::default(),
    ));
    let run_to = |app: &mut App, tick: u64| {
        while app.world().resource::<SimTick>().0 < tick {
            app.update();
        }
    };
    let mut total = 0usize;
    for f in 0..frames {
        run_to(&mut app, start_ticks + f as u64 * ticks_per_frame);
        let points = gather(app.world_mut(), seed, &eruption);
        total += points.len();
        let path = dir.join(format!("frame_{f:05}.ply"));
        if let Err(e) = write_ply(&path, &points) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    println!("wrote {frames} PLY frames ({total} spheres in all) to {}", dir.display());
    ExitCode::SUCCESS
}
