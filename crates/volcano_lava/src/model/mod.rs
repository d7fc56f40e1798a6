//! Plain-data model of the lava domain: no ECS types. One call to [`step_layers`] advances
//! the whole domain (flow, crust, breakouts, folds) by one domain step (0.02 s by default);
//! [`step`] and [`step_under_crust`] advance the flow layer alone.

pub mod bands;
pub mod breakout;
pub mod budget;
pub mod crust;
pub mod field;
pub mod flow;
mod flow_rows;
mod flux;
pub mod folds;
pub mod fountain;
pub mod guard;
pub mod imprint;
pub mod params;
pub mod runout;
pub mod samples;
pub mod scratch;
pub mod surface;
mod surface_rows;
pub mod thermal;

use breakout::{Breakout, BreakoutState, update_breakouts};
use field::{FlowField, Source};
use folds::{FoldParams, FoldSystem, thicken_crust_under_folds, update_folds};
use params::LavaParams;
use surface::{SurfaceState, update_surface};

/// The three layers of one lava field (thesis §5.1), borrowed for one [`step_layers`].
#[derive(Debug)]
pub struct LayersMut<'a> {
    /// Layer 1: the flow.
    pub flow: &'a mut FlowField,
    /// Layer 2: the surface and its crust.
    pub surface: &'a mut SurfaceState,
    /// Layer 3: the fold particles.
    pub folds: &'a mut FoldSystem,
    /// The crust's drag and tears.
    pub breakouts: &'a mut BreakoutState,
}

/// What one [`step_layers`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DomainReport {
    /// The flow layer's step.
    pub flow: LavaStepReport,
    /// Where the crust tore and lava broke out this step.
    pub breakouts: Vec<Breakout>,
    /// What the guard repaired before the step ([`guard::repair`]).
    pub repaired: guard::LavaRepair,
    /// The fold particles are at [`FoldParams::max_particles`] (a limiter: no new folds).
    pub folds_at_cap: bool,
}

/// One domain step of a lava field, the one sequence the plugin and the scenario runner (and
/// so the CLI) call (docs/ARCHITECTURE.md §2.1): the flow advances and cools under the
/// crust ([`step_under_crust`]), the crust grows ([`update_surface`]), a crust that drags too
/// much tears ([`update_breakouts`]), the folds move ([`update_folds`]) and thicken the crust
/// under them ([`thicken_crust_under_folds`]); [`guard::repair`] runs first.
/// Parameters must have passed their `validate`.
pub fn step_layers(
    layers: LayersMut<'_>,
    params: &LavaParams,
    fold_params: &FoldParams,
    sources: &[Source],
    dt: f64,
) -> DomainReport {
    let LayersMut { flow, surface, folds, breakouts } = layers;
    // The guard runs once, before the step: state edited since the last step (through
    // reflection, a tool) never reaches the model's clamps, and what a step produced is found
    // at the start of the next (one pass per step: the lava runs at 50 Hz on the main thread).
    let air = params.air_temperature;
    let repaired = guard::repair(LayersMut { flow, surface, folds, breakouts }, air);
    let report = step_under_crust(flow, params, sources, &surface.crust, dt);
    update_surface(surface, flow, params, dt);
    let tears = update_breakouts(breakouts, flow, surface, params);
    let folds_at_cap = update_folds(folds, flow, surface, params, fold_params, dt).at_cap;
    thicken_crust_under_folds(folds, flow, surface, params, fold_params);
    DomainReport { flow: report, breakouts: tears, repaired, folds_at_cap }
}

/// What one [`step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LavaStepReport {
    /// Flow substeps taken (CFL-limited).
    pub substeps: u32,
    /// Whether the substep cap slowed the flow this step.
    pub mobility_capped: bool,
    /// Volume emitted by sources (m³).
    pub emitted: f64,
    /// Volume frozen into the ground (m³).
    pub frozen: f64,
    /// Volume that left through open edges (m³).
    pub outflow: f64,
}

/// Advances `field` by `dt` seconds with no crust (bare lava radiates at its temperature):
/// [`step_under_crust`] with an empty crust.
pub fn step(field: &mut FlowField, params: &LavaParams, sources: &[Source], dt: f64) -> LavaStepReport {
    step_under_crust(field, params, sources, &[], dt)
}

/// Advances `field` by `dt` seconds: sources emit, the flow moves lava (mass-exact, CFL
/// substeps), the lava cools through `crust` (per cell, m: the crust model's
/// [`surface::SurfaceState::crust`]; empty = none) and freezes. A non-positive or
/// non-finite `dt` does nothing. Parameters must have passed [`LavaParams::validate`];
/// sources are validated at creation.
pub fn step_under_crust(
    field: &mut FlowField,
    params: &LavaParams,
    sources: &[Source],
    crust: &[f64],
    dt: f64,
) -> LavaStepReport {
    let mut report = LavaStepReport::default();
    if !(dt.is_finite() && dt > 0.0) {
        return report;
    }
    for src in sources {
        let v = src.rate * dt;
        if v > 0.0 && !src.cells.is_empty() {
            field.deposit(&src.cells, v, src.temperature);
            field.budget.sources += v;
            report.emitted += v;
        }
    }
    let flow = flow::advance_flow(field, params, dt);
    report.substeps = flow.substeps;
    report.mobility_capped = flow.mobility_capped;
    report.outflow = flow.outflow;
    report.frozen = thermal::cool_and_freeze(field, params, crust, dt).frozen;
    report
}
