//! The ash deposit of pyroclastic flows on the terrain (thesis §3.6 deposits mass under the
//! moving spheres; what the deposit then does is beyond the thesis).
//!
//! Deposit is mass per terrain node (kg, f64, so long runs still balance to rounding). Its
//! thickness is `m / (cell² · ρ_bulk)`. A granular deposit cannot stand steeper than its angle
//! of repose (dry pyroclastic material: about 30–35°), so [`relax_to_repose`] lets excess
//! deposit slide to lower neighbours; later flows run over the deposit surface
//! ([`deposit_surface`]), so a filled crater or valley overflows instead of growing a spike.

use volcano_core::parallel::Bands;

/// Deposit thickness (m) of `mass` kg on one node of spacing `cell` at bulk density `rho`.
pub fn thickness(mass: f64, cell: f64, rho: f64) -> f64 {
    if rho > 0.0 && cell > 0.0 { mass / (cell * cell * rho) } else { 0.0 }
}

/// Writes `surface[k] = ground[k] + thickness(mass[k])` for every node (same layout).
pub fn deposit_surface(ground: &[f32], mass: &[f64], cell: f64, rho: f64, surface: &mut [f32]) {
    for ((s, g), m) in surface.iter_mut().zip(ground).zip(mass) {
        *s = (*g as f64 + thickness(*m, cell, rho)) as f32;
    }
}

/// Adds `kg` to node `k` of `mass` and raises `surface` there by its thickness
/// ([`thickness`] at `cell`, `rho`), for every `(k, kg)` of `adds` in the list's order: what
/// `DepositMap::add` does one deposit at a time (§3.6: a moving sphere deposits under itself).
/// The grids (rows of `nx` nodes) are cut into fixed bands of rows that run in parallel; each
/// band applies the adds that fall in it in the list's order, so every node sums its deposits
/// in that order, bit for bit as one loop would, at any thread count. Sorting the adds by band
/// first also keeps each band's writes within a few hundred kB instead of scattering them over
/// the whole map. Nodes outside the grids are skipped.
pub fn add_to_nodes(
    mass: &mut [f64],
    surface: &mut [f32],
    nx: usize,
    adds: &[(u32, f64)],
    cell: f64,
    rho: f64,
) {
    const BAND_ROWS: usize = 32;
    let n = mass.len();
    if adds.is_empty() || nx == 0 || surface.len() != n || !n.is_multiple_of(nx) {
        return;
    }
    let band_len = BAND_ROWS * nx;
    let bands = n.div_ceil(band_len);
    // Counting sort by band, stable: each band's adds keep the list's order.
    let mut start = vec![0usize; bands + 1];
    for &(k, _) in adds {
        if (k as usize) < n {
            start[k as usize / band_len + 1] += 1;
        }
    }
    for b in 1..start.len() {
        start[b] += start[b - 1];
    }
    let mut fill = start.clone();
    let mut sorted = vec![(0u32, 0.0f64); start[bands]];
    for &(k, kg) in adds {
        if (k as usize) < n {
            let b = k as usize / band_len;
            sorted[fill[b]] = (k, kg);
            fill[b] += 1;
        }
    }
    Bands::of(BAND_ROWS).map((mass, surface), nx, |first_row, (m, s)| {
        let b = first_row / BAND_ROWS;
        let base = first_row * nx;
        for &(k, kg) in &sorted[start[b]..start[b + 1]] {
            let k = k as usize - base;
            m[k] += kg;
            s[k] += thickness(kg, cell, rho) as f32;
        }
    });
}

/// One Jacobi pass of granular relaxation ("thermal erosion" restricted to the loose
/// deposit): wherever the deposit surface `ground + thickness` drops more than
/// `tan_repose · cell` to a 4-neighbour, the node sheds half of its largest excess — never
/// more than its own deposit — shared among the too-low neighbours in proportion to their
/// excess. Bare terrain never moves. Mass moves node to node (nothing leaves the grid), so
/// the total is conserved to rounding and no node goes negative. Returns the mass moved (kg).
/// Written by hand: no crate relaxes a deposit layer over a fixed heightfield.
pub fn relax_to_repose(
    ground: &[f32],
    mass: &mut [f64],
    (nx, ny): (usize, usize),
    cell: f64,
    rho: f64,
    tan_repose: f64,
    scratch: &mut Vec<f64>,
) -> f64 {
    let n = nx * ny;
    if n == 0 || ground.len() != n || mass.len() != n || !(cell > 0.0 && rho > 0.0 && tan_repose >= 0.0) {
        return 0.0;
    }
    let per_metre = cell * cell * rho;
    let level = |k: usize, mass: &[f64]| ground[k] as f64 + mass[k] / per_metre;
    scratch.clear();
    scratch.resize(n, 0.0);
    let limit = tan_repose * cell;
    let mut moved = 0.0;
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            if mass[k] <= 0.0 {
                continue;
            }
            let here = level(k, mass);
            let mut nb = [(0usize, 0.0f64); 4];
            let mut count = 0;
            let (mut total, mut largest) = (0.0, 0.0f64);
            for (di, dj) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (a, b) = (i as i64 + di, j as i64 + dj);
                if a < 0 || b < 0 || a >= nx as i64 || b >= ny as i64 {
                    continue;
                }
                let q = b as usize * nx + a as usize;
                let excess = here - level(q, mass) - limit;
                if excess > 0.0 {
                    nb[count] = (q, excess);
                    count += 1;
                    total += excess;
                    largest = largest.max(excess);
                }
            }
            if count == 0 {
                continue;
            }
            let out = (0.5 * largest * per_metre).min(mass[k]);
            scratch[k] -= out;
            for &(q, excess) in &nb[..count] {
                scratch[q] += out * excess / total;
            }
            moved += out;
        }
    }
    for (m, d) in mass.iter_mut().zip(scratch.iter()) {
        *m = (*m + d).max(0.0);
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spike_on_flat_ground_relaxes_to_the_repose_angle_and_keeps_its_mass() {
        let (nx, ny, cell, rho) = (41, 41, 10.0, 1000.0);
        let ground = vec![100.0f32; nx * ny];
        let mut mass = vec![0.0; nx * ny];
        let centre = 20 * nx + 20;
        mass[centre] = 2000.0 * cell * cell * rho; // a 2 km column of ash on one node
        let before: f64 = mass.iter().sum();
        let tan = 34f64.to_radians().tan();
        let mut scratch = Vec::new();
        for _ in 0..2_000 {
            relax_to_repose(&ground, &mut mass, (nx, ny), cell, rho, tan, &mut scratch);
        }
        let after: f64 = mass.iter().sum();
        assert!(((after - before) / before).abs() < 1e-12, "mass {before} → {after}");
        assert!(mass.iter().all(|m| *m >= 0.0));
        // No neighbour pair steeper than the angle of repose (+ a small Jacobi remainder).
        let h = |k: usize| ground[k] as f64 + thickness(mass[k], cell, rho);
        let mut steepest = 0.0f64;
        for j in 0..ny {
            for i in 0..nx - 1 {
                steepest = steepest.max((h(j * nx + i) - h(j * nx + i + 1)).abs() / cell);
            }
        }
        assert!(steepest < tan * 1.05, "steepest {steepest} vs tan 34° = {tan}");
        let peak = thickness(mass[centre], cell, rho);
        eprintln!("peak {peak} m, 5 nodes out {} m", thickness(mass[centre + 5], cell, rho));
        assert!((30.0..70.0).contains(&peak), "peak {peak}");
        assert!(thickness(mass[centre + 5], cell, rho) > 1.0, "the pile spread 5 nodes out");
    }

    #[test]
    fn bare_slopes_and_gentle_deposits_do_not_move() {
        let (nx, ny, cell, rho) = (8, 8, 10.0, 1000.0);
        // A 45° bare slope with no deposit: nothing to move.
        let ground: Vec<f32> = (0..nx * ny).map(|k| (k % nx) as f32 * 10.0).collect();
        let mut mass = vec![0.0; nx * ny];
        let mut scratch = Vec::new();
        let tan = 34f64.to_radians().tan();
        assert_eq!(relax_to_repose(&ground, &mut mass, (nx, ny), cell, rho, tan, &mut scratch), 0.0);
        // A 1 m uniform layer on flat ground stays.
        let flat = vec![0.0f32; nx * ny];
        let mut layer = vec![cell * cell * rho; nx * ny];
        assert_eq!(relax_to_repose(&flat, &mut layer, (nx, ny), cell, rho, tan, &mut scratch), 0.0);
        // Bad inputs change nothing.
        assert_eq!(relax_to_repose(&flat, &mut layer, (nx, ny), 0.0, rho, tan, &mut scratch), 0.0);
        assert_eq!(relax_to_repose(&flat, &mut layer[..3], (nx, ny), cell, rho, tan, &mut scratch), 0.0);
    }

    #[test]
    fn deposit_on_a_steep_slope_slides_down_and_stops_at_the_foot() {
        // 1D ramp: 45° for 10 nodes, then flat; 2 m of ash on the ramp's top node.
        let (nx, ny, cell, rho) = (30, 1, 10.0, 1000.0);
        let ground: Vec<f32> = (0..nx).map(|i| (10usize.saturating_sub(i)) as f32 * 10.0).collect();
        let mut mass = vec![0.0; nx];
        mass[0] = 2.0 * cell * cell * rho;
        let mut scratch = Vec::new();
        for _ in 0..500 {
            relax_to_repose(&ground, &mut mass, (nx, ny), cell, rho, 0.6, &mut scratch);
        }
        let on_ramp: f64 = mass[..10].iter().sum();
        let total: f64 = mass.iter().sum();
        assert!(on_ramp < 1e-6 * total, "ash left on a 45° slope: {on_ramp} of {total}");
        assert!((total - 2.0 * cell * cell * rho).abs() < 1e-6);
    }
}
