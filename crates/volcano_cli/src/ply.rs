//! `volcano plume --export DIR --frames N`: runs the plume plugin headless and writes one
//! binary PLY point file per frame with `x, y, z, radius, density` for every sphere of every
//! scale (s1 on slices, umbrella spheres, and their procedural s2/s3 children). Coordinates are
//! Bevy's world frame: metres, **y up**, vent at the origin (in Blender's PLY import choose
//! "Y up"; Houdini is y-up already).

use std::io::{BufWriter, Write};
use std::path::Path;
use std::process::ExitCode;
use std::time::Duration;

use bevy::math::DVec3;
use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use volcano::plume::view::{for_each_sphere, gather_parents};
use volcano::plume::{Eruption, PlumeParams};
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

/// Every sphere of every scale, through the same enumeration the renderer uses; without the
/// clouds the view derives over pyroclastic currents (`current_clouds`), which are a look, not
/// model spheres.
fn gather(world: &mut World) -> Vec<PointRecord> {
    let (eruptions, mut parents) = gather_parents(world);
    parents.retain(|p| !p.cloud);
    let mut out = Vec::new();
    for_each_sphere(&eruptions, &parents, |s| {
        out.push(PointRecord { center: s.center, radius: s.radius, density: s.density })
    });
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
    let ticks_per_frame = ((frame_seconds * crate::TICK_HZ).round() as u64).max(1);
    let start_ticks = (start_seconds * crate::TICK_HZ).round() as u64;
    let seed = 1;
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, VolcanoSimPlugins))
        .insert_resource(Time::<Fixed>::from_hz(crate::TICK_HZ))
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
        let points = gather(app.world_mut());
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
