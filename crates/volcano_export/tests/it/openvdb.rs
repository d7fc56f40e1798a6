//! Files checked with OpenVDB (Debian's python3-openvdb, which `scripts/setup.sh` installs):
//! `tools/check_vdb.py` opens every grid and compares names, classes, transforms, active
//! boxes, counts, sums and sampled voxels with the grids in memory.

use std::path::Path;
use std::process::Command;

use volcano_export::splat::{Combine, Fill, Sphere, splat_spheres};
use volcano_export::vdb::{FloatGrid, GridClass, MetaValue, Transform, expectation, write_vdb_file};

/// Runs the OpenVDB check on `vdb` against `grids`; panics with its output on a mismatch. The
/// check is part of the test suite: without python3-openvdb it fails (set
/// `VOLCANO_SKIP_OPENVDB=1` to skip it on a machine without it, never in CI).
fn openvdb_check(vdb: &Path, grids: &[&FloatGrid]) {
    if std::env::var_os("VOLCANO_SKIP_OPENVDB").is_some() {
        eprintln!("VOLCANO_SKIP_OPENVDB set: OpenVDB check of {} skipped", vdb.display());
        return;
    }
    let json = vdb.with_extension("json");
    std::fs::write(&json, expectation(grids, 2_000).to_string()).unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/check_vdb.py");
    let out = Command::new("/usr/bin/python3")
        .arg(&script)
        .arg(vdb)
        .arg(&json)
        .output()
        .expect("/usr/bin/python3 (install python3-openvdb: scripts/setup.sh)");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "OpenVDB check failed:\n{text}");
    eprint!("{text}");
    let lines = text.lines().filter(|l| l.starts_with("ok ")).count();
    assert_eq!(lines, grids.len(), "one line per grid:\n{text}");
}

/// Three grids in one file: spheres spanning several root nodes (negative and positive
/// indices beyond ±4096), a single voxel, and a dense block filling whole leaves; with
/// metadata on a grid and on the file.
#[test]
fn openvdb_reads_every_grid_and_value_we_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.vdb");

    let mut ash =
        FloatGrid::new("ash", GridClass::FogVolume, Transform::new(2.5, [100.0, -20.0, 7.5]).unwrap())
            .unwrap();
    let spheres = [
        Sphere { center: [0.0, 0.0, 0.0], radius: 40.0, density: 1.25 },
        Sphere { center: [-10_500.0, 200.0, 11_000.0], radius: 12.0, density: 0.5 },
        Sphere { center: [10_400.0, -10_300.0, 3.0], radius: 1.0, density: 3.0 },
    ];
    splat_spheres(&mut ash, spheres, Fill::Density, Combine::Max, u64::MAX).unwrap();
    ash.insert_meta("units", MetaValue::String("kg/m^3".into())).unwrap();

    let mut one =
        FloatGrid::new("single", GridClass::Unknown, Transform::new(1.0, [0.0; 3]).unwrap()).unwrap();
    one.set([-1, -1, -1], 273.15).unwrap();

    let mut block =
        FloatGrid::new("temperature", GridClass::Unknown, Transform::new(0.5, [0.0; 3]).unwrap()).unwrap();
    for i in -8..16 {
        for j in 0..8 {
            for k in 120..136 {
                block.set([i, j, k], 250.0 + (i * 7 + j * 3 + k) as f32 * 0.25).unwrap();
            }
        }
    }
    let grids = [&ash, &one, &block];
    write_vdb_file(&path, &grids, &[("volcano_time_s", MetaValue::Double(150.0))]).unwrap();
    assert!(ash.active_voxel_count() > 10_000 && ash.leaf_count() > 50);
    openvdb_check(&path, &grids);
}

/// An empty grid is a valid file too (a frame before the eruption).
#[test]
fn openvdb_reads_an_empty_grid() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.vdb");
    let g = FloatGrid::new("cloud", GridClass::FogVolume, Transform::new(100.0, [0.0; 3]).unwrap()).unwrap();
    write_vdb_file(&path, &[&g], &[]).unwrap();
    openvdb_check(&path, &[&g]);
}
