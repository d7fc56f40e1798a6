//! Plain-data model of the lava domain: no ECS types. One call to [`step`] advances a
//! [`FlowField`] by one domain step (0.02 s by default).

pub mod bands;
pub mod breakout;
pub mod budget;
pub mod field;
pub mod flow;
pub mod folds;
pub mod imprint;
pub mod params;
pub mod samples;
pub mod surface;
pub mod thermal;

use field::{FlowField, Source};
use params::LavaParams;

/// What one [`step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepReport {
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
pub fn step(field: &mut FlowField, params: &LavaParams, sources: &[Source], dt: f64) -> StepReport {
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
) -> StepReport {
    let mut report = StepReport::default();
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
