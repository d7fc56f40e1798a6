//! Headless scenario runner: builds a scenario, applies its timeline, steps it and gathers
//! the summary the CLI writes as `summary.json`.

use std::collections::BTreeMap;
use std::time::Instant;

use bevy::math::Vec2;
use serde::Serialize;
use volcano_core::{ConfigError, LandCover};

use super::clouds::{CloudForm, cloud_cover};
use super::fields::AtmosphereState;
use super::params::AtmosphereParams;
use super::scenario::{Diagnostic, Event, EventAction, FieldKind, WeatherScenario, add_noise, add_spot};
use super::step::{Workspace, check_dt, step};
use super::volume::coherent_forms;

/// What a scenario run measured; serialised as the CLI's `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AtmosphereSummary {
    /// Scenario name.
    pub scenario: String,
    /// Cells per side.
    pub grid: usize,
    /// Layer count.
    pub layers: usize,
    /// Steps run.
    pub steps: u32,
    /// Step length (s).
    pub dt: f64,
    /// Largest |total water − initial| / initial over the run (vapour + condensed + ground,
    /// precipitation included in the ground).
    pub water_total_rel_error: f64,
    /// Same, relative to the water in the air only (a stricter figure when the sea holds
    /// most of the water).
    pub water_air_rel_error: f64,
    /// Largest |∇·V − target| after projection over all steps and layers (1/s).
    pub max_divergence_after_projection: f64,
    /// Largest ratio of that error after/before the projection in one step.
    pub divergence_error_ratio: f64,
    /// Mean multigrid residual reduction factor per V-cycle.
    pub multigrid_residual_reduction: f64,
    /// Fraction of cloudy free cells per layer at the end.
    pub cloud_cover: Vec<f64>,
    /// Cloudy cells per cloud form at the end, after the k-means++ coherence pass.
    pub cloud_forms: BTreeMap<String, usize>,
    /// Mean wall time per step (ms).
    pub step_ms: f64,
    /// Water precipitated to the ground (g).
    pub precipitated_g: f64,
    /// Whether every field stayed finite and every amount non-negative without the guard
    /// ([`guard::repair`](super::guard::repair)) having to repair a cell (checked each step).
    pub valid: bool,
    /// Largest |wind| through a closed face (rock on one side) after the last step's
    /// projection (m/s); zero when the projection respects the terrain.
    pub max_solid_face_flux_m_s: f64,
    /// Largest realised |D| over the run (m/s).
    pub max_vertical_speed_m_s: f64,
    /// Largest |C + U| over the run (m/s), before the exponential of eq. (4.6) limited it.
    pub max_unlimited_vertical_speed_m_s: f64,
    /// Limiter: cell-steps where that exponential took more than 10 % off D.
    pub vertical_limited_cells: u64,
    /// Limiter: layer-steps whose conservative transport hit the substep cap (donor limiter).
    pub flux_limited_layer_steps: u32,
    /// Mean onshore wind of the lowest layer over the coast, 11:30–12:30 local (m/s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub onshore_wind_noon_m_s: Option<f64>,
    /// Same, 02:30–03:30 local (m/s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub onshore_wind_night_m_s: Option<f64>,
    /// Mean vertical velocity above the lowest free layer on windward slopes (m/s), second
    /// half of the run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub windward_updraft_m_s: Option<f64>,
    /// Same on lee slopes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lee_updraft_m_s: Option<f64>,
    /// Fraction of windward columns with cloud in any layer, second half of the run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub windward_cloud_cover: Option<f64>,
    /// Same on lee slopes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lee_cloud_cover: Option<f64>,
}

/// A finished run: the final state and its summary.
#[derive(Debug, Clone)]
pub struct ScenarioRun {
    /// State after the last step.
    pub state: AtmosphereState,
    /// Measurements.
    pub summary: AtmosphereSummary,
}

/// Runs built-in scenario `name` (`convection`, `island`, `sea-breeze`, `orographic`,
/// `mixed`) for `steps` steps of `dt` s on a `grid²` grid; `None` takes the scenario's own.
pub fn run_scenario(
    name: &str,
    steps: Option<u32>,
    dt: Option<f64>,
    grid: Option<usize>,
) -> Result<AtmosphereSummary, ConfigError> {
    Ok(run(&WeatherScenario::builtin(name)?, steps, dt, grid)?.summary)
}

/// Applies one timeline event to the state.
pub fn apply_event(state: &mut AtmosphereState, event: &Event) {
    let g = state.grid;
    let Some(layer) = state.layers.get_mut(event.layer) else {
        return;
    };
    match &event.action {
        EventAction::SetWind(u, v) => {
            layer.wind = Vec2::new(*u, *v);
            layer.u.data_mut().fill(*u);
            layer.v.data_mut().fill(*v);
        }
        EventAction::Turbulence(nz) => {
            add_noise(g, layer.u.data_mut(), nz, 0);
            add_noise(g, layer.v.data_mut(), nz, 1);
        }
        EventAction::Paint(field, spot) => {
            let mut delta = vec![0.0; g.cells()];
            add_spot(g, &mut delta, spot);
            apply_delta(layer, *field, &delta, false);
        }
        EventAction::Band { field, x_from_m, x_to_m, value } => {
            let delta: Vec<f64> = (0..g.cells())
                .map(|k| {
                    let x = g.centre(k).0;
                    if x >= *x_from_m && x < *x_to_m { *value } else { f64::NAN }
                })
                .collect();
            apply_delta(layer, *field, &delta, true);
        }
    }
}

/// Adds `delta` to a field (or sets it where `set` and delta is not NaN), keeping amounts ≥ 0
/// and nothing inside terrain.
fn apply_delta(layer: &mut super::fields::LayerFields, field: FieldKind, delta: &[f64], set: bool) {
    let sigma = layer.sigma.data().to_vec();
    let combine = |old: f64, d: f64| if set { if d.is_nan() { old } else { d } } else { old + d };
    match field {
        FieldKind::Temperature => {
            for (t, d) in layer.t.data_mut().iter_mut().zip(delta) {
                *t = combine(*t as f64, *d).clamp(150.0, 350.0) as f32;
            }
        }
        FieldKind::Humidity | FieldKind::Water | FieldKind::Ash => {
            let g = match field {
                FieldKind::Humidity => &mut layer.h,
                FieldKind::Water => &mut layer.w,
                _ => &mut layer.ash,
            };
            for ((q, d), s) in g.data_mut().iter_mut().zip(delta).zip(&sigma) {
                if *s > 0.0 {
                    *q = combine(*q, *d).max(0.0);
                }
            }
        }
    }
}

/// Runs a scenario (validated) with optional overrides.
pub fn run(
    scenario: &WeatherScenario,
    steps: Option<u32>,
    dt: Option<f64>,
    grid: Option<usize>,
) -> Result<ScenarioRun, ConfigError> {
    let steps = steps.unwrap_or(scenario.steps);
    let dt = check_dt(dt.unwrap_or(scenario.dt))?;
    let mut state = scenario.build(grid)?;
    let params: AtmosphereParams = scenario.params.clone();
    let mut work = Workspace::new(&state)?;
    let shore = scenario.diagnostics.contains(&Diagnostic::ShoreBreeze).then(|| ShoreProbe::new(&state));
    let slopes = scenario.diagnostics.contains(&Diagnostic::Slopes).then(|| SlopeProbe::new(&state));
    let water0 = state.water_total();
    let air0 = state.air_water().max(1e-300);
    let mut events: Vec<&Event> = scenario.events.iter().collect();
    events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    let mut next_event = 0;
    let (mut water_err, mut air_err, mut div_max, mut div_ratio, mut red_sum) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64, 0.0);
    let (mut noon, mut night) = (Mean::default(), Mean::default());
    let (mut ww, mut lw, mut wc, mut lc) =
        (Mean::default(), Mean::default(), Mean::default(), Mean::default());
    let mut valid = true;
    let mut elapsed = 0.0;
    let mut solid_face = 0.0;
    let (mut max_d, mut unlimited, mut v_limited, mut f_limited) = (0.0f64, 0.0f64, 0u64, 0u32);
    for s in 0..steps {
        while next_event < events.len() && events[next_event].at_s <= state.time_s {
            apply_event(&mut state, events[next_event]);
            next_event += 1;
        }
        let t0 = Instant::now();
        let rep = step(&mut state, &params, &mut work, dt)?;
        elapsed += t0.elapsed().as_secs_f64();
        let total = state.water_total();
        water_err = water_err.max(((total - water0) / water0.max(1e-300)).abs());
        air_err = air_err.max(((total - water0) / air0).abs());
        div_max = div_max.max(rep.max_divergence_error);
        if rep.max_initial_divergence_error > 0.0 {
            div_ratio = div_ratio.max(rep.max_divergence_error / rep.max_initial_divergence_error);
        }
        red_sum += rep.residual_reduction;
        solid_face = rep.max_solid_face_flux_m_s;
        max_d = max_d.max(rep.max_vertical_speed);
        unlimited = unlimited.max(rep.max_unlimited_vertical_speed);
        v_limited += rep.vertical_limited_cells;
        f_limited += rep.flux_limited_layers;
        valid &= state.is_valid() && !rep.repaired.any();
        let hour = state.local_hour();
        if let Some(p) = &shore {
            if (11.5..12.5).contains(&hour) {
                noon.add(p.onshore(&state));
            }
            if (2.5..3.5).contains(&hour) {
                night.add(p.onshore(&state));
            }
        }
        if let Some(p) = &slopes
            && s >= steps / 2
        {
            let (a, b, c, d) = p.measure(&state, params.cloud_threshold);
            ww.add(a);
            lw.add(b);
            wc.add(c);
            lc.add(d);
        }
    }
    let summary = AtmosphereSummary {
        scenario: scenario.name.clone(),
        grid: state.grid.n,
        layers: state.layers.len(),
        steps,
        dt,
        water_total_rel_error: water_err,
        water_air_rel_error: air_err,
        max_divergence_after_projection: div_max,
        divergence_error_ratio: div_ratio,
        multigrid_residual_reduction: if steps > 0 { red_sum / steps as f64 } else { 0.0 },
        cloud_cover: cloud_cover(&state, params.cloud_threshold),
        cloud_forms: count_forms(&coherent_forms(&state, params.cloud_threshold, 8, 0.3, 0)),
        step_ms: if steps > 0 { 1e3 * elapsed / steps as f64 } else { 0.0 },
        precipitated_g: state.precipitated,
        valid,
        max_solid_face_flux_m_s: solid_face,
        max_vertical_speed_m_s: max_d,
        max_unlimited_vertical_speed_m_s: unlimited,
        vertical_limited_cells: v_limited,
        flux_limited_layer_steps: f_limited,
        onshore_wind_noon_m_s: noon.get(),
        onshore_wind_night_m_s: night.get(),
        windward_updraft_m_s: ww.get(),
        lee_updraft_m_s: lw.get(),
        windward_cloud_cover: wc.get(),
        lee_cloud_cover: lc.get(),
    };
    Ok(ScenarioRun { state, summary })
}

/// Cells per form, keyed by the form's name.
fn count_forms(forms: &[Vec<Option<CloudForm>>]) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for f in forms.iter().flatten().flatten() {
        *counts.entry(format!("{f:?}")).or_insert(0) += 1;
    }
    counts
}

#[derive(Debug, Default)]
struct Mean {
    sum: f64,
    count: usize,
}
impl Mean {
    fn add(&mut self, x: f64) {
        if x.is_finite() {
            self.sum += x;
            self.count += 1;
        }
    }
    fn get(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum / self.count as f64)
    }
}

/// Coastal cells and their onshore directions (toward land), from the land mask smoothed
/// over ±3 cells.
struct ShoreProbe {
    cells: Vec<(usize, f64, f64)>,
}

impl ShoreProbe {
    fn new(state: &AtmosphereState) -> Self {
        let n = state.grid.n;
        let land: Vec<f64> = state
            .ground
            .cover
            .data()
            .iter()
            .map(|&c| if c == LandCover::Water { 0.0 } else { 1.0 })
            .collect();
        let r = 3i64;
        let at =
            |i: i64, j: i64| land[(j.rem_euclid(n as i64) as usize) * n + i.rem_euclid(n as i64) as usize];
        let mut smooth = vec![0.0; n * n];
        for j in 0..n as i64 {
            for i in 0..n as i64 {
                let mut s = 0.0;
                for dj in -r..=r {
                    for di in -r..=r {
                        s += at(i + di, j + dj);
                    }
                }
                smooth[j as usize * n + i as usize] = s / ((2 * r + 1) * (2 * r + 1)) as f64;
            }
        }
        let sm =
            |i: i64, j: i64| smooth[(j.rem_euclid(n as i64) as usize) * n + i.rem_euclid(n as i64) as usize];
        let mut cells = Vec::new();
        for j in 0..n as i64 {
            for i in 0..n as i64 {
                let gx = sm(i + 1, j) - sm(i - 1, j);
                let gy = sm(i, j + 1) - sm(i, j - 1);
                let g = (gx * gx + gy * gy).sqrt();
                if g > 0.05 {
                    cells.push((j as usize * n + i as usize, gx / g, gy / g));
                }
            }
        }
        Self { cells }
    }

    /// Mean onshore component of layer 0's wind (cell-centred) over the coastal cells.
    fn onshore(&self, state: &AtmosphereState) -> f64 {
        let n = state.grid.n;
        let l = &state.layers[0];
        let (u, v) = (l.u.data(), l.v.data());
        let mut s = 0.0;
        for &(k, nx, ny) in &self.cells {
            let (i, j) = (k % n, k / n);
            let uc = 0.5 * (u[k] + u[j * n + (i + 1) % n]) as f64;
            let vc = 0.5 * (v[k] + v[((j + 1) % n) * n + i]) as f64;
            s += uc * nx + vc * ny;
        }
        if self.cells.is_empty() { f64::NAN } else { s / self.cells.len() as f64 }
    }
}

/// Windward and lee slope cells (slope > 2 %, facing toward or away from the lowest layer's
/// prevailing wind within 45°).
struct SlopeProbe {
    windward: Vec<usize>,
    lee: Vec<usize>,
}

impl SlopeProbe {
    fn new(state: &AtmosphereState) -> Self {
        let n = state.grid.n;
        let dx = state.grid.dx;
        let h = state.ground.height.data();
        let wind = state.layers[0].wind;
        let (mut windward, mut lee) = (Vec::new(), Vec::new());
        for j in 0..n {
            for i in 0..n {
                let gx = (h[j * n + (i + 1) % n] - h[j * n + (i + n - 1) % n]) as f64 / (2.0 * dx);
                let gy = (h[((j + 1) % n) * n + i] - h[((j + n - 1) % n) * n + i]) as f64 / (2.0 * dx);
                let slope = (gx * gx + gy * gy).sqrt();
                if slope < 0.02 {
                    continue;
                }
                // Slopes facing the wind (or turned away from it) within 45°.
                let along =
                    (gx * wind.x as f64 + gy * wind.y as f64) / (slope * wind.length().max(1e-6) as f64);
                if along > std::f64::consts::FRAC_1_SQRT_2 {
                    windward.push(j * n + i);
                } else if along < -std::f64::consts::FRAC_1_SQRT_2 {
                    lee.push(j * n + i);
                }
            }
        }
        Self { windward, lee }
    }

    /// (windward mean D, lee mean D, windward cloud fraction, lee cloud fraction).
    fn measure(&self, state: &AtmosphereState, threshold: f64) -> (f64, f64, f64, f64) {
        let d_at = |k: usize| -> f64 {
            let l = state.ground.lowest[k];
            if l == u8::MAX { 0.0 } else { state.layers[l as usize].d.data()[k] as f64 }
        };
        let cloudy = |k: usize| {
            state.layers.iter().any(|l| l.w.data()[k] > threshold && l.sigma.data()[k] > 0.0) as u8 as f64
        };
        let mean = |cells: &[usize], f: &dyn Fn(usize) -> f64| {
            if cells.is_empty() {
                f64::NAN
            } else {
                cells.iter().map(|&k| f(k)).sum::<f64>() / cells.len() as f64
            }
        };
        (
            mean(&self.windward, &d_at),
            mean(&self.lee, &d_at),
            mean(&self.windward, &cloudy),
            mean(&self.lee, &cloudy),
        )
    }
}
