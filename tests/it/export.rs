//! `volcano::export`: a running world's spheres and air in OpenVDB grids at the right places
//! and values, the frame's files written whole, read back, and opened by OpenVDB itself.

use std::path::Path;
use std::process::Command;

use bevy::prelude::*;
use volcano::atmosphere::{AirLayer, Atmosphere};
use volcano::export::vdb::{FloatGrid, expectation, read_vdb};
use volcano::export::{ExportError, ExportSettings, FrameView, capture_frame, write_frame};
use volcano::lava::{LavaField, LavaState};
use volcano::plume::components::{PlumeSlice, S1};
use volcano::prelude::*;

use crate::worlds;

fn app() -> App {
    crate::worlds::sim_app(std::time::Duration::from_millis(20))
}

fn grid<'a>(grids: &'a [FloatGrid], name: &str) -> &'a FloatGrid {
    grids.iter().find(|g| g.name() == name).unwrap_or_else(|| panic!("no grid {name}"))
}

fn voxel_at(g: &FloatGrid, p: Vec3) -> [i32; 3] {
    g.transform().world_to_index(p.as_dvec3().to_array()).map(|x| x.round() as i32)
}

/// A Plinian column 6 s after the start, parents only on 10 m voxels: the voxel at every
/// large sphere's centre holds its density (the union of spheres of one slice is that dense),
/// and the temperature there is its slice's (or a hotter overlapping slice's).
#[test]
fn every_sphere_is_where_the_world_has_it_with_its_density_and_temperature() {
    let mut app = app();
    app.world_mut().spawn(worlds::small_island());
    app.world_mut().spawn((Volcano::new(100.0, 5).unwrap(), Eruption::plinian(), Transform::default()));
    spheres_hold_their_slices_density_and_temperature(app, 300, 100);
}

/// An s1 sphere and a pyroclastic particle with the same id (`slice << 8 | ring` and
/// `slice << 16 | k` meet: s1 id 65,536 is slice 256's first sphere, particle 65,536 is slice
/// 1's first particle), far apart: each voxel takes its own sphere's temperature.
#[test]
fn a_particle_and_an_s1_sphere_with_one_id_keep_their_own_temperatures() {
    use rand_chacha::rand_core::SeedableRng;
    use volcano::plume::components::{PlumeSlice, S1};
    use volcano::plume::pyroclastic::PyroParticle;
    use volcano::plume::{PlumeParams, Slice};
    let mut world = World::new();
    let volcano = world.spawn((Eruption::plinian(), volcano::core::VolcanoRng::new(1))).id();
    let mut state = Slice::at_vent(&PlumeParams::default());
    state.temperature = 1_000.0;
    let slice = world
        .spawn(PlumeSlice {
            volcano,
            index: 256,
            vent: Vec3::ZERO,
            state: state.clone(),
            ring_phase: 0.0,
            ash_pending: 0.0,
            secondary: false,
        })
        .id();
    let sphere =
        volcano::plume::model::spheres::S1Sphere { ring_angle: 0.0, size_factor: 1.0, radial_factor: 1.0 };
    world.spawn((
        S1 { slice, sphere, spin: 0.0, id: 65_536 },
        Transform::from_xyz(0.0, 500.0, 0.0).with_scale(Vec3::splat(50.0)),
    ));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let mut particle = volcano::plume::model::pyroclastic::collapse(&state, 30.0, 1, &mut rng)[0];
    particle.temperature = 500.0;
    world.spawn((
        PyroParticle { volcano, particle, vent: Vec3::ZERO, id: 65_536, buoyant: false },
        Transform::from_xyz(2_000.0, 100.0, 0.0),
    ));
    let settings = ExportSettings { ash_voxel_m: 10.0, detail_spheres: false, ..default() };
    let frame = capture_frame(&mut world, &settings, FrameView::default()).unwrap();
    let temp = grid(&frame.grids, "temperature");
    assert_eq!(temp.get(voxel_at(temp, Vec3::new(0.0, 500.0, 0.0))), 1_000.0, "the s1 sphere's slice");
    assert_eq!(temp.get(voxel_at(temp, Vec3::new(2_000.0, 100.0, 0.0))), 500.0, "the particle's own");
}

/// Runs `updates`, exports parents only on 10 m voxels and checks every large s1 sphere (more
/// than `min_spheres` of them) and every particle; returns the frame's sphere count and the
/// particles checked.
fn spheres_hold_their_slices_density_and_temperature(
    mut app: App,
    updates: u32,
    min_spheres: usize,
) -> (u64, usize) {
    for _ in 0..updates {
        app.update();
    }
    let settings = ExportSettings { ash_voxel_m: 10.0, detail_spheres: false, ..default() };
    let frame = capture_frame(app.world_mut(), &settings, FrameView::default()).unwrap();
    let (ash, temp) = (grid(&frame.grids, "ash"), grid(&frame.grids, "temperature"));
    assert!(frame.grids.iter().all(|g| g.name() != "cloud"), "no atmosphere, no cloud grid");

    let world = app.world_mut();
    let slices: Vec<(Entity, f64, f64)> = world
        .query::<(Entity, &PlumeSlice)>()
        .iter(world)
        .map(|(e, s)| (e, s.state.density, s.state.temperature))
        .collect();
    let hottest = slices.iter().map(|s| s.2).fold(0.0, f64::max);
    let mut checked = 0;
    for (s1, t) in world.query::<(&S1, &Transform)>().iter(world) {
        let &(_, density, temperature) = slices.iter().find(|s| s.0 == s1.slice).unwrap();
        if t.scale.x < 30.0 {
            continue;
        }
        let ijk = voxel_at(ash, t.translation);
        let a = ash.get(ijk) as f64;
        assert!(
            a >= 0.97 * density,
            "sphere of r {} at {}: ash {a}, slice density {density}",
            t.scale.x,
            t.translation
        );
        let k = temp.get(ijk) as f64;
        assert!(
            k >= temperature - 1e-3 && k <= hottest + 1e-3,
            "temperature {k} at a sphere of a {temperature} K slice"
        );
        checked += 1;
    }
    assert!(checked > min_spheres, "only {checked} large spheres");
    assert!(frame.info.spheres as usize >= checked);
    let mut particles = 0;
    for (p, t) in world.query::<(&volcano::plume::pyroclastic::PyroParticle, &Transform)>().iter(world) {
        let k = temp.get(voxel_at(temp, t.translation)) as f64;
        assert!(k >= p.particle.temperature - 1e-3, "{k} K at a {} K particle", p.particle.temperature);
        particles += 1;
    }
    (frame.info.spheres, particles)
}

/// Ash put into every layer of a block of 4 × 4 cells, away from the island, is exported as
/// `ash_fall` over that block at the right altitudes, and its mass is the atmosphere's to 3 %
/// (the export samples the layers' blend on 200 m voxels); condensed water put into one layer
/// of a block elsewhere is a `cloud` over that block, around that layer.
#[test]
fn the_airs_ash_and_clouds_are_where_the_layers_hold_them() {
    let mut app = app();
    let terrain = worlds::small_island();
    worlds::air_over(&mut app.world_mut().commands(), &terrain, 16);
    app.world_mut().flush();
    let world = app.world_mut();
    let (n, dx) = {
        let a = world.query::<&Atmosphere>().single(world).unwrap();
        (a.n, a.dx)
    };
    // Cells 1..5 × 1..5 (grid x and y = world x and z), 0.5 g/m³ in every layer.
    let cells: Vec<usize> = (1..5).flat_map(|j| (1..5).map(move |i| j * n + i)).collect();
    // Cells 9..13 × 2..6 of layer 2: 3 g/m³ of condensed water.
    let wet: Vec<usize> = (2..6).flat_map(|j| (9..13).map(move |i| j * n + i)).collect();
    let mut books_kg = 0.0;
    let mut stack = (f64::MAX, f64::MIN);
    let mut wet_layer = (0.0, 0.0);
    let mut centres: Vec<(f64, f32)> = Vec::new();
    for mut layer in world.query::<&mut AirLayer>().iter_mut(world) {
        let h = layer.fields.thickness;
        // A temperature a layer's own: 250 K + 10 K per layer up.
        let t = 250.0 + 10.0 * layer.index as f32;
        layer.fields.t.data_mut().fill(t);
        centres.push((layer.fields.altitude, t));
        if layer.index == 2 {
            wet_layer = (layer.fields.bottom, layer.fields.bottom + h);
            for &c in &wet {
                layer.fields.w.data_mut()[c] = 3.0;
            }
        }
        stack = (stack.0.min(layer.fields.bottom), stack.1.max(layer.fields.bottom + h));
        for &c in &cells {
            layer.fields.ash.data_mut()[c] = 0.5;
            books_kg += 0.5e-3 * h * dx * dx;
        }
    }
    let settings = ExportSettings { air_voxel_m: dx / 8.0, ..default() };
    let frame = capture_frame(world, &settings, FrameView::default()).unwrap();
    let fall = grid(&frame.grids, "ash_fall");
    let mass = fall.integral();
    assert!((mass / books_kg - 1.0).abs() < 0.03, "exported {mass} kg, atmosphere {books_kg} kg");
    let half = 0.5 * n as f64 * dx;
    for (ijk, _) in fall.iter_active() {
        let [x, y, z] = fall.transform().index_to_world(ijk);
        // Inside the block, to the bilinear reach of one cell.
        for (c, axis) in [(x, "x"), (z, "z")] {
            let cell = (c + half) / dx;
            assert!((0.5..5.5).contains(&cell), "ash at {axis} cell {cell}");
        }
        assert!(y >= stack.0 && y <= stack.1, "ash at {y} m, stack {stack:?}");
    }
    // The air's temperature: inside the stack, between the temperatures of the layers whose
    // centres bracket the voxel (its own layer's below the lowest centre and above the top
    // one); nothing above the stack. A swapped axis puts layers' temperatures at the wrong
    // altitudes.
    centres.sort_by(|a, b| a.0.total_cmp(&b.0));
    let air = grid(&frame.grids, "air_temperature");
    let mut inside = 0;
    for (ijk, t) in air.iter_active() {
        let y = air.transform().index_to_world(ijk)[1];
        assert!(y <= stack.1, "air temperature {t} K at {y} m, above the stack's top {}", stack.1);
        inside += 1;
        let k = centres.partition_point(|c| c.0 <= y);
        let (lo, hi) = match k {
            0 => (centres[0].1, centres[0].1),
            k if k == centres.len() => (centres[k - 1].1, centres[k - 1].1),
            k => (centres[k - 1].1, centres[k].1),
        };
        assert!(t >= lo - 1e-3 && t <= hi + 1e-3, "{t} K at {y} m, between layers of {lo} and {hi} K");
    }
    assert!(inside > 1_000, "{inside} air voxels");
    let cloud = grid(&frame.grids, "cloud");
    assert!(cloud.active_voxel_count() > 100, "{} cloud voxels", cloud.active_voxel_count());
    let (lo, hi) = (wet_layer.0 - (wet_layer.1 - wet_layer.0), wet_layer.1 + (wet_layer.1 - wet_layer.0));
    for (ijk, _) in cloud.iter_active() {
        let [x, y, z] = cloud.transform().index_to_world(ijk);
        let (ci, cj) = ((x + half) / dx, (z + half) / dx);
        assert!((8.5..13.5).contains(&ci) && (1.5..6.5).contains(&cj), "cloud over cell ({ci}, {cj})");
        assert!(y >= lo && y <= hi, "cloud at {y} m, layer 2 spans {wet_layer:?}");
    }
}

/// `write_frame` writes the `.vdb` and the `.json`; both read back; OpenVDB opens every grid
/// (tools/check_vdb.py, python3-openvdb); bad settings and an unwritable folder are errors
/// that leave nothing behind.
#[test]
fn a_frame_is_written_whole_and_openvdb_reads_it() {
    let mut app = app();
    app.world_mut().spawn(worlds::small_island());
    app.world_mut().spawn((Volcano::new(100.0, 5).unwrap(), Eruption::plinian(), Transform::default()));
    // At twice the game's speed the frame's time is the volcano's, not the fixed clock's.
    app.world_mut().resource_mut::<SimControl>().set_speed(2.0).unwrap();
    for _ in 0..100 {
        app.update();
    }
    let bad = ExportSettings { ash_voxel_m: f64::NAN, ..default() };
    assert!(matches!(
        capture_frame(app.world_mut(), &bad, FrameView::default()),
        Err(ExportError::Settings(_))
    ));
    let frame = capture_frame(app.world_mut(), &ExportSettings::default(), FrameView::default()).unwrap();

    let dir = tempfile::tempdir().unwrap();
    let (vdb, json) = write_frame(dir.path(), 3, &frame).unwrap();
    assert!(vdb.ends_with("frame_0003.vdb") && json.ends_with("frame_0003.json"));
    let (grids, meta) = read_vdb(&std::fs::read(&vdb).unwrap()).unwrap();
    assert_eq!(grids.iter().map(|g| g.name.as_str()).collect::<Vec<_>>(), ["ash", "temperature"]);
    assert!(meta.contains_key("creator"));
    for (read, written) in grids.iter().zip(&frame.grids) {
        assert_eq!(read.active.len() as u64, written.active_voxel_count());
        assert!(written.iter_active().all(|(ijk, v)| read.active.get(&ijk) == Some(&v)));
    }
    let info: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(info["up"], "y");
    assert_eq!(info["tick"], frame.info.tick);
    let ticks = frame.info.tick as f64;
    assert!(ticks > 90.0, "{ticks} ticks");
    assert!(
        (frame.info.time_s - 2.0 * 0.02 * ticks).abs() < 1e-9,
        "{} s after {ticks} ticks at speed 2",
        frame.info.time_s
    );
    assert_eq!(info["grids"][0]["active_voxels"], frame.grids[0].active_voxel_count());

    if std::env::var_os("VOLCANO_SKIP_OPENVDB").is_none() {
        let refs: Vec<&FloatGrid> = frame.grids.iter().collect();
        let expect = dir.path().join("expect.json");
        std::fs::write(&expect, expectation(&refs, 2_000).to_string()).unwrap();
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/check_vdb.py");
        let out = Command::new("/usr/bin/python3").arg(script).arg(&vdb).arg(&expect).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "OpenVDB check:\n{text}");
    }

    let missing = dir.path().join("no/such/folder");
    let e = write_frame(&missing, 0, &frame).unwrap_err();
    assert!(e.to_string().contains("no/such/folder"), "{e}");
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 3, "the frame's two files and the expectation, no temporary: {names:?}");
}

/// A lava flow on the island's flank after 10 s: its surface mesh covers the cells the lava
/// covers, at the lava's surface, with the top of the crust's temperature per vertex (the
/// crust only cooling the top, fresh lava glowing, every vertex between the air's and the
/// eruption's); `terrain.glb` and `frame_NNNN.glb` read back with the `gltf` crate's own checks.
#[test]
fn the_lava_is_a_mesh_where_it_flows_with_its_surface_temperature() {
    let mut app = app();
    let terrain = worlds::small_island();
    let source = Vec2::new(1_800.0, 300.0);
    let placement = volcano::lava::Placement {
        nx: 48,
        ny: 48,
        ..volcano::lava::Placement::downslope_of(&terrain, source, 48, 1.0).unwrap()
    };
    let world = app.world_mut();
    let mut commands = world.commands();
    worlds::lava(&mut commands, &terrain, placement, source, 2.0);
    commands.spawn(terrain);
    world.flush();
    for _ in 0..500 {
        app.update();
    }
    let frame = capture_frame(app.world_mut(), &ExportSettings::default(), FrameView::default()).unwrap();
    assert_eq!(frame.info.meshes, ["lava_0"]);
    let mesh = &frame.meshes[0];
    let world = app.world_mut();
    let (field, state) = world.query::<(&LavaField, &LavaState)>().single(world).unwrap();
    let flow = &state.flow;
    let (h, ground) = (flow.thickness(), flow.ground().data());
    let temps = mesh.temperature.as_ref().unwrap();
    let core_max = flow.temperature().data().iter().copied().fold(0.0, f64::max);
    let mut covered_quads = 0;
    for j in 0..flow.ny() - 1 {
        for i in 0..flow.nx() - 1 {
            let ks = [
                j * flow.nx() + i,
                j * flow.nx() + i + 1,
                (j + 1) * flow.nx() + i,
                (j + 1) * flow.nx() + i + 1,
            ];
            covered_quads +=
                ks.iter().all(|&k| h.data()[k] + flow.solid().data()[k] > field.params.min_thickness)
                    as usize;
        }
    }
    assert!(covered_quads > 20, "{covered_quads} quads of lava");
    assert_eq!(mesh.indices.len(), 6 * covered_quads);
    // A vertex for each cell the covered quads use, at that cell's lava surface.
    let mut used = std::collections::HashSet::new();
    for (v, p) in mesh.positions.iter().enumerate() {
        let (i, j) = flow.cell_at(Vec2::new(p[0], p[2])).unwrap();
        let k = j * flow.nx() + i;
        assert!(used.insert(k), "cell {k} twice");
        assert_eq!(h.position(i, j), Vec2::new(p[0], p[2]));
        assert_eq!(p[1], (ground[k] + h.data()[k].max(0.0)) as f32);
        let t = temps[v] as f64;
        assert!(t >= field.params.air_temperature - 1e-3 && t <= core_max + 1e-3, "vertex at {t} K");
    }
    assert!(mesh.indices.iter().all(|&v| (v as usize) < mesh.positions.len()));
    let referenced: std::collections::HashSet<u32> = mesh.indices.iter().copied().collect();
    assert_eq!(referenced.len(), mesh.positions.len(), "every vertex is used");
    // The crust only cools the top: no liquid vertex above its own core, and the fresh lava
    // near the source still glows (above 1,000 K) after 10 s.
    let core = flow.temperature().data();
    for (p, &t) in mesh.positions.iter().zip(temps) {
        let (i, j) = flow.cell_at(Vec2::new(p[0], p[2])).unwrap();
        let k = j * flow.nx() + i;
        if h.data()[k] > field.params.min_thickness {
            assert!(t as f64 <= core[k] + 1e-3, "top {t} K over a {} K core", core[k]);
        }
    }
    let hottest = temps.iter().copied().fold(0.0, f32::max);
    assert!(hottest > 1_000.0, "hottest top {hottest} K");
    let dir = tempfile::tempdir().unwrap();
    write_frame(dir.path(), 0, &frame).unwrap();
    let terrain =
        volcano::export::capture_terrain(world, &ExportSettings { terrain_max_side: 33, ..default() })
            .unwrap()
            .unwrap();
    assert_eq!(terrain.positions.len(), 33 * 33, "65 samples a side at stride 2");
    volcano::export::write_terrain(dir.path(), &terrain).unwrap();
    for (name, vertices) in [("frame_0000.glb", frame.meshes[0].positions.len()), ("terrain.glb", 33 * 33)] {
        let glb = gltf::Gltf::from_slice(&std::fs::read(dir.path().join(name)).unwrap()).unwrap();
        let blob = glb.blob.as_deref().unwrap();
        let mesh = glb.document.meshes().next().unwrap();
        let prim = mesh.primitives().next().unwrap();
        let reader = prim.reader(|_| Some(blob));
        assert_eq!(reader.read_positions().unwrap().count(), vertices, "{name}");
    }
}
