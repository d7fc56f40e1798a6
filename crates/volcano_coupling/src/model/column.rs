//! Exchanges between a column and the air layers (thesis §4.3.3, Figs 4.11–4.13).
//!
//! Coordinates: the atmosphere grid's `(x, y)` is the world's `(x, z)` (docs/ARCHITECTURE.md
//! §1); a layer's staggered wind `(u, v)` blows toward world `+x` and `+z`. The plume frame has
//! `y` toward world `−z`, so a layer wind becomes `(u, −v)` for the plume.

use std::borrow::Borrow;

use bevy::math::DVec2;
use volcano_atmosphere::model::fields::{GridSpec, LayerFields};
use volcano_plume::AmbientLevel;

/// One slice as the layers see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColumnSlice {
    /// Horizontal centre, world `(x, z)` (m).
    pub centre: DVec2,
    /// Altitude above sea level (m).
    pub altitude: f64,
    /// Radius (m).
    pub radius: f64,
    /// Temperature (K).
    pub temperature: f64,
    /// Water mass fraction of the slice (kg of water per kg of slice).
    pub water_fraction: f64,
}

/// What the plume → air transfer did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TransferReport {
    /// Layers that received a slice's values.
    pub layers_imposed: u32,
    /// Cells whose temperature and moisture were imposed.
    pub cells_imposed: u32,
    /// Net water written into the layers (g): the imposed moisture minus what the cells held.
    pub water_written_g: f64,
}

/// For each layer, the index of the slice nearest the layer's altitude among those inside its
/// altitude range `[bottom, bottom + thickness)`; `None` where no slice is in range.
pub fn nearest_slice_per_layer<L: Borrow<LayerFields>>(
    layers: &[L],
    slices: &[ColumnSlice],
) -> Vec<Option<usize>> {
    layers
        .iter()
        .map(|l| {
            let l = l.borrow();
            let (lo, hi) = (l.bottom, l.bottom + l.thickness);
            slices
                .iter()
                .enumerate()
                .filter(|(_, s)| s.altitude >= lo && s.altitude < hi)
                .min_by(|(ia, a), (ib, b)| {
                    (a.altitude - l.altitude)
                        .abs()
                        .total_cmp(&(b.altitude - l.altitude).abs())
                        .then(ia.cmp(ib))
                })
                .map(|(i, _)| i)
        })
        .collect()
}

/// Radius (m) over which a slice of radius `r` imposes its values on a grid of cell `dx`: the
/// slice's own radius, but at least one cell so a narrow column still reaches the cell it is in.
pub fn imposition_radius(r: f64, dx: f64) -> f64 {
    r.max(dx)
}

/// The annulus `[R, max(3r, R + 1.5 dx)]` (m) read as a column's surroundings, `R` the
/// imposition radius: both transfers use it, so the cells the column writes are never read
/// back as its air.
pub fn annulus_bounds(r: f64, dx: f64) -> (f64, f64) {
    let r_in = imposition_radius(r, dx);
    (r_in, (3.0 * r).max(r_in + 1.5 * dx))
}

/// Means of temperature (K), humidity (g/m³) and cell-centred wind (world x/z, m/s) over the
/// free cells whose centres lie in the annulus `r_in ≤ d ≤ r_out` around `centre`. `None` if no
/// free cell is there.
pub fn annulus_mean(
    layer: &LayerFields,
    grid: GridSpec,
    centre: DVec2,
    r_in: f64,
    r_out: f64,
) -> Option<(f64, f64, DVec2)> {
    let n = grid.n;
    let mask = n - 1;
    let (mut t, mut h, mut w, mut count) = (0.0, 0.0, DVec2::ZERO, 0usize);
    for_cells_within(grid, centre, r_out, |k, d| {
        if d < r_in || layer.sigma.data()[k] <= 0.0 {
            return;
        }
        let (i, j) = (k % n, k / n);
        let u = 0.5 * (layer.u.data()[k] + layer.u.data()[j * n + ((i + 1) & mask)]) as f64;
        let v = 0.5 * (layer.v.data()[k] + layer.v.data()[((j + 1) & mask) * n + i]) as f64;
        t += layer.t.data()[k] as f64;
        h += layer.h.data()[k];
        w += DVec2::new(u, v);
        count += 1;
    });
    (count > 0).then(|| {
        let c = count as f64;
        (t / c, h / c, w / c)
    })
}

/// Calls `f(k, distance)` for every cell of the (non-wrapping) grid whose centre is within
/// `radius` of `p` (world x/z), in index order.
pub fn for_cells_within(grid: GridSpec, p: DVec2, radius: f64, mut f: impl FnMut(usize, f64)) {
    let n = grid.n as i64;
    let o = grid.origin();
    let (fx, fy) = ((p.x - o.x as f64) / grid.dx, (p.y - o.y as f64) / grid.dx);
    let reach = radius / grid.dx;
    let (i0, i1) = (((fx - reach).floor() as i64).max(0), ((fx + reach).ceil() as i64).min(n - 1));
    let (j0, j1) = (((fy - reach).floor() as i64).max(0), ((fy + reach).ceil() as i64).min(n - 1));
    for j in j0..=j1 {
        for i in i0..=i1 {
            let k = (j * n + i) as usize;
            let (cx, cy) = grid.centre(k);
            let d = DVec2::new(cx - p.x, cy - p.y).length();
            if d <= radius {
                f(k, d);
            }
        }
    }
}

/// The air around the column at each layer (air → plume, §4.3.3): for layer `i`, the annulus
/// `[R, max(3r, R + 1.5 dx)]` around the slice `nearest[i]` (or around `vent` with radius `r0`
/// where no slice is in the layer), `R` the imposition radius, so the cells the column writes
/// into are never read back as its surroundings. Winds are returned in the plume frame. Layers
/// with no free cell in their annulus are skipped.
pub fn ambient_levels<L: Borrow<LayerFields>>(
    layers: &[L],
    grid: GridSpec,
    slices: &[ColumnSlice],
    nearest: &[Option<usize>],
    vent: DVec2,
    r0: f64,
) -> Vec<AmbientLevel> {
    layers
        .iter()
        .zip(nearest)
        .filter_map(|(layer, near)| {
            let layer = layer.borrow();
            let (centre, r) = near.map_or((vent, r0), |i| (slices[i].centre, slices[i].radius));
            let (r_in, r_out) = annulus_bounds(r, grid.dx);
            let (t, h, w) = annulus_mean(layer, grid, centre, r_in, r_out)?;
            Some(AmbientLevel {
                altitude: layer.altitude,
                temperature: t,
                humidity: h,
                wind: DVec2::new(w.x, -w.y),
            })
        })
        .collect()
}

/// Humidity (g/m³) that air of the layer's pressure `pi` (Pa) at temperature `t` (K) holds when
/// it carries a water mass fraction `q` (kg/kg): `q ρ_air`, `ρ_air = Π / (R_air T)`.
///
/// The slice's own water per volume is not used: the thesis' vent mixture is ≈ 50× denser than
/// a real one (docs/physics/plume.md §4.1), so its 3 wt% of magmatic water would be thousands of
/// g/m³ near the vent and its latent heat would run the layer's temperature away. The mass
/// fraction is what the column's air carries into the layer.
pub fn humidity_of(q: f64, pi: f64, t: f64) -> f64 {
    1e3 * q.max(0.0) * pi / (volcano_core::units::R_AIR * t.max(1.0))
}

/// Frees the cells the previous plume → air transfer held ([`LayerFields::entraining`]):
/// called once per transfer, before the columns over this atmosphere are imposed.
pub fn release_columns(layers: &mut [LayerFields]) {
    for layer in layers {
        layer.entraining.clear();
    }
}

/// Plume → air (§4.3.3): in each layer with a slice in range, the cells within the imposition
/// radius `R` of the slice take `q_k = q_a + φ (q_s − q_a) w_k / w̄` for temperature and
/// humidity, with `w_k = 1 − d_k / R` (a cone peaking at the column's centre), `w̄` its mean over
/// those cells and `q_a` the annulus mean around them. `φ = min(1, π r² w̄ / (dx² Σ σ_k w_k))`
/// is the share of the cells' free area the column fills: where the column covers its cells
/// (`r ≳ dx`) φ = 1 and the imposed values' mean is the slice's, as the thesis prints; a column
/// narrower than a cell gives it the heat and water of its own cross-section, not of the whole
/// cell (departure: the printed rule makes what a narrow column puts into the air grow as
/// `dx²`, 4× more at 400 m cells than at 200 m, docs/ARCHITECTURE.md §1.4).
///
/// The imposed cells are added to [`LayerFields::entraining`] with the annulus temperature, so
/// the weather step does not carry the column's heat out sideways or down (an entraining
/// column draws the air around it in and its air only rises). Call [`release_columns`] once
/// per transfer before the first column is imposed, so the cells of the previous transfer
/// (or of a volcano that stopped) are not held any more.
///
/// The slice's humidity is its water fraction in air of the layer's pressure and the slice's
/// temperature ([`humidity_of`]). Only free cells (σ > 0) are written; humidity never goes below
/// 0. Returns what was done, with the net water written (g) for the water budget.
pub fn impose(
    layers: &mut [LayerFields],
    grid: GridSpec,
    slices: &[ColumnSlice],
    nearest: &[Option<usize>],
) -> TransferReport {
    let mut report = TransferReport::default();
    let cell_area = grid.dx * grid.dx;
    for (layer, near) in layers.iter_mut().zip(nearest) {
        let Some(s) = near.map(|i| slices[i]) else { continue };
        let (r, r_out) = annulus_bounds(s.radius, grid.dx);
        let Some((t_a, h_a, _)) = annulus_mean(layer, grid, s.centre, r, r_out) else {
            continue;
        };
        let mut cells: Vec<(usize, f64)> = Vec::new();
        for_cells_within(grid, s.centre, r, |k, d| {
            if layer.sigma.data()[k] > 0.0 {
                cells.push((k, 1.0 - d / r));
            }
        });
        let sum_w = cells.iter().map(|c| c.1).sum::<f64>();
        let sum_sigma_w = cells.iter().map(|&(k, w)| layer.sigma.data()[k] as f64 * w).sum::<f64>();
        if cells.is_empty() || sum_w <= 0.0 {
            continue;
        }
        let mean_w = sum_w / cells.len() as f64;
        let phi = (std::f64::consts::PI * s.radius * s.radius * mean_w / (cell_area * sum_sigma_w)).min(1.0);
        let volume = layer.thickness * cell_area;
        let h_s = humidity_of(s.water_fraction, layer.pi, s.temperature);
        for &(k, w) in &cells {
            let f = phi * w / mean_w;
            let sigma = layer.sigma.data()[k] as f64;
            let h_new = (h_a + (h_s - h_a) * f).max(0.0);
            report.water_written_g += (h_new - layer.h.data()[k]) * sigma * volume;
            layer.h.data_mut()[k] = h_new;
            layer.t.data_mut()[k] = (t_a + (s.temperature - t_a) * f).max(1.0) as f32;
            layer.entraining.push((k as u32, t_a as f32));
        }
        report.layers_imposed += 1;
        report.cells_imposed += cells.len() as u32;
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_atmosphere::model::fields::layer_geometry;

    fn layers(n: usize, dx: f64) -> (GridSpec, Vec<LayerFields>) {
        let g = GridSpec::new(n, dx).unwrap();
        let alts = [500.0, 1500.0, 3000.0];
        let geo = layer_geometry(&alts).unwrap();
        (g, alts.iter().zip(geo).map(|(&a, (b, h))| LayerFields::new(g, a, b, h, 280.0)).collect())
    }

    fn slice(alt: f64, r: f64) -> ColumnSlice {
        ColumnSlice {
            centre: DVec2::new(30.0, -20.0),
            altitude: alt,
            radius: r,
            temperature: 400.0,
            water_fraction: 0.02,
        }
    }

    #[test]
    fn each_layer_takes_the_slice_nearest_its_altitude_within_its_range() {
        let (_, l) = layers(16, 100.0);
        // Layer 1 spans [1000, 2250): 1450 is nearer 1500 than 1100 is; 5000 is above all.
        let s = [slice(1100.0, 50.0), slice(1450.0, 50.0), slice(5000.0, 50.0), slice(100.0, 50.0)];
        assert_eq!(nearest_slice_per_layer(&l, &s), vec![Some(3), Some(1), None]);
    }

    #[test]
    fn imposed_mean_is_the_slice_value_and_peaks_at_the_centre() {
        let (g, mut l) = layers(32, 100.0);
        l[1].h.data_mut().fill(4.0);
        // 40 cells of 100 m (4.0e5 m²) inside a 360 m column (4.07e5 m²): the column covers
        // its cells, so the thesis' rule holds as printed.
        let s = [slice(1500.0, 360.0)];
        let near = nearest_slice_per_layer(&l, &s);
        let before = l[1].water_grams(100.0);
        let r = impose(&mut l, g, &s, &near);
        assert_eq!(r.layers_imposed, 1);
        let mut cells = Vec::new();
        for_cells_within(g, s[0].centre, 360.0, |k, d| cells.push((k, d)));
        assert_eq!(cells.len(), 40);
        assert_eq!(l[1].entraining.len(), 40, "the imposed cells are held during the step");
        assert_eq!(cells.len() as u32, r.cells_imposed);
        let mean_t = cells.iter().map(|&(k, _)| l[1].t.data()[k] as f64).sum::<f64>() / cells.len() as f64;
        let mean_h = cells.iter().map(|&(k, _)| l[1].h.data()[k]).sum::<f64>() / cells.len() as f64;
        assert!((mean_t - 400.0).abs() < 1e-3, "{mean_t}");
        let h_s = humidity_of(0.02, l[1].pi, 400.0);
        assert!(h_s > 10.0 && h_s < 20.0, "2 % water in air at ≈ 850 hPa, 400 K: {h_s} g/m³");
        assert!((mean_h - h_s).abs() < 1e-9, "{mean_h}");
        let centre = cells.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap().0;
        let edge = cells.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap().0;
        assert!(l[1].t.data()[centre] > 400.0 && l[1].t.data()[edge] < 400.0);
        // The booked water is what the layer gained.
        assert!((l[1].water_grams(100.0) - before - r.water_written_g).abs() < 1e-6 * before);
        // Other layers untouched.
        assert!(l[0].t.data().iter().all(|&t| t == 280.0));
    }

    #[test]
    fn two_columns_are_both_held_until_the_next_transfer_releases_them() {
        let (g, mut l) = layers(32, 100.0);
        let a = [slice(1500.0, 150.0)];
        let b = [ColumnSlice { centre: DVec2::new(-900.0, 700.0), ..slice(1500.0, 150.0) }];
        release_columns(&mut l);
        let (na, nb) = (nearest_slice_per_layer(&l, &a), nearest_slice_per_layer(&l, &b));
        let ra = impose(&mut l, g, &a, &na);
        let rb = impose(&mut l, g, &b, &nb);
        assert_eq!(l[1].entraining.len() as u32, ra.cells_imposed + rb.cells_imposed);
        release_columns(&mut l);
        assert!(l.iter().all(|x| x.entraining.is_empty()), "a volcano that stopped holds nothing");
    }

    #[test]
    fn annulus_excludes_the_column_and_reads_the_wind_around_it() {
        let (g, mut l) = layers(32, 100.0);
        l[0].u.data_mut().fill(6.0);
        l[0].v.data_mut().fill(-2.0);
        // A hot core inside the imposition radius must not be seen as ambient.
        for_cells_within(g, DVec2::ZERO, 200.0, |k, _| l[0].t.data_mut()[k] = 900.0);
        let near = vec![None, None, None];
        let a = ambient_levels(&l, g, &[], &near, DVec2::ZERO, 200.0);
        assert_eq!(a.len(), 3);
        assert!((a[0].temperature - 280.0).abs() < 1e-9, "{:?}", a[0]);
        // World (6, −2) → plume frame (6, 2).
        assert!((a[0].wind - DVec2::new(6.0, 2.0)).length() < 1e-6);
    }
}
