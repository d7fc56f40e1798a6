//! Pyroclastic flows (thesis §3.3.1 Peléan regime, §3.6, Fig 3.6): a collapsing slice becomes
//! s2-sized spheres that fall, hit the terrain, run down its valleys while they lose mass, and,
//! once lighter than the air, gather into secondary columns.
//!
//! Frame: the plume frame of [`Slice`] (x, y horizontal, z up, metres above the vent). The
//! ground is a function `z = ground(x, y)` in the same frame.

use bevy::math::{DVec2, DVec3};
use bevy::reflect::Reflect;
use rand::RngExt;
use serde::{Deserialize, Serialize};
use volcano_core::error::{ConfigError, in_range, positive};
use volcano_core::units::G0;

use super::slice::{MIN_DENSITY, Phase, Slice, SliceEnv};

/// Parameters of the pyroclastic particles.
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PyroclasticParams {
    /// σ_pyr, mass loss while moving, read like σ_col as a density decrement rate (kg/m³/s):
    /// a moving particle of volume V loses `σ_pyr · V · Δt` kg per step, deposited under it.
    /// Table 3.1 prints 5·10⁻⁶; read this way a flow would need days to turn buoyant (the
    /// particles do not entrain air), so the default, 0.3, is a showcase value: the
    /// `pyroclastic_showcase` collapse (22 kg/m³ at 255 m) turns buoyant after about 70 s of
    /// running.
    pub sigma_pyr: f64,
    /// Drag coefficient of a sphere (eq 3.5 with the cross-section π r²).
    pub drag_coefficient: f64,
    /// Wind coefficient λ (eq 3.6, kg/m³) with the cross-section π r². Not the slices'
    /// λ = 600: that value makes slices follow the wind, and on dense ground-hugging spheres it
    /// acts as an enormous horizontal drag (a 6-tonne sphere of radius 8 m would creep down a
    /// 17° slope at 0.3 m/s). The default, 1 kg/m³, is of the order of ½ ρ_air C_d.
    pub wind_coefficient: f64,
    /// Clustering radius r_pyr (m): buoyant particles within it of a cluster seed join it.
    /// Default 50 m, about 5 s2 radii as in the authors' prototype.
    pub cluster_radius: f64,
    /// Fewest buoyant particles that make a secondary column (prototype: more than 18).
    pub min_cluster: u32,
    /// Bulk density of the deposit (kg/m³), for its thickness.
    pub deposit_density: f64,
    /// A particle on the ground slower than this (m/s) settles: its whole mass is deposited.
    pub settle_speed: f64,
    /// Longest distance a particle may travel in one substep (m): keeps terrain collisions
    /// from tunnelling through ridges; more substeps only where particles are fast.
    pub max_travel: f64,
    /// Angle of repose of the deposit (degrees): steeper deposit slides down (beyond the
    /// thesis, [`super::deposit::relax_to_repose`]). Dry pyroclastic material: 30–35°.
    pub repose_angle_deg: f64,
}

impl Default for PyroclasticParams {
    fn default() -> Self {
        Self {
            sigma_pyr: 0.3,
            drag_coefficient: 0.47,
            wind_coefficient: 1.0,
            cluster_radius: 50.0,
            min_cluster: 19,
            deposit_density: 1_000.0,
            settle_speed: 0.5,
            max_travel: 20.0,
            repose_angle_deg: 34.0,
        }
    }
}

impl PyroclasticParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("sigma_pyr", self.sigma_pyr, 0.0, 100.0)?;
        in_range("pyroclastic drag_coefficient", self.drag_coefficient, 0.0, 10.0)?;
        in_range("pyroclastic wind_coefficient", self.wind_coefficient, 0.0, 1e5)?;
        in_range("cluster_radius", self.cluster_radius, 1.0, 10_000.0)?;
        in_range("min_cluster", self.min_cluster as f64, 1.0, 100_000.0)?;
        positive("deposit_density", self.deposit_density)?;
        in_range("settle_speed", self.settle_speed, 0.0, 100.0)?;
        in_range("max_travel", self.max_travel, 0.1, 10_000.0)?;
        in_range("repose_angle_deg", self.repose_angle_deg, 0.0, 89.0)?;
        Ok(())
    }
}

/// One pyroclastic sphere (fixed volume; its mass falls as it sediments).
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct Particle {
    /// Centre (plume frame, m).
    pub position: DVec3,
    /// Velocity (m/s).
    pub velocity: DVec3,
    /// Radius (m).
    pub radius: f64,
    /// Mass (kg).
    pub mass: f64,
    /// Temperature (K), carried to a secondary column.
    pub temperature: f64,
    /// Whether it touched the ground during the last step.
    pub grounded: bool,
}

impl Particle {
    /// Volume `4/3 π r³` (m³).
    pub fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.radius.powi(3)
    }
    /// Density `m / V` (kg/m³).
    pub fn density(&self) -> f64 {
        self.mass / self.volume()
    }
}

/// Collapse hand-over (§3.6): a slice of volume V and mass M becomes N = round(V / V_s2)
/// spheres of the s2 radius `r_s2`, scattered uniformly through the slice's volume (a disc of
/// radius r and thickness r around its centre), each of mass M/N with the slice's velocity and
/// temperature: mass and momentum are conserved exactly (up to rounding of M/N · N).
/// `max_particles` caps N for huge slices (then the spheres are larger, same total volume).
pub fn collapse(slice: &Slice, r_s2: f64, max_particles: usize, rng: &mut impl rand::Rng) -> Vec<Particle> {
    let volume = slice.volume();
    let v_s2 = 4.0 / 3.0 * std::f64::consts::PI * r_s2.max(1e-3).powi(3);
    let n = ((volume / v_s2).round() as usize).clamp(1, max_particles.max(1));
    // Same total volume with n spheres.
    let radius = (volume / n as f64 * 3.0 / (4.0 * std::f64::consts::PI)).cbrt();
    let mass = slice.mass / n as f64;
    (0..n)
        .map(|_| {
            let (a, u, h): (f64, f64, f64) =
                (rng.random_range(0.0..std::f64::consts::TAU), rng.random(), rng.random_range(-0.5..0.5));
            let rho = slice.r * u.sqrt();
            let offset = DVec3::new(rho * a.cos(), rho * a.sin(), h * slice.r);
            Particle {
                position: slice.position + offset,
                velocity: slice.velocity,
                radius,
                mass,
                temperature: slice.temperature,
                grounded: false,
            }
        })
        .collect()
}

/// What one particle step did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ParticleReport {
    /// Mass lost to the ground this step (kg), with where it fell.
    pub deposited: f64,
    /// Where the deposit fell (x, y).
    pub deposit_at: DVec2,
    /// The particle came to rest on the ground: its whole remaining mass is in `deposited`
    /// and it should be removed.
    pub settled: bool,
    /// Substeps used.
    pub substeps: u32,
    /// Lighter than the air around it at the end of the step (a secondary-column candidate).
    pub buoyant: bool,
}

/// Ground normal by central differences (unit, pointing up). Generic over the ground function
/// (a closure or a `dyn Fn`) so that the particle step's calls can be inlined.
pub fn ground_normal<G: Fn(f64, f64) -> f64 + ?Sized>(ground: &G, x: f64, y: f64, h: f64) -> DVec3 {
    let dx = (ground(x + h, y) - ground(x - h, y)) / (2.0 * h);
    let dy = (ground(x, y + h) - ground(x, y - h)) / (2.0 * h);
    DVec3::new(-dx, -dy, 1.0).normalize_or(DVec3::Z)
}

/// Advances a particle by `dt` (a base tick, 0.02 s), in as many substeps as `max_travel`
/// needs. Forces as for slices (§3.4.3) with sphere geometry: weight and buoyancy (3.4), drag
/// (3.5, cross-section π r², implicit) and wind (3.6, exact relaxation of the relative
/// velocity). Mass loss σ_pyr while moving (§3.6), fixed volume. Heightfield collision: a
/// particle below the ground is put back on it and loses the velocity component into the
/// ground; the tangential part is kept, so flows follow valleys. `ground` is a closure or a
/// `dyn Fn` (generic, so a closure's calls are inlined).
pub fn step_particle<G: Fn(f64, f64) -> f64 + ?Sized>(
    particle: &mut Particle,
    p: &PyroclasticParams,
    env: &SliceEnv,
    ground: &G,
    dt: f64,
) -> ParticleReport {
    let mut report = ParticleReport { deposit_at: particle.position.truncate(), ..Default::default() };
    if !(dt.is_finite() && dt > 0.0) {
        return report;
    }
    let travel = particle.velocity.length() * dt;
    let n = ((travel / p.max_travel).ceil() as u32).clamp(1, 64);
    let h = dt / n as f64;
    let volume = particle.volume();
    let mut air_density = 0.0;
    for _ in 0..n {
        let air = env.air.sample(env.vent_altitude + particle.position.z);
        air_density = air.density;
        let wind = (env.wind)(particle.position.z.max(0.0));
        let m = particle.mass;
        // Weight and buoyancy, eq 3.4.
        let mut v = particle.velocity + DVec3::Z * (h * (-m * G0 + air.density * volume * G0) / m);
        // Drag, eq 3.5 (implicit).
        let area = std::f64::consts::PI * particle.radius * particle.radius;
        let c = 0.5 * air.density * p.drag_coefficient * area / m;
        v /= 1.0 + c * v.length() * h;
        // Wind, eq 3.6 (exact for du/dt = −k|u|u).
        let k = p.wind_coefficient * area / m;
        let u = v.truncate() - wind;
        v = (wind + u / (1.0 + k * u.length() * h)).extend(v.z);
        particle.velocity = v;
        particle.position += v * h;
        // Terrain collision.
        let g = ground(particle.position.x, particle.position.y);
        particle.grounded = particle.position.z <= g;
        if particle.grounded {
            particle.position.z = g;
            let normal = ground_normal(ground, particle.position.x, particle.position.y, 1.0);
            let into = particle.velocity.dot(normal);
            if into < 0.0 {
                particle.velocity -= normal * into;
            }
        }
        // Sedimentation while moving, σ_pyr as a density decrement rate (kg/m³/s).
        let moving = particle.velocity.length() > p.settle_speed;
        if moving {
            let loss = (p.sigma_pyr * volume * h).min((particle.mass - MIN_DENSITY * volume).max(0.0));
            particle.mass -= loss;
            report.deposited += loss;
        }
    }
    report.substeps = n;
    report.deposit_at = particle.position.truncate();
    // Air density of the last substep's start (≤ max_travel away: a fraction of a percent).
    report.buoyant = particle.density() < air_density;
    if particle.grounded
        && particle.velocity.length() <= p.settle_speed
        && particle.density() >= MIN_DENSITY
        && !report.buoyant
    {
        // At rest on the ground: it becomes deposit.
        report.deposited += particle.mass;
        particle.mass = 0.0;
        report.settled = true;
    }
    report
}

/// Buoyant particles gathered into clusters.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Clusters {
    /// Indices into the particle list, per cluster, each sorted.
    pub members: Vec<Vec<usize>>,
    /// The seed of each cluster (every member is within the radius of it).
    pub seeds: Vec<usize>,
    /// Distance checks made (for the complexity test).
    pub pair_checks: u64,
}

/// Groups the particles lighter than the air around them (`buoyant[i]`) into clusters: seeds
/// are taken in index order; a seed collects every still-free buoyant particle within
/// `radius` of it; groups of at least `min_count` become clusters.
///
/// Neighbours come from a dense horizontal grid over the buoyant particles' bounding box,
/// filled by a counting sort (cells of at least 2·radius, so a query disc touches at most 2×2
/// cells) that also copies the positions into cell order, so a query reads two contiguous runs
/// of memory: O(N) for bounded density, no hashing. The grid is coarsened if the particles are
/// so spread out that it would have more than 4 cells per particle. Written by hand: the
/// grouping rule is the thesis', and a k-d tree crate would not make it simpler.
/// Deterministic: each cell lists its particles in index order.
pub fn find_clusters(particles: &[Particle], buoyant: &[bool], radius: f64, min_count: usize) -> Clusters {
    let mut out = Clusters::default();
    let eligible = |i: usize| buoyant.get(i).copied().unwrap_or(false) && particles[i].position.is_finite();
    let live: Vec<usize> = (0..particles.len()).filter(|&i| eligible(i)).collect();
    if live.is_empty() {
        return out;
    }
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for &i in &live {
        let p = particles[i].position.truncate();
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let extent = (hi - lo).max(DVec2::splat(1e-9));
    let max_cells = 4.0 * live.len() as f64 + 64.0;
    let mut cell = (2.0 * radius).max(1e-6);
    if (extent.x / cell + 2.0) * (extent.y / cell + 2.0) > max_cells {
        cell = cell.max((extent.x * extent.y / max_cells).sqrt()).max(extent.max_element() / max_cells);
    }
    let nx = ((extent.x / cell).floor() as usize + 2).max(2);
    let ny = ((extent.y / cell).floor() as usize + 2).max(2);
    let cell_of = |p: DVec3| {
        let f = (p.truncate() - lo) / cell;
        (f.y as usize).min(ny - 1) * nx + (f.x as usize).min(nx - 1)
    };
    // Counting sort of the live particles by cell (stable: index order within a cell), their
    // positions copied in that order: a query reads its cells' particles from one contiguous
    // run of memory instead of jumping through the particle list.
    let cells: Vec<u32> = live.iter().map(|&i| cell_of(particles[i].position) as u32).collect();
    let mut start = vec![0u32; nx * ny + 1];
    for &c in &cells {
        start[c as usize + 1] += 1;
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    let mut fill = start.clone();
    // Per slot of the sorted order: position and particle index; per live particle: its slot.
    let (mut at, mut index) = (vec![DVec3::ZERO; live.len()], vec![0u32; live.len()]);
    let mut slot_of = vec![0u32; live.len()];
    for (n, (&i, &c)) in live.iter().zip(&cells).enumerate() {
        let s = fill[c as usize] as usize;
        fill[c as usize] += 1;
        at[s] = particles[i].position;
        index[s] = i as u32;
        slot_of[n] = s as u32;
    }
    // Taken, by slot.
    let mut taken = vec![false; live.len()];
    let r2 = radius * radius;
    let mut group = Vec::new();
    for (n, &seed) in live.iter().enumerate() {
        let s = slot_of[n] as usize;
        if taken[s] {
            continue;
        }
        let c = at[s];
        // The 2×2 cells that contain the disc of `radius` around c (cell ≥ 2·radius).
        let f = (c.truncate() - lo) / cell - 0.5;
        let i0 = (f.x.floor().max(0.0) as usize).min(nx - 2);
        let j0 = (f.y.floor().max(0.0) as usize).min(ny - 2);
        group.clear();
        for j in j0..j0 + 2 {
            let row = j * nx;
            let (a, b) = (start[row + i0] as usize, start[row + i0 + 2] as usize);
            for t in a..b {
                if taken[t] {
                    continue;
                }
                out.pair_checks += 1;
                if at[t].distance_squared(c) <= r2 {
                    group.push(t);
                }
            }
        }
        if group.len() >= min_count.max(1) {
            let mut members: Vec<usize> = group.iter().map(|&t| index[t] as usize).collect();
            members.sort_unstable();
            for &t in &group {
                taken[t] = true;
            }
            out.members.push(members);
            out.seeds.push(seed);
        }
    }
    out
}

/// A secondary column (§3.6): a new rising slice at the cluster's centroid with the cluster's
/// averaged density ρ̄ = Σm / ΣV, mass-weighted velocity and temperature, and the size that
/// holds the cluster's mass at that density, `r = ∛(Σm / (ρ̄ π))` (slice volume π r³). Mass
/// and momentum are conserved, the vertical part too: a flow running down a slope hands its
/// downward velocity to the column, which sinks until its buoyancy turns it round (the slice
/// model only calls a slice's top an apex once it has been rising).
pub fn secondary_column(particles: &[Particle], members: &[usize]) -> Option<Slice> {
    let (mut m, mut vol, mut mv, mut mt, mut c) = (0.0, 0.0, DVec3::ZERO, 0.0, DVec3::ZERO);
    for &i in members {
        let p = particles.get(i)?;
        m += p.mass;
        vol += p.volume();
        mv += p.velocity * p.mass;
        mt += p.temperature * p.mass;
        c += p.position * p.mass;
    }
    if !(m > 0.0 && vol > 0.0) {
        return None;
    }
    let rho = m / vol;
    let r = (m / (rho * std::f64::consts::PI)).cbrt();
    Some(Slice {
        r,
        length: r,
        position: c / m,
        velocity: mv / m,
        density: rho,
        temperature: mt / m,
        mass: m,
        // Lighter than the air by construction: a buoyant plume from the start.
        phase: Phase::Buoyant,
        age: 0.0,
        apex: (c / m).z,
        buoyant_from: Some((c / m).z),
        neutral_altitude: None,
        neutral_speed: None,
        initial_mass: m,
        entrained_mass: 0.0,
        sedimented_mass: 0.0,
        // The ash of pyroclastic flows is booked by the pyroclastic budget (deposited,
        // lifted); a secondary column carries no separate solid or water account.
        solid_mass: 0.0,
        water_mass: 0.0,
    })
}
