//! The `effusive` scenario: a vent on a long valley feeding a [`Runout`] at a constant rate
//! until the flow stops or the time runs out, measured against the published behaviour of
//! lava-flow length (docs/physics/lava.md §7): the Graetz-number limit (Pinkerton & Wilson
//! 1994), Walker's (1973) effusion-rate control and Jeffreys' sheet speed.

use std::time::Instant;

use bevy::math::DVec2;
use serde::{Deserialize, Serialize};
use volcano_core::error::in_range;
use volcano_core::{ConfigError, Terrain};

use super::terrains::runout_valley;
use crate::model::params::{GRAVITY, LavaParams, ViscosityModel};
use crate::model::runout::{Runout, RunoutSettings, Vent};

/// Graetz number at which a cooling-limited flow stops (Pinkerton & Wilson 1994: ≈ 300).
pub const GRAETZ_STOP: f64 = 300.0;

/// The early window of [`EffusiveSummary::front_speed_m_s`] (s).
const EARLY_S: f64 = 1800.0;

/// Options of the effusive scenario (the CLI flags).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EffusiveConfig {
    /// Effusion rate (m³/s).
    pub rate: f64,
    /// Simulated seconds at most.
    pub seconds: f64,
    /// Valley slope (degrees).
    pub slope_deg: f64,
    /// Terrain node spacing (m).
    pub node: f64,
    /// Lava cells per node side.
    pub refine: u32,
    /// Valley length (m).
    pub length_m: f64,
    /// Valley width (m).
    pub width_m: f64,
    /// Gully along the valley: depth and width (m); depth 0 = a plane.
    pub gully: (f64, f64),
    /// Distance (m) downslope of the vent where the ground reaches sea level; none = no sea.
    pub sea_at_m: Option<f64>,
    /// Vent radius (m).
    pub vent_radius: f64,
    /// Step (s).
    pub dt: f64,
    /// The run ends early once the front has advanced less than one cell in this many
    /// seconds (the flow stopped).
    pub stop_window_s: f64,
}

impl Default for EffusiveConfig {
    fn default() -> Self {
        Self {
            rate: 5.0,
            seconds: 3600.0,
            slope_deg: 5.0,
            node: 20.0,
            refine: 4,
            length_m: 10_000.0,
            width_m: 1_280.0,
            gully: (10.0, 200.0),
            sea_at_m: None,
            vent_radius: 10.0,
            dt: 1.0,
            stop_window_s: 7200.0,
        }
    }
}

impl EffusiveConfig {
    /// Checks every option.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("rate", self.rate, 0.0, 1e4)?;
        in_range("seconds", self.seconds, 0.0, 1e7)?;
        in_range("slope_deg", self.slope_deg, 0.5, 30.0)?;
        in_range("node", self.node, 1.0, 200.0)?;
        in_range("length_m", self.length_m, 10.0 * self.node, 4096.0 * self.node)?;
        in_range("width_m", self.width_m, 10.0 * self.node, 4096.0 * self.node)?;
        in_range("vent_radius", self.vent_radius, 0.0, 0.1 * self.width_m)?;
        in_range("dt", self.dt, 1e-3, 10.0)?;
        in_range("stop_window_s", self.stop_window_s, 10.0 * self.dt, 1e7)?;
        if let Some(d) = self.sea_at_m {
            in_range("sea_at_m", d, self.node, self.length_m)?;
        }
        RunoutSettings { refine: self.refine, ..Default::default() }.validate()
    }

    /// The lava: a channel-fed crystallising basalt ([`ViscosityModel::CHANNEL_BASALT`]).
    pub fn params(&self) -> LavaParams {
        LavaParams { viscosity: ViscosityModel::CHANNEL_BASALT, ..LavaParams::default() }
    }

    /// The valley and the vent on its axis, 3 nodes below its top row.
    pub fn terrain(&self) -> Result<(Terrain, Vent), ConfigError> {
        let (nx, ny) =
            ((self.width_m / self.node).round() as usize, (self.length_m / self.node).round() as usize);
        let tan = self.slope_deg.to_radians().tan();
        let vent_row = 3.0;
        let top = match self.sea_at_m {
            Some(d) => (d + vent_row * self.node) * tan,
            None => 1000.0 + ny as f64 * self.node * tan,
        };
        let terrain =
            runout_valley((nx, ny, self.node), self.slope_deg, top, self.gully, self.sea_at_m.is_some())?;
        let o = terrain.heights().origin().as_dvec2();
        let centre = DVec2::new(o.x + 0.5 * (nx - 1) as f64 * self.node, o.y + vent_row * self.node);
        let vent = Vent::point(centre, self.vent_radius, self.rate, 1450.0);
        vent.validate()?;
        Ok((terrain, vent))
    }
}

/// What the effusive scenario measured (`summary.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct EffusiveSummary {
    /// Simulated seconds run.
    pub seconds: f64,
    /// Farthest lava from the vent (m).
    pub runout_m: f64,
    /// How far downslope of the vent lava reached (m, along the valley).
    pub downslope_m: f64,
    /// Mean front speed over the first half hour (or tenth of a shorter run; m/s).
    pub front_speed_m_s: f64,
    /// Depth-averaged speed of a Jeffreys sheet with the flow's early mean depth, the slope
    /// and the vent lava's viscosity, `ρ g d² sin θ/(3η)` (m/s).
    pub jeffreys_speed_m_s: f64,
    /// Covered area over runout (m).
    pub mean_width_m: f64,
    /// Mean depth of the liquid lava (m).
    pub mean_depth_m: f64,
    /// Volume fed by the vent (m³).
    pub volume_fed_m3: f64,
    /// Volume frozen into the ground (m³), quenched included.
    pub volume_frozen_m3: f64,
    /// Volume quenched in the sea (m³).
    pub volume_quenched_m3: f64,
    /// Heat the quenched lava gave the water and the air above it (J).
    pub quench_heat_j: f64,
    /// Whether the front stopped (advanced less than a cell over `stop_window_s`).
    pub stopped: bool,
    /// When a stopped front last advanced (s).
    pub stopped_at_s: Option<f64>,
    /// Runout at which the Graetz number `16 Q d/(κ w L)` (equivalent diameter ≈ 4 d for a
    /// wide channel; Pinkerton & Wilson 1994) falls to 300, with this flow's mean width and
    /// depth when its front last advanced (or at the end).
    pub graetz_runout_m: f64,
    /// The flow's Graetz number at its runout.
    pub graetz_number: f64,
    /// Most tiles stored at once.
    pub tiles_max: usize,
    /// The cells they hold.
    pub cells_max: usize,
    /// Terrain cells (for comparison: memory follows the flow, not the terrain).
    pub terrain_cells: usize,
    /// Lava cell size (m).
    pub cell_m: f64,
    /// `|volume − accounts| / fed`.
    pub budget_error_rel: f64,
    /// Wall-clock seconds of the run.
    pub wall_s: f64,
}

/// Runs the scenario; `progress` is called with the simulated time every simulated minute.
pub fn run_effusive(
    c: &EffusiveConfig,
    mut progress: impl FnMut(f64),
) -> Result<EffusiveSummary, ConfigError> {
    c.validate()?;
    let params = c.params();
    let (mut terrain, vent) = c.terrain()?;
    let settings = RunoutSettings { refine: c.refine, ..Default::default() };
    let mut r = Runout::new(&terrain, settings, &params)?;
    let wall = Instant::now();
    let steps = (c.seconds / c.dt).round() as usize;
    let min_h = params.min_thickness;
    let mut s = EffusiveSummary {
        cell_m: r.grid().cell(),
        terrain_cells: terrain.heights().data().len() * (c.refine * c.refine) as usize,
        ..Default::default()
    };
    let (mut best, mut best_at, mut down) = (0.0f64, 0.0f64, 0.0f64);
    let mut at_best = r.stats(vent.centre, min_h);
    let (mut early, mut early_depth) = (None, 0.0);
    let minute = (60.0 / c.dt).round().max(1.0) as usize;
    for n in 1..=steps {
        let rep = r.step(&terrain, &params, &[vent], c.dt);
        s.volume_quenched_m3 += rep.quenched;
        s.quench_heat_j += rep.quench_heat;
        r.write_frozen(&mut terrain)?;
        s.tiles_max = s.tiles_max.max(r.tiles().len());
        let t = r.time();
        if n % minute == 0 || n == steps {
            progress(t);
            let st = r.stats(vent.centre, min_h);
            if let Some((_, hi)) = st.bounds {
                down = down.max(hi.y - vent.centre.y);
            }
            if st.runout_m > best + r.grid().cell() {
                (best, best_at, at_best) = (st.runout_m, t, st);
            }
            if early.is_none() && t >= EARLY_S.min(0.1 * c.seconds) {
                early = Some(st.runout_m / t);
                early_depth = st.mean_depth_m;
            }
            if t - best_at >= c.stop_window_s {
                s.stopped = true;
                s.stopped_at_s = Some(best_at);
                break;
            }
        }
    }
    let st = r.stats(vent.centre, min_h);
    s.seconds = r.time();
    // Tiles that slept took their frozen cells out of the stats: the farthest ever seen.
    s.runout_m = st.runout_m.max(best);
    s.downslope_m = st.bounds.map_or(down, |(_, hi)| down.max(hi.y - vent.centre.y));
    s.front_speed_m_s = early.unwrap_or(if s.seconds > 0.0 { st.runout_m / s.seconds } else { 0.0 });
    let eta = params.viscosity.viscosity(vent.temperature);
    let depth = if early.is_some() { early_depth } else { st.mean_depth_m };
    s.jeffreys_speed_m_s =
        params.density * GRAVITY * depth * depth * c.slope_deg.to_radians().sin() / (3.0 * eta);
    s.mean_width_m = st.mean_width_m;
    s.mean_depth_m = st.mean_depth_m;
    let b = r.budget();
    s.volume_fed_m3 = b.sources;
    s.volume_frozen_m3 = b.solidified;
    s.budget_error_rel = b.error_rel(r.lava_volume());
    s.cells_max = s.tiles_max * crate::model::runout::tiles::TILE_CELLS;
    let g = if s.stopped { at_best } else { st };
    if g.mean_width_m > 0.0 && g.runout_m > 0.0 {
        let k = c.rate * 16.0 * g.mean_depth_m / (params.kappa() * g.mean_width_m);
        s.graetz_runout_m = k / GRAETZ_STOP;
        s.graetz_number = k / g.runout_m;
    }
    s.wall_s = wall.elapsed().as_secs_f64();
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_early_front_moves_at_the_jeffreys_speed() {
        let c = EffusiveConfig { seconds: 1800.0, length_m: 3000.0, ..Default::default() };
        let s = run_effusive(&c, |_| {}).unwrap();
        let ratio = s.front_speed_m_s / s.jeffreys_speed_m_s;
        assert!(
            (0.7..1.4).contains(&ratio),
            "front {} m/s, Jeffreys {} m/s",
            s.front_speed_m_s,
            s.jeffreys_speed_m_s
        );
        assert!(s.runout_m > 500.0 && !s.stopped, "{s:?}");
        assert!(s.budget_error_rel < 1e-12, "{}", s.budget_error_rel);
        // Memory follows the flow: a few percent of the terrain's cells are stored.
        assert!(s.cells_max * 10 < s.terrain_cells, "{} of {}", s.cells_max, s.terrain_cells);
    }

    #[test]
    fn the_sea_stops_the_flow_and_takes_its_heat() {
        let c = EffusiveConfig {
            seconds: 3000.0,
            length_m: 1000.0,
            sea_at_m: Some(200.0),
            rate: 2.0,
            gully: (0.0, 0.0),
            ..Default::default()
        };
        let s = run_effusive(&c, |_| {}).unwrap();
        assert!(s.volume_quenched_m3 > 0.2 * s.volume_fed_m3, "{s:?}");
        // The front stands at the shore (a cell of the sea at most).
        assert!(s.downslope_m > 150.0 && s.downslope_m < 200.0 + 2.0 * s.cell_m, "{}", s.downslope_m);
        // At least the heat of cooling to the air (ρ V C ΔT, ΔT > 1000 K) went into the sea.
        let p = c.params();
        assert!(s.quench_heat_j > p.density * s.volume_quenched_m3 * p.heat_capacity * 1000.0, "{s:?}");
        assert!(s.budget_error_rel < 1e-12);
    }

    /// A small valley (8 m nodes, 2 m cells, a gully 2 m deep and 40 m wide) where thin,
    /// slow flows stop within hours.
    fn small(rate: f64) -> EffusiveConfig {
        EffusiveConfig {
            rate,
            seconds: 200_000.0,
            node: 8.0,
            length_m: 2048.0,
            width_m: 256.0,
            gully: (2.0, 40.0),
            vent_radius: 3.0,
            stop_window_s: 3600.0,
            ..Default::default()
        }
    }

    #[test]
    fn cooling_stops_the_flow_near_the_graetz_length_and_a_higher_rate_runs_farther() {
        let (slow, fast) =
            (run_effusive(&small(0.025), |_| {}).unwrap(), run_effusive(&small(0.1), |_| {}).unwrap());
        for s in [&slow, &fast] {
            assert!(s.stopped, "{s:?}");
            // Pinkerton & Wilson (1994): motion ceases near Gz ≈ 300.
            let ratio = s.runout_m / s.graetz_runout_m;
            assert!((0.5..3.0).contains(&ratio), "runout {} m, Graetz {} m", s.runout_m, s.graetz_runout_m);
            assert!(s.budget_error_rel < 1e-12);
        }
        // Walker (1973): on the same slope a higher effusion rate makes a longer flow.
        assert!(fast.runout_m > 2.0 * slow.runout_m, "{} vs {}", fast.runout_m, slow.runout_m);
    }

    #[test]
    fn bad_options_are_errors() {
        let d = EffusiveConfig::default();
        assert!(d.validate().is_ok());
        for bad in [
            EffusiveConfig { rate: -1.0, ..d.clone() },
            EffusiveConfig { slope_deg: f64::NAN, ..d.clone() },
            EffusiveConfig { refine: 0, ..d.clone() },
            EffusiveConfig { sea_at_m: Some(1e9), ..d.clone() },
            EffusiveConfig { dt: 0.0, ..d.clone() },
        ] {
            assert!(run_effusive(&bad, |_| {}).is_err(), "{bad:?}");
        }
    }
}
