//! One weather step: ground exchange, phase change, vertical exchange, advection and
//! projection per layer, temperature relaxation.
//!
//! Layers run in parallel where they are independent (phase change, dynamics), and rows in
//! parallel inside a layer, all on Bevy's compute task pool through
//! [`volcano_core::parallel`] (fixed row bands, results in band order): the work and every
//! reduction are the same whatever the thread count, so results are deterministic.
//! Reductions over layers are summed in layer order.

use serde::Serialize;
use volcano_core::ConfigError;
use volcano_core::parallel;

use super::advection::{Transport, advect_conservative, advect_wind_and_temperature, apertures};
use super::ash::{AshReport, step_ash};
use super::fields::{AtmosphereState, LayerFields};
use super::guard::{self, AtmosphereRepair};
use super::params::AtmosphereParams;
use super::projection::{ProjectionReport, ProjectionWork, damp, project, relax_wind};
use super::sun::sun_position;
use super::terrain::ground_exchange;
use super::thermo::{phase_change_fraction, saturation_humidity_floor, wedge_air};
use super::vertical::{VerticalWork, divergence_target, precipitate, transfer, vertical_velocity_in};

/// Scratch buffers of one layer, kept between steps.
#[derive(Debug, Clone)]
pub struct LayerWork {
    projection: ProjectionWork,
    target: Vec<f64>,
    ax: Vec<f32>,
    ay: Vec<f32>,
    a: Vec<f32>,
    b: Vec<f32>,
    scratch: Vec<f32>,
    t_old: Vec<f32>,
    /// Face fluxes and donor limits of the conservative advection (3n²).
    src: Vec<f64>,
}

/// Scratch buffers of a whole atmosphere.
#[derive(Debug, Clone)]
pub struct Workspace {
    layers: Vec<LayerWork>,
    vertical: VerticalWork,
}

impl Workspace {
    /// Buffers matching `state`'s grid and layer count.
    pub fn new(state: &AtmosphereState) -> Result<Self, ConfigError> {
        let (n, dx) = (state.grid.n, state.grid.dx);
        let cells = n * n;
        let layers = (0..state.layers.len())
            .map(|_| {
                Ok(LayerWork {
                    projection: ProjectionWork::new(n, dx)?,
                    target: vec![0.0; cells],
                    ax: vec![0.0; cells],
                    ay: vec![0.0; cells],
                    a: vec![0.0; cells],
                    b: vec![0.0; cells],
                    scratch: vec![0.0; 3 * cells],
                    t_old: vec![0.0; cells],
                    src: vec![0.0; 3 * cells],
                })
            })
            .collect::<Result<Vec<_>, ConfigError>>()?;
        Ok(Self { layers, vertical: VerticalWork::default() })
    }

    fn matches(&self, state: &AtmosphereState) -> bool {
        self.layers.len() == state.layers.len()
            && self.layers.iter().all(|l| l.projection.poisson.n() == state.grid.n)
    }
}

/// What one step did (diagnostics for summaries and tests).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct WeatherStepReport {
    /// Largest |∇·V − target| after projection over all layers (1/s).
    pub max_divergence_error: f64,
    /// Largest |∇·V − target| before projection (1/s).
    pub max_initial_divergence_error: f64,
    /// Mean multigrid residual reduction per V-cycle over the layers' solves.
    pub residual_reduction: f64,
    /// V-cycles run, summed over layers.
    pub v_cycles: u32,
    /// max |D| realised (m/s), see `vertical::realised_velocity`.
    pub max_vertical_speed: f64,
    /// max |C + U| before the exponential of eq. (4.6) (m/s): what D would be without a limit.
    pub max_unlimited_vertical_speed: f64,
    /// Limiter: cells (over all interfaces) where the exponential of eq. (4.6) took more than
    /// 10 % off the vertical velocity (the step is long for the updraft there).
    pub vertical_limited_cells: u64,
    /// Grams precipitated this step.
    pub precipitated: f64,
    /// Grams evaporated from the ground this step (negative: dew).
    pub ground_evaporation: f64,
    /// Largest |wind| on a closed face (rock on one side) after the projection (m/s).
    pub max_solid_face_flux_m_s: f64,
    /// Limiter: layers whose conservative transport hit the substep cap and ran the donor
    /// limiter (exact, but the step is too long for the wind there).
    pub flux_limited_layers: u32,
    /// Largest number of flux substeps a layer needed.
    pub flux_substeps: u32,
    /// Wall time (ms) of the phases: ground, phase change, vertical exchange, dynamics.
    pub phase_ms: [f64; 4],
    /// Ash settled onto the ground and blown out through the rim this step.
    pub ash: AshReport,
    /// What the guard repaired before and after the step ([`guard::repair`]): zero in a
    /// healthy run.
    pub repaired: AtmosphereRepair,
}

/// Checks a step length: finite, in (0, 3600] s.
pub fn check_dt(dt: f64) -> Result<f64, ConfigError> {
    if dt.is_finite() && dt > 0.0 && dt <= 3600.0 {
        Ok(dt)
    } else {
        Err(ConfigError::InvalidParameter {
            name: "dt",
            value: dt,
            reason: "must be a finite time step in (0, 3600] s".into(),
        })
    }
}

/// Advances the atmosphere by `dt` seconds; [`guard::repair`] runs before and after.
pub fn step(
    state: &mut AtmosphereState,
    params: &AtmosphereParams,
    work: &mut Workspace,
    dt: f64,
) -> Result<WeatherStepReport, ConfigError> {
    check_dt(dt)?;
    params.validate()?;
    state.check_shape()?;
    state.check_clock()?;
    if !work.matches(state) {
        *work = Workspace::new(state)?;
    }
    // The guard runs before the step (state edited since, e.g. painted or reflected, never
    // reaches the model's clamps) and after it (nothing non-finite reaches the readers).
    let mut report = WeatherStepReport { repaired: guard::repair(state), ..Default::default() };

    let clock = std::time::Instant::now();
    let lap = |i: usize, r: &mut WeatherStepReport| r.phase_ms[i] = clock.elapsed().as_secs_f64() * 1e3;
    // 1. Ground: sun, radiation, sensible heat, evaporation (§4.2.5).
    let sun = sun_position(state.day_now(), state.local_hour(), state.latitude_deg);
    report.ground_evaporation = ground_exchange(state, params, &sun, dt);
    lap(0, &mut report);

    // 2. Phase change in every layer (4.2–4.4), layers in parallel.
    parallel::par_map(state.layers.iter_mut().collect(), |_, layer| layer_phase_change(layer, params, dt));
    lap(1, &mut report);

    // 3. Vertical exchange: C, U, D (4.5), transfers (4.6), precipitation.
    let heights = state.ground.height.data();
    let vert =
        vertical_velocity_in(&mut state.layers, heights, state.grid.dx, params, dt, &mut work.vertical);
    report.max_vertical_speed = vert.max_speed;
    report.max_unlimited_vertical_speed = vert.max_unlimited_speed;
    report.vertical_limited_cells = vert.limited_cells;
    transfer(&mut state.layers, dt);
    let area = state.grid.dx * state.grid.dx;
    report.precipitated = precipitate(
        &mut state.layers,
        state.ground.water.data_mut(),
        params.precipitation_threshold,
        params.precipitation_rate,
        dt,
        area,
    );
    state.precipitated += report.precipitated;
    lap(2, &mut report);

    // 4. Dynamics per layer: advection, forcing, damping, projection, conservative transport.
    for i in 0..state.layers.len() {
        divergence_target(&state.layers, i, &mut work.layers[i].target);
    }
    let (n, dx) = (state.grid.n, state.grid.dx);
    let items = state.layers.iter_mut().zip(work.layers.iter_mut()).collect();
    let reports: Vec<(ProjectionReport, Transport)> =
        parallel::par_map(items, |_, (layer, w)| layer_dynamics(layer, w, params, n, dx, dt))
            .into_iter()
            .collect::<Result<_, _>>()?;
    let mut reduction_sum = 0.0;
    for (r, t) in &reports {
        report.max_divergence_error = report.max_divergence_error.max(r.final_error);
        report.max_initial_divergence_error = report.max_initial_divergence_error.max(r.initial_error);
        report.max_solid_face_flux_m_s = report.max_solid_face_flux_m_s.max(r.solid_face_speed);
        reduction_sum += r.solve.reduction_per_cycle.min(1e6);
        report.v_cycles += r.solve.cycles;
        report.flux_substeps = report.flux_substeps.max(t.substeps);
        report.flux_limited_layers += t.limited as u32;
    }
    report.residual_reduction = reduction_sum / reports.len().max(1) as f64;
    lap(3, &mut report);
    for i in (1..4).rev() {
        report.phase_ms[i] -= report.phase_ms[i - 1];
    }

    // 5. Relaxation of T.
    let relax = (1.0 - (-dt / params.temperature_relaxation_s).exp()) as f32;
    for layer in state.layers.iter_mut() {
        let t_ref = layer.t_ref;
        layer.t.data_mut().iter_mut().for_each(|t| *t += (t_ref - *t) * relax);
    }

    // 6. Ash: settling to the ground and the open rim.
    report.ash = step_ash(
        &mut state.layers,
        state.ground.ash.data_mut(),
        n,
        dx,
        params.ash_settling_speed,
        params.ash_open_rim,
        dt,
    );
    state.time_s += dt;
    report.repaired += guard::repair(state);
    Ok(report)
}

/// Evaporation/condensation with latent heat in every free cell of a layer (rows in
/// parallel; cells are independent). In cells where the terrain cuts the layer's slab the
/// saturation is evaluated for the wedge's air, lifted within the layer ([`wedge_air`]).
///
/// An open cell (σ = 1) without condensed water and with its humidity below the layer's
/// [`saturation_humidity_floor`] over the range of its temperatures is skipped: there the
/// transfer `(1 − e^{−γΔt})(H' − H)` is ≥ 0 and limited to W = 0, so the phase change would
/// leave T, H and W exactly as they are (bit for bit); it saves the saturation law where
/// the air is dry.
fn layer_phase_change(layer: &mut LayerFields, params: &AtmosphereParams, dt: f64) {
    let pi = layer.pi;
    let (altitude, thickness) = (layer.altitude, layer.thickness);
    let n = layer.t.nx();
    let rate = 1.0 - (-params.phase_rate * dt).exp();
    let (t_lo, t_hi) =
        layer.t.data().iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &t| (lo.min(t), hi.max(t)));
    let dry = saturation_humidity_floor(t_lo as f64, t_hi as f64, pi);
    let sigma = layer.sigma.data();
    let rows = (layer.t.data_mut(), layer.h.data_mut(), layer.w.data_mut());
    parallel::for_each_row(rows, n, |j, (t, h, w)| {
        for i in 0..t.len() {
            if sigma[j * n + i] <= 0.0 {
                continue;
            }
            let s = sigma[j * n + i] as f64;
            if s < 1.0 {
                let (tw, pw) = wedge_air(t[i] as f64, altitude, thickness, s);
                let pc = phase_change_fraction(tw, h[i], w[i], pw, rate);
                t[i] = (t[i] as f64 + (pc.t - tw)) as f32;
                h[i] = pc.h;
                w[i] = pc.w;
                continue;
            }
            // W = +0 and H ≥ +0 exactly: then `H + 0`, `W − 0` and `T − 0` keep every bit.
            if w[i].to_bits() == 0 && !h[i].is_sign_negative() && h[i] <= dry && (t_lo..=t_hi).contains(&t[i])
            {
                continue;
            }
            let pc = phase_change_fraction(t[i] as f64, h[i], w[i], pi, rate);
            t[i] = pc.t as f32;
            h[i] = pc.h;
            w[i] = pc.w;
        }
    });
}

/// Advection of V and T, wind forcing, orographic damping, projection with the continuity
/// target and the terrain's apertures, then conservative advection of H, W and ash by the
/// projected wind.
fn layer_dynamics(
    layer: &mut LayerFields,
    w: &mut LayerWork,
    params: &AtmosphereParams,
    n: usize,
    dx: f64,
    dt: f64,
) -> Result<(ProjectionReport, Transport), ConfigError> {
    let c = (dt / dx) as f32;
    let scheme = params.advection;
    // V (both components from the old wind) and T.
    w.a.copy_from_slice(layer.u.data());
    w.b.copy_from_slice(layer.v.data());
    w.t_old.copy_from_slice(layer.t.data());
    // An entraining column's cells show the air around it to the advection and keep their own
    // temperature (LayerFields::entraining).
    let held: Vec<f32> = layer.entraining.iter().map(|&(k, _)| layer.t.data()[k as usize]).collect();
    for &(k, t_outside) in &layer.entraining {
        w.t_old[k as usize] = t_outside;
    }
    advect_wind_and_temperature(
        (&w.a, &w.b, &w.t_old),
        (layer.u.data_mut(), layer.v.data_mut(), layer.t.data_mut()),
        &mut w.scratch,
        n,
        c,
        params.wind_advection,
        scheme,
    );
    for (&(k, _), &t) in layer.entraining.iter().zip(&held) {
        layer.t.data_mut()[k as usize] = t;
    }
    if let Some(tau) = layer.wind_relaxation_s {
        relax_wind(layer.u.data_mut(), layer.v.data_mut(), layer.wind.x, layer.wind.y, dt, tau);
    }
    apertures(layer.sigma.data(), n, &mut w.ax, &mut w.ay);
    // Orographic damping, eq. (4.8).
    damp(
        layer.u.data_mut(),
        layer.v.data_mut(),
        &w.ax,
        &w.ay,
        layer.sigma.data(),
        n,
        dt / params.terrain_damping_s,
    );
    let rep = project(
        layer.u.data_mut(),
        layer.v.data_mut(),
        layer.p.data_mut(),
        &w.target,
        &w.ax,
        &w.ay,
        &mut w.projection,
        dx,
        params.multigrid_cycles,
        params.multigrid_tolerance,
    )?;
    let transport = {
        let LayerFields { h, w: water, ash, u, v, sigma, .. } = layer;
        let mut fields: [&mut [f64]; 3] = [h.data_mut(), water.data_mut(), ash.data_mut()];
        advect_conservative(
            &mut fields,
            &mut w.src,
            u.data(),
            v.data(),
            &w.ax,
            &w.ay,
            sigma.data(),
            n,
            dt / dx,
        )
    };
    Ok((rep, transport))
}
