//! Headless scenarios (thesis Fig 5.10 terrains, plus `incline` and `spread` with analytic
//! references) and the summary the CLI writes as `summary.json`.

pub mod effusive;
pub mod terrains;

use std::str::FromStr;

use bevy::math::Vec2;
use serde::{Deserialize, Serialize};
use volcano_core::ConfigError;
use volcano_core::error::{in_range, positive};

use crate::model::breakout::{Breakout, BreakoutState};
use crate::model::field::{Edge, Edges, FlowField, Source};
use crate::model::folds::{FoldParams, FoldSystem};
use crate::model::params::{GRAVITY, LavaParams, ViscosityModel};
use crate::model::surface::SurfaceState;
use crate::model::{DomainReport, LayersMut, step_layers};

/// Which scenario to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ScenarioKind {
    /// Fig 5.10 left: slope with a long obstacle. At the default 1 m³/s the lava (cooling
    /// through its crust, near the liquidus) drains sideways along the face about as fast as
    /// it arrives: no breakouts up to 480 s. At 3 m³/s more arrives than flows around, the
    /// pond inflates under a crust made rigid by compression and tears in front of the face
    /// (`tests/folds.rs`, breakouts).
    #[default]
    Obstacle,
    /// Fig 5.10 middle: slope with a small obstacle that splits the flow.
    Split,
    /// Fig 5.10 right: slope with a canyon.
    Canyon,
    /// The same slope and source with nothing on it (reference for the three above).
    Slope,
    /// Uniform slope fed by a line source across its full width, periodic sides.
    Incline,
    /// A fixed volume released as a cylinder on flat ground.
    Spread,
}

impl ScenarioKind {
    /// Names accepted by [`FromStr`].
    pub const NAMES: [&'static str; 6] = ["obstacle", "split", "canyon", "slope", "incline", "spread"];
}

impl FromStr for ScenarioKind {
    type Err = ConfigError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "obstacle" => Self::Obstacle,
            "split" => Self::Split,
            "canyon" => Self::Canyon,
            "slope" => Self::Slope,
            "incline" => Self::Incline,
            "spread" => Self::Spread,
            _ => {
                return Err(ConfigError::UnknownName {
                    kind: "lava scenario",
                    name: s.into(),
                    known: Self::NAMES.join(", "),
                });
            }
        })
    }
}

/// Options of a scenario run (the CLI flags).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScenarioConfig {
    /// Scenario.
    pub kind: ScenarioKind,
    /// Simulated seconds.
    pub seconds: f64,
    /// Constant viscosity (Pa·s); `None` = FLOWGO VFT (or 1000 Pa·s when isothermal).
    pub viscosity: Option<f64>,
    /// Constant viscosity and no cooling.
    pub isothermal: bool,
    /// `spread`: released volume (m³).
    pub volume: f64,
    /// `incline`: m³/s per metre of width; other slopes: m³/s of the point source.
    pub rate: f64,
    /// Slope (degrees; `incline` ≤ 10°).
    pub slope_deg: f64,
    /// Cells per side (`incline`: cells along the slope; its width is 8 periodic cells).
    pub grid: usize,
    /// Cell size (m).
    pub cell: f64,
    /// `spread`: radius of the released cylinder (m).
    pub initial_radius: f64,
    /// Domain step (s), thesis Table 5.2: 0.02.
    pub dt: f64,
}

impl ScenarioConfig {
    /// Defaults for `kind`.
    pub fn new(kind: ScenarioKind) -> Self {
        let (seconds, rate, slope) = match kind {
            ScenarioKind::Incline => (400.0, 0.05, 5.0),
            ScenarioKind::Spread => (300.0, 0.0, 0.0),
            _ => (240.0, 1.0, 3.0),
        };
        Self {
            kind,
            seconds,
            viscosity: None,
            isothermal: false,
            volume: 20.0,
            rate,
            slope_deg: slope,
            grid: 128,
            cell: 0.5,
            initial_radius: 2.0,
            dt: 0.02,
        }
    }

    /// Checks every option (clear error, no panic).
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("seconds", self.seconds, 0.0, 1e6)?;
        if let Some(eta) = self.viscosity {
            in_range("viscosity", eta, 1e-2, 1e12)?;
        }
        positive("volume", self.volume)?;
        in_range("rate", self.rate, 0.0, 1e4)?;
        let max_slope = if self.kind == ScenarioKind::Incline { 10.0 } else { 45.0 };
        in_range("slope_deg", self.slope_deg, 0.0, max_slope)?;
        in_range("grid", self.grid as f64, 8.0, 4096.0)?;
        in_range("cell", self.cell, 0.01, 100.0)?;
        positive("initial_radius", self.initial_radius)?;
        in_range("dt", self.dt, 1e-5, 1.0)?;
        Ok(())
    }

    /// Lava parameters this configuration implies.
    pub fn params(&self) -> Result<LavaParams, ConfigError> {
        let p = match (self.isothermal, self.viscosity) {
            (true, eta) => LavaParams::isothermal(eta.unwrap_or(1000.0))?,
            (false, Some(eta)) => {
                LavaParams { viscosity: ViscosityModel::Constant(eta), ..LavaParams::default() }
            }
            (false, None) => LavaParams::default(),
        };
        p.validate()?;
        Ok(p)
    }
}

/// Analytic references for `incline` and `spread`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Analytic {
    /// Jeffreys mean velocity `ρ g h² sinθ/(3η)` at the *measured* slope-normal thickness.
    pub mean_velocity_m_s: Option<f64>,
    /// Jeffreys normal thickness `(3ηq/(ρ g sinθ))^{1/3}` for the fed rate q.
    pub thickness_m: Option<f64>,
    /// Huppert (1982) front radius `0.894 (ρ g V³ t/(3η))^{1/8}`.
    pub front_radius_m: Option<f64>,
}

/// What a scenario run measured (`summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LavaSummary {
    /// Scenario name.
    pub scenario: ScenarioKind,
    /// Simulated seconds.
    pub seconds: f64,
    /// Domain steps.
    pub steps: u64,
    /// Mean and largest flow substeps per step.
    pub mean_substeps: f64,
    /// Largest substeps in one step.
    pub max_substeps: u32,
    /// Steps where the substep cap slowed the flow.
    pub mobility_capped_steps: u64,
    /// Cells the guard reset and particles it removed because their state was no longer
    /// finite (0 in a healthy run).
    pub faulted: u64,
    /// Liquid lava removed with them (m³).
    pub faulted_volume_m3: f64,
    /// Steps that ended with the folds at `FoldParams::max_particles` (no new folds).
    pub fold_cap_steps: u64,
    /// Liquid lava on the grid (m³).
    pub lava_volume_m3: f64,
    /// Emitted by sources (m³).
    pub source_volume_m3: f64,
    /// Placed initially (m³).
    pub initial_volume_m3: f64,
    /// Frozen into the ground (m³).
    pub solidified_volume_m3: f64,
    /// Left through open edges (m³).
    pub outflow_volume_m3: f64,
    /// Budget closure error, relative.
    pub volume_error_rel: f64,
    /// Farthest lava (thicker than `min_thickness`) from the source along the slope (m).
    pub front_distance_m: f64,
    /// Radius of the disc with the lava-covered area (m) (spread).
    pub front_radius_m: f64,
    /// Mean along-slope speed (m/s): in the steady region for `incline`, else over the flow.
    pub mean_velocity_m_s: f64,
    /// Mean slope-normal thickness (m): steady region for `incline`, else over the flow.
    pub thickness_m: f64,
    /// Largest crust (m).
    pub max_crust_m: f64,
    /// Mean crust over the flow (m).
    pub mean_crust_m: f64,
    /// Folds (layer 3).
    pub folds: Option<u64>,
    /// Fold particles (layer 3).
    pub fold_particles: Option<u64>,
    /// Fold particles overridden by other folds and removed so far.
    pub buried_fold_particles: Option<u64>,
    /// Most fold particles whose centres fall in one grid cell.
    pub max_fold_particles_per_cell: Option<u64>,
    /// Crust tears (breakouts) so far.
    pub breakouts: Option<u64>,
    /// Analytic references where they exist.
    pub analytic: Analytic,
}

/// A built scenario: state, sources and parameters, ready to step.
#[derive(Debug, Clone)]
pub struct LavaScenario {
    /// The configuration it was built from.
    pub config: ScenarioConfig,
    /// Lava parameters.
    pub params: LavaParams,
    /// Flow state.
    pub field: FlowField,
    /// Surface (crust) state.
    pub surface: SurfaceState,
    /// Fold parameters.
    pub fold_params: FoldParams,
    /// Folds.
    pub folds: FoldSystem,
    /// Crust drag and breakouts.
    pub breakouts: BreakoutState,
    /// Every crust tear so far, in order (where and how much the lava had inflated).
    pub breakout_log: Vec<Breakout>,
    /// Sources.
    pub sources: Vec<Source>,
    /// World position of the source (or release centre).
    pub origin: Vec2,
    steps: u64,
    substeps: u64,
    max_substeps: u32,
    capped: u64,
    repaired: crate::model::guard::LavaRepair,
    fold_cap_steps: u64,
}

impl LavaScenario {
    /// Builds the terrain, field, sources and parameters of `config`.
    pub fn build(config: &ScenarioConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let params = config.params()?;
        let (n, dx) = (config.grid, config.cell);
        let open = Edges { west: Edge::Open, east: Edge::Open, south: Edge::Wall, north: Edge::Open };
        let hot = params.liquidus;
        let (field, sources, origin) = match config.kind {
            ScenarioKind::Incline => {
                let g = terrains::incline(8, n, dx, config.slope_deg)?;
                let edges = Edges {
                    west: Edge::Periodic,
                    east: Edge::Periodic,
                    south: Edge::Wall,
                    north: Edge::Open,
                };
                let field = FlowField::new(g, edges, params.air_temperature)?;
                let src = field.row_source(1, config.rate, hot)?;
                let origin = field.ground().position(0, 1);
                (field, vec![src], origin)
            }
            ScenarioKind::Spread => {
                let mut field =
                    FlowField::new(terrains::flat(n, dx)?, Edges::default(), params.air_temperature)?;
                let c = field.ground().position(n / 2, n / 2);
                field.place_volume(c, config.initial_radius, config.volume, hot)?;
                (field, vec![], c)
            }
            kind => {
                let g = terrains::scenario_ground(kind, n, dx, config.slope_deg)?;
                let field = FlowField::new(g, open, params.air_temperature)?;
                let c = field.ground().position(n / 2, n / 10);
                let src = field.point_source(c, 1.5 * dx.max(0.5), config.rate, hot)?;
                (field, vec![src], c)
            }
        };
        let surface = SurfaceState::new(field.nx(), field.ny());
        let n_cells = field.nx() * field.ny();
        Ok(Self {
            config: config.clone(),
            params,
            field,
            surface,
            fold_params: FoldParams::default(),
            folds: FoldSystem::new(1),
            breakouts: BreakoutState::new(n_cells),
            breakout_log: Vec::new(),
            sources,
            origin,
            steps: 0,
            substeps: 0,
            max_substeps: 0,
            capped: 0,
            repaired: Default::default(),
            fold_cap_steps: 0,
        })
    }

    /// Advances one domain step: flow and cooling under the crust, surface (crust), breakouts,
    /// folds, and the folds' thickening of the crust under them.
    pub fn step(&mut self) {
        let layers = LayersMut {
            flow: &mut self.field,
            surface: &mut self.surface,
            folds: &mut self.folds,
            breakouts: &mut self.breakouts,
        };
        let DomainReport { flow: r, breakouts: tears, repaired, folds_at_cap } =
            step_layers(layers, &self.params, &self.fold_params, &self.sources, self.config.dt);
        self.breakout_log.extend(tears);
        self.repaired += repaired;
        self.fold_cap_steps += u64::from(folds_at_cap);
        self.steps += 1;
        self.substeps += r.substeps as u64;
        self.max_substeps = self.max_substeps.max(r.substeps);
        self.capped += r.mobility_capped as u64;
    }

    /// Runs until `seconds` of simulated time have passed.
    pub fn run_until(&mut self, seconds: f64) {
        let n = ((seconds - self.field.time()) / self.config.dt).round().max(0.0) as u64;
        for _ in 0..n {
            self.step();
        }
    }

    /// Most fold particles whose centres fall in one grid cell (how densely they pile up).
    pub fn max_fold_particles_per_cell(&self) -> u64 {
        let mut counts = vec![0u64; self.field.nx() * self.field.ny()];
        for q in &self.folds.particles {
            if let Some((i, j)) = self.field.cell_at(Vec2::new(q.pos.x as f32, q.pos.y as f32)) {
                counts[j * self.field.nx() + i] += 1;
            }
        }
        counts.into_iter().max().unwrap_or(0)
    }

    /// Measures the current state.
    pub fn summary(&self) -> LavaSummary {
        let c = &self.config;
        let f = &self.field;
        let p = &self.params;
        let (nx, ny, dx) = (f.nx(), f.ny(), f.cell());
        let h = f.thickness().data();
        let (u, v) = f.velocity();
        let (u, v) = (u.data(), v.data());
        let b = f.budget();
        let theta = c.slope_deg.to_radians();
        let wet: Vec<usize> = (0..nx * ny).filter(|&k| h[k] >= p.min_thickness).collect();
        let area = wet.len() as f64 * dx * dx;
        let origin_cell = f.cell_at(self.origin).unwrap_or((0, 0));
        let front_distance = wet
            .iter()
            .map(|&k| {
                let (i, j) = (k % nx, k / nx);
                if c.kind == ScenarioKind::Spread {
                    let (di, dj) = (i as f64 - origin_cell.0 as f64, j as f64 - origin_cell.1 as f64);
                    di.hypot(dj) * dx
                } else {
                    (j as f64 - origin_cell.1 as f64) * dx / theta.cos()
                }
            })
            .fold(0.0, f64::max);
        // Region for speed/thickness: incline steady band (40–70 % of the length) or the flow.
        let region: Vec<usize> = if c.kind == ScenarioKind::Incline {
            let (j0, j1) = ((ny as f64 * 0.4) as usize, (ny as f64 * 0.7) as usize);
            wet.iter().copied().filter(|&k| (j0..j1).contains(&(k / nx))).collect()
        } else {
            wet.clone()
        };
        let nreg = region.len().max(1) as f64;
        let thickness = region.iter().map(|&k| h[k]).sum::<f64>() / nreg * theta.cos();
        let speed = region.iter().map(|&k| u[k].hypot(v[k])).sum::<f64>() / nreg / theta.cos();
        let (max_crust, mean_crust) = self.surface.crust_stats(f, p.min_thickness);
        let eta = match p.viscosity {
            ViscosityModel::Constant(eta) => Some(eta),
            _ => None,
        };
        let rho_g = p.density * GRAVITY;
        let analytic = match (c.kind, eta) {
            (ScenarioKind::Incline, Some(eta)) if theta > 0.0 => Analytic {
                mean_velocity_m_s: Some(jeffreys_velocity(rho_g, eta, thickness, theta)),
                thickness_m: Some((3.0 * eta * c.rate / (rho_g * theta.sin())).cbrt()),
                front_radius_m: None,
            },
            (ScenarioKind::Spread, Some(eta)) => Analytic {
                front_radius_m: Some(huppert_radius(rho_g, eta, c.volume, f.time())),
                ..Default::default()
            },
            _ => Analytic::default(),
        };
        LavaSummary {
            scenario: c.kind,
            seconds: f.time(),
            steps: self.steps,
            mean_substeps: self.substeps as f64 / self.steps.max(1) as f64,
            max_substeps: self.max_substeps,
            mobility_capped_steps: self.capped,
            faulted: self.repaired.cells + self.repaired.particles,
            faulted_volume_m3: b.faulted,
            fold_cap_steps: self.fold_cap_steps,
            lava_volume_m3: f.lava_volume(),
            source_volume_m3: b.sources,
            initial_volume_m3: b.initial,
            solidified_volume_m3: b.solidified,
            outflow_volume_m3: b.outflow,
            volume_error_rel: b.error_rel(f.lava_volume()),
            front_distance_m: front_distance,
            front_radius_m: (area / std::f64::consts::PI).sqrt(),
            mean_velocity_m_s: speed,
            thickness_m: thickness,
            max_crust_m: max_crust,
            mean_crust_m: mean_crust,
            folds: Some(self.folds.fold_count() as u64),
            fold_particles: Some(self.folds.particle_count() as u64),
            buried_fold_particles: Some(self.folds.buried_count()),
            max_fold_particles_per_cell: Some(self.max_fold_particles_per_cell()),
            breakouts: Some(self.breakouts.count),
            analytic,
        }
    }
}

/// Jeffreys (1925) mean velocity of a viscous sheet of slope-normal thickness `h` on an
/// incline θ: `u = ρ g h² sinθ/(3η)`.
pub fn jeffreys_velocity(rho_g: f64, eta: f64, h: f64, theta: f64) -> f64 {
    rho_g * h * h * theta.sin() / (3.0 * eta)
}

/// Huppert (1982) front radius of an axisymmetric viscous gravity current of fixed volume V:
/// `r_N = ξ_N (ρ g V³ t/(3η))^{1/8}` with `ξ_N = (2¹⁰/(3⁴ π³))^{1/8} ≈ 0.8942`.
pub fn huppert_radius(rho_g: f64, eta: f64, volume: f64, t: f64) -> f64 {
    let xi = (1024.0 / (81.0 * std::f64::consts::PI.powi(3))).powf(0.125);
    xi * (rho_g * volume.powi(3) * t / (3.0 * eta)).powf(0.125)
}

/// Builds and runs `config` for its `seconds`, returning the summary.
pub fn run_scenario(config: &ScenarioConfig) -> Result<LavaSummary, ConfigError> {
    let mut s = LavaScenario::build(config)?;
    s.run_until(config.seconds);
    Ok(s.summary())
}
