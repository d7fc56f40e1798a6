//! `volcano pyroclastic`: runs a (collapsing) eruption headless on the `pyroclastic_flow`
//! scene's terrain for S seconds and writes `DIR/summary.json` (particles, runout, secondary
//! columns, the mass budget) and `DIR/deposit.png`, a top view of the terrain (hill-shaded),
//! the deposit thickness (brown, darker = thicker) and the particle tracks (orange dots).

use std::path::Path;
use std::process::ExitCode;

use bevy::prelude::*;
use serde::Serialize;
use volcano::plume::pyroclastic::airborne_mass;
use volcano::plume::{DepositMap, Eruption, PlumeParams, PyroParticle};
use volcano::prelude::*;

/// What `summary.json` holds.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// Simulated seconds.
    pub seconds: f64,
    /// Particles spawned by collapses.
    pub particles_spawned: u64,
    /// Particles alive at the end.
    pub particles_alive: usize,
    /// Farthest horizontal distance from the vent reached by a particle (m).
    pub runout_m: f64,
    /// Secondary columns formed.
    pub secondary_columns: u64,
    /// Mass handed over by collapsing slices (kg).
    pub collapsed_mass_kg: f64,
    /// Mass on the deposit map (kg).
    pub deposited_mass_kg: f64,
    /// Mass of live particles (kg).
    pub airborne_mass_kg: f64,
    /// Mass lifted into secondary columns (kg).
    pub lifted_mass_kg: f64,
    /// Mass of particles that left the terrain (kg).
    pub lost_mass_kg: f64,
    /// |collapsed − (airborne + deposited + lifted + lost)| / collapsed.
    pub budget_rel_error: f64,
    /// Thickest deposit (m) at the bulk density.
    pub max_deposit_m: f64,
}

/// Particle positions sampled once per simulated second, and the farthest distance.
#[derive(Resource, Default)]
struct Tracks {
    points: Vec<Vec2>,
    runout: f32,
}

fn record(tick: Res<SimTick>, particles: Query<(&PyroParticle, &Transform)>, mut tracks: ResMut<Tracks>) {
    for (p, t) in &particles {
        let d = Vec2::new(t.translation.x - p.vent.x, t.translation.z - p.vent.z).length();
        tracks.runout = tracks.runout.max(d);
        if tick.0.is_multiple_of(50) {
            tracks.points.push(Vec2::new(t.translation.x, t.translation.z));
        }
    }
}

/// Runs the eruption and writes the outputs.
pub fn run(params: &PlumeParams, seconds: f64, dir: &Path) -> ExitCode {
    if !(seconds.is_finite() && seconds > 0.0 && seconds <= 3_600.0) {
        eprintln!("error: --seconds must be in (0, 3600]");
        return ExitCode::from(2);
    }
    let mut eruption = Eruption::pyroclastic();
    eruption.params = params.clone();
    if let Err(e) = eruption.validate() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let scene = match volcano::scenes::by_name("pyroclastic_flow") {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let (terrain, (volcano, transform)) = match (scene.terrain.build(), scene.volcano.build()) {
        (Ok(t), Ok(v)) => (t, v),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(e) = std::fs::create_dir_all(dir) {
        eprintln!("error: cannot create {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    let mut app = crate::sim_app();
    app.init_resource::<Tracks>().add_systems(FixedUpdate, record.in_set(SimSystems::End));
    app.world_mut().spawn(terrain.clone());
    app.world_mut().spawn((volcano, eruption, transform));
    let ticks = (seconds * crate::TICK_HZ).round() as u64;
    while app.world().resource::<SimTick>().0 < ticks {
        app.update();
    }
    let world = app.world_mut();
    let airborne = airborne_mass(world);
    let alive = world.query::<&PyroParticle>().iter(world).count();
    let b = volcano::plume::ground::all_budgets(world);
    // The scenario's one terrain.
    let deposit = world.query::<&DepositMap>().iter(world).next().cloned().unwrap_or_default();
    let tracks = world.remove_resource::<Tracks>().unwrap_or_default();
    let accounted = airborne + b.deposited + b.lifted + b.lost;
    let max_deposit = deposit.mass.as_ref().map_or(0.0, |g| {
        g.data().iter().copied().fold(0.0, f64::max) / (deposit.bulk_density * g.cell() * g.cell())
    });
    let summary = Summary {
        seconds,
        particles_spawned: b.spawned,
        particles_alive: alive,
        runout_m: tracks.runout as f64,
        secondary_columns: b.secondary_columns,
        collapsed_mass_kg: b.collapsed,
        deposited_mass_kg: b.deposited,
        airborne_mass_kg: airborne,
        lifted_mass_kg: b.lifted,
        lost_mass_kg: b.lost,
        budget_rel_error: if b.collapsed > 0.0 { (b.collapsed - accounted).abs() / b.collapsed } else { 0.0 },
        max_deposit_m: max_deposit,
    };
    let json = serde_json::to_string_pretty(&summary).unwrap_or_default();
    if let Err(e) = std::fs::write(dir.join("summary.json"), &json) {
        eprintln!("error: cannot write summary: {e}");
        return ExitCode::FAILURE;
    }
    if let Err(e) = write_map(&terrain, &deposit, &tracks.points, &dir.join("deposit.png")) {
        eprintln!("error: cannot write deposit.png: {e}");
        return ExitCode::FAILURE;
    }
    println!("{json}");
    ExitCode::SUCCESS
}

/// Top view of the central half of the terrain, 2 pixels per cell: hill-shaded terrain,
/// deposit thickness in brown (log scale from 1 mm to 10 m), particle positions once per
/// second as an orange tint.
fn write_map(terrain: &Terrain, deposit: &DepositMap, tracks: &[Vec2], path: &Path) -> Result<(), String> {
    let h = terrain.heights();
    let (i0, j0) = (h.nx() / 4, h.ny() / 4);
    let (cw, ch) = (h.nx() / 2, h.ny() / 2);
    let scale = 2usize;
    let (w, ht) = (cw * scale, ch * scale);
    let mut rgb = vec![Vec3::ZERO; w * ht];
    let light = Vec3::new(-1.0, 1.5, -1.0).normalize();
    let cell = h.cell() as f32 / scale as f32;
    let origin = h.position(i0, j0);
    for y in 0..ht {
        for x in 0..w {
            let p = origin + Vec2::new(x as f32, y as f32) * cell;
            let n = terrain.normal_at(p.x, p.y);
            let shade = 0.35 + 0.65 * n.dot(light).max(0.0);
            let mut c = Vec3::splat(0.75 * shade);
            let t = deposit.thickness_at(p.x, p.y);
            if t > 1e-3 {
                let k = ((t / 1e-3).log10() / 4.0).clamp(0.0, 1.0) as f32;
                let tan = Vec3::new(0.85, 0.7, 0.5).lerp(Vec3::new(0.3, 0.18, 0.08), k);
                c = tan * (0.5 + 0.5 * shade);
            }
            rgb[y * w + x] = c;
        }
    }
    // Tracks as a single tint (not accumulated), so the deposit stays readable under them.
    let mut seen = vec![false; w * ht];
    for p in tracks {
        let q = (*p - origin) / cell;
        let (x, y) = (q.x.round() as i64, q.y.round() as i64);
        if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < ht {
            seen[y as usize * w + x as usize] = true;
        }
    }
    for (c, s) in rgb.iter_mut().zip(&seen) {
        if *s {
            *c = c.lerp(Vec3::new(1.0, 0.45, 0.0), 0.35);
        }
    }
    let bytes: Vec<u8> =
        rgb.iter().flat_map(|c| [c.x, c.y, c.z].map(|v| (v.clamp(0.0, 1.0) * 255.0) as u8)).collect();
    let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w as u32, ht as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(&bytes).map_err(|e| e.to_string())
}
