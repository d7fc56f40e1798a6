//! Heat and vapour from the ground into the layers: a lava fountain's gas, a sea entry's laze
//! (docs/physics/coupling.md §3). Such a source is a buoyant plume too weak to need slices:
//! its rise follows Morton, Taylor & Turner's (1956) maximum height for a maintained point
//! source of heat in stably stratified air,
//!
//! `z_max = 5.0 (F/π)^{1/4} N^{-3/4}`,  `F = g Q / (ρ c_p T)`,
//!
//! (`Q` the heat flux, `N` the Brunt–Väisälä frequency), which in a standard troposphere is
//! the volcanologists' `H ≈ 8.2 Q^{1/4}` (Wilson et al. 1978; Sparks et al. 1997 §4). The
//! plume carries its heat up through the layers it crosses (shared by overlap with
//! `[ground, z_max]`) and its vapour to where it spreads, `≈ 0.75 z_max`, over the cells within
//! its radius there, `b = 6α z / 5` with `α = 0.1` (MTT's top-hat radius).

use bevy::math::DVec2;
use volcano_atmosphere::model::fields::{GridSpec, LayerFields};
use volcano_atmosphere::model::thermo::{CP_AIR, air_density};
use volcano_core::units::G0;

use super::column::for_cells_within;
use super::inject::cell_at;

/// The smallest buoyancy frequency (s⁻¹) the rise law uses: in neutral or unstable air MTT's
/// height diverges; 0.005 s⁻¹ is a weakly stable troposphere. A floored step says so.
pub const MIN_BUOYANCY_FREQUENCY: f64 = 0.005;

/// Where a plume spreads, as a fraction of its maximum height above the source (MTT's
/// neutral-buoyancy level, ≈ 0.75).
pub const SPREAD_FRACTION: f64 = 0.75;

/// MTT's entrainment coefficient for a plume's top-hat radius `b = 6α z / 5`.
pub const ENTRAINMENT_ALPHA: f64 = 0.1;

/// A heat source at the ground as the layers see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundSource {
    /// World `(x, z)` of the source (m).
    pub at: DVec2,
    /// Altitude of the ground there (m).
    pub altitude: f64,
    /// Heat flux (W).
    pub heat_w: f64,
    /// Water vapour flux (kg/s).
    pub vapour_kg_s: f64,
    /// Radius at the ground (m).
    pub radius: f64,
}

/// What [`inject_source`] did for one source over one interval.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SourceReport {
    /// Heat given to the layers (J).
    pub heat_j: f64,
    /// Vapour given to the layers (g).
    pub vapour_g: f64,
    /// Heat and vapour that found no free air under the grid (outside it, or every layer rock):
    /// booked as outflow by the caller (J, g).
    pub outside: (f64, f64),
    /// The plume's maximum height above sea level (m).
    pub top_m: f64,
    /// Where it spread (m above sea level).
    pub spread_m: f64,
    /// The air was neutral or unstable and [`MIN_BUOYANCY_FREQUENCY`] was used (a limiter).
    pub stability_floored: bool,
}

/// MTT's buoyancy flux `F = g Q / (ρ c_p T)` (m⁴/s³) of a heat flux `q` (W) into air of density
/// `rho` (kg/m³) and temperature `t` (K).
pub fn buoyancy_flux(q: f64, rho: f64, t: f64) -> f64 {
    G0 * q / (rho * CP_AIR * t)
}

/// MTT's maximum rise (m above the source) of a maintained point source of buoyancy flux `f`
/// (m⁴/s³) in air of buoyancy frequency `n` (s⁻¹): `5.0 (F/π)^{1/4} N^{-3/4}`.
pub fn rise_height(f: f64, n: f64) -> f64 {
    if !(f > 0.0 && n > 0.0) {
        return 0.0;
    }
    5.0 * (f / std::f64::consts::PI).powf(0.25) * n.powf(-0.75)
}

/// Buoyancy frequency (s⁻¹) of the air over cell `cell` above `altitude`, from the first free
/// layer at or above it to the top layer: `N² = (g/T̄)(ΔT/Δz + g/c_p)`. `None` with fewer than
/// two free layers there, or where the air is neutral or unstable.
pub fn buoyancy_frequency(layers: &[LayerFields], cell: usize, altitude: f64) -> Option<f64> {
    let free: Vec<&LayerFields> =
        layers.iter().filter(|l| l.bottom + l.thickness > altitude && l.sigma.data()[cell] > 0.0).collect();
    let (low, high) = (free.first()?, free.last()?);
    let dz = high.altitude - low.altitude;
    if dz <= 0.0 {
        return None;
    }
    let (tl, th) = (low.t.data()[cell] as f64, high.t.data()[cell] as f64);
    let n2 = G0 / (0.5 * (tl + th)) * ((th - tl) / dz + G0 / CP_AIR);
    (n2 > 0.0).then(|| n2.sqrt())
}

/// Air density (kg/m³) of a layer at a cell, from its mean pressure and temperature.
fn density(layer: &LayerFields, cell: usize) -> f64 {
    air_density(layer.pi, layer.t.data()[cell] as f64)
}

/// Lifts `seconds` of `source` into the layers (see the module docs): each crossed layer's
/// share of the heat warms its free cells within the plume's radius (`ΔT = E / (ρ c_p σ h dx²)`,
/// the same energy in each cell), the vapour goes into the layer where the plume spreads (or the
/// first free one above it). A layer with no free cell there passes its share up; what no layer
/// takes is reported as `outside`.
pub fn inject_source(
    layers: &mut [LayerFields],
    grid: GridSpec,
    source: &GroundSource,
    seconds: f64,
) -> SourceReport {
    let heat = (source.heat_w * seconds).max(0.0);
    let vapour = (source.vapour_kg_s * seconds * 1e3).max(0.0);
    let mut report = SourceReport { outside: (heat, vapour), ..Default::default() };
    if layers.is_empty() || !(heat > 0.0 || vapour > 0.0) || !(heat.is_finite() && vapour.is_finite()) {
        return report;
    }
    let Some(cell) = cell_at(grid, source.at.x, source.at.y) else { return report };
    // The air the plume starts in: the first free layer at the source's altitude.
    let Some(base_index) =
        layers.iter().position(|l| l.bottom + l.thickness > source.altitude && l.sigma.data()[cell] > 0.0)
    else {
        return report;
    };
    let base = &layers[base_index];
    let (rho, t) = (density(base, cell), base.t.data()[cell] as f64);
    let n = buoyancy_frequency(layers, cell, source.altitude);
    report.stability_floored = n.is_none_or(|n| n < MIN_BUOYANCY_FREQUENCY);
    let n = n.unwrap_or(0.0).max(MIN_BUOYANCY_FREQUENCY);
    let rise = rise_height(buoyancy_flux(source.heat_w.max(0.0), rho, t), n);
    report.top_m = source.altitude + rise;
    report.spread_m = source.altitude + SPREAD_FRACTION * rise;
    let radius = (1.2 * ENTRAINMENT_ALPHA * SPREAD_FRACTION * rise).max(source.radius).max(grid.dx);
    let mut cells = Vec::new();
    for_cells_within(grid, source.at, radius, |k, _| cells.push(k));
    if cells.is_empty() {
        cells.push(cell);
    }
    let area = grid.dx * grid.dx;
    // Heat: by each layer's overlap with [ground, top] (all of it in the first free layer if
    // the plume overlaps none); a layer with no free cell there passes its share up.
    let overlap: Vec<f64> = layers
        .iter()
        .map(|l| ((l.bottom + l.thickness).min(report.top_m) - l.bottom.max(source.altitude)).max(0.0))
        .collect();
    let total: f64 = overlap.iter().sum();
    let mut carried = 0.0;
    for (i, layer) in layers.iter_mut().enumerate() {
        let share = match total > 0.0 {
            true => heat * overlap[i] / total,
            false if i == base_index => heat,
            false => 0.0,
        };
        let e = share + carried;
        if e <= 0.0 {
            continue;
        }
        let free: Vec<usize> = cells.iter().copied().filter(|&k| layer.sigma.data()[k] > 0.0).collect();
        if free.is_empty() {
            carried = e;
            continue;
        }
        let per_cell = e / free.len() as f64;
        for k in free {
            let heat_capacity =
                density(layer, k) * CP_AIR * layer.sigma.data()[k] as f64 * layer.thickness * area;
            layer.t.data_mut()[k] += (per_cell / heat_capacity) as f32;
        }
        report.heat_j += e;
        carried = 0.0;
    }
    // Vapour: where the plume spreads, or the first free layer above it.
    let start =
        layers.iter().position(|l| report.spread_m < l.bottom + l.thickness).unwrap_or(layers.len() - 1);
    let mut vapour_left = vapour;
    for layer in layers.iter_mut().skip(start) {
        let free: Vec<usize> = cells.iter().copied().filter(|&k| layer.sigma.data()[k] > 0.0).collect();
        if free.is_empty() {
            continue;
        }
        let per_cell = vapour / free.len() as f64;
        for k in free {
            layer.h.data_mut()[k] += per_cell / (layer.sigma.data()[k] as f64 * layer.thickness * area);
        }
        report.vapour_g = vapour;
        vapour_left = 0.0;
        break;
    }
    report.outside = (carried, vapour_left);
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_atmosphere::model::fields::layer_geometry;

    /// Layers at `alts` with the standard troposphere's temperature (288.15 K − 6.5 K/km).
    fn standard(grid: GridSpec, alts: &[f64]) -> Vec<LayerFields> {
        let geo = layer_geometry(alts).unwrap();
        alts.iter()
            .zip(geo)
            .map(|(&a, (b, h))| LayerFields::new(grid, a, b, h, (288.15 - 0.0065 * a) as f32))
            .collect()
    }

    fn source(q: f64) -> GroundSource {
        GroundSource {
            at: DVec2::new(130.0, -70.0),
            altitude: 0.0,
            heat_w: q,
            vapour_kg_s: 50.0,
            radius: 30.0,
        }
    }

    const ALTS: [f64; 6] = [500.0, 1_500.0, 3_000.0, 5_000.0, 8_000.0, 11_000.0];

    #[test]
    fn in_a_standard_troposphere_a_plume_rises_8_2_q_to_the_quarter() {
        // Wilson et al. (1978), Sparks et al. (1997): H ≈ 8.2 Q^{1/4} m (Q in W) for a
        // maintained source in a standard atmosphere, from MTT's law.
        let grid = GridSpec::new(32, 500.0).unwrap();
        for q in [1e7, 1e9, 1e11] {
            let mut layers = standard(grid, &ALTS);
            let r = inject_source(&mut layers, grid, &source(q), 1.0);
            let coefficient = r.top_m / q.powf(0.25);
            assert!(
                (coefficient - 8.2).abs() < 0.4,
                "Q = {q:e} W: H = {:.0} m = {coefficient:.2} Q^1/4",
                r.top_m
            );
            assert!(!r.stability_floored);
            assert!((r.spread_m - SPREAD_FRACTION * r.top_m).abs() < 1e-6);
        }
    }

    #[test]
    fn the_heat_and_vapour_given_are_the_sources_exactly() {
        let grid = GridSpec::new(32, 500.0).unwrap();
        let mut layers = standard(grid, &ALTS);
        let before: Vec<LayerFields> = layers.clone();
        // Rock fills the lowest layer under part of the plume.
        let src = source(3e10);
        for k in [cell_at(grid, 130.0, -70.0).unwrap(), cell_at(grid, 630.0, -70.0).unwrap()] {
            layers[0].sigma.data_mut()[k] = 0.0;
        }
        let r = inject_source(&mut layers, grid, &src, 20.0);
        assert_eq!(r.outside, (0.0, 0.0));
        let area = grid.dx * grid.dx;
        let (mut heat, mut water) = (0.0, 0.0);
        for (l, b) in layers.iter().zip(&before) {
            for k in 0..grid.cells() {
                let vol = l.sigma.data()[k] as f64 * l.thickness * area;
                heat += density(b, k) * CP_AIR * vol * (l.t.data()[k] - b.t.data()[k]) as f64;
                water += vol * (l.h.data()[k] - b.h.data()[k]);
            }
        }
        // Temperatures are f32 (≈ 3·10⁻⁵ K at 300 K): the energy closes to that rounding.
        assert!((heat / (3e10 * 20.0) - 1.0).abs() < 2e-3, "heat {heat:e}");
        assert!((water / (50.0 * 20.0 * 1e3) - 1.0).abs() < 1e-12, "water {water:e}");
        // Q = 3·10¹⁰ W rises ≈ 3.4 km: heat in the four lowest layers, none above the top, the
        // vapour in the layer where it spreads (≈ 2.5 km, layer 2).
        assert!(r.top_m > 3_000.0 && r.top_m < 4_500.0, "{}", r.top_m);
        let warmed: Vec<bool> = layers
            .iter()
            .zip(&before)
            .map(|(l, b)| l.t.data().iter().zip(b.t.data()).any(|(x, y)| x > y))
            .collect();
        assert_eq!(warmed, [true, true, true, false, false, false]);
        let wetted: Vec<bool> = layers.iter().map(|l| l.h.data().iter().any(|&h| h > 0.0)).collect();
        assert_eq!(wetted, [false, false, true, false, false, false]);
    }

    #[test]
    fn a_source_off_the_grid_or_under_rock_gives_nothing_and_says_so() {
        let grid = GridSpec::new(16, 100.0).unwrap();
        let mut layers = standard(grid, &ALTS[..3]);
        let off = GroundSource { at: DVec2::new(5e3, 0.0), ..source(1e9) };
        let r = inject_source(&mut layers, grid, &off, 2.0);
        assert_eq!((r.heat_j, r.vapour_g, r.outside), (0.0, 0.0, (2e9, 1e5)));
        for l in &mut layers {
            l.sigma.data_mut().fill(0.0);
        }
        let r = inject_source(&mut layers, grid, &source(1e9), 2.0);
        assert_eq!((r.heat_j, r.outside), (0.0, (2e9, 1e5)));
    }

    #[test]
    fn unstable_air_floors_the_stability_and_reports_it() {
        let grid = GridSpec::new(16, 200.0).unwrap();
        let geo = layer_geometry(&ALTS[..3]).unwrap();
        // A superadiabatic stack: 12 K/km cooling.
        let mut layers: Vec<LayerFields> = ALTS[..3]
            .iter()
            .zip(geo)
            .map(|(&a, (b, h))| LayerFields::new(grid, a, b, h, (300.0 - 0.012 * a) as f32))
            .collect();
        let k = cell_at(grid, 130.0, -70.0).unwrap();
        assert_eq!(buoyancy_frequency(&layers, k, 0.0), None);
        let r = inject_source(&mut layers, grid, &source(1e9), 1.0);
        assert!(r.stability_floored);
        assert!(r.top_m.is_finite() && r.top_m > 0.0);
        assert!((r.heat_j - 1e9).abs() < 1e-3);
    }
}
