//! Procedural amplification (thesis §4.2.6), model side: coherent cloud forms by k-means++
//! where the per-cell classification fragments, and a 3D density volume from the layers'
//! condensed water with type-keyed vertical placement and noise. Rendering (FogVolume) is
//! done elsewhere.

use noise::{NoiseFn, OpenSimplex};
use rand::{RngExt, SeedableRng};

use super::clouds::{CloudForm, classify};
use super::fields::AtmosphereState;

/// k-means with k-means++ seeding (Arthur & Vassilvitskii 2007) on `D`-dimensional points.
/// Deterministic for a seed; ties go to the lowest cluster index. Returns (centroids, labels).
///
/// Hand-written: linfa-clustering would bring ndarray and its own RNG stack for these few
/// lines.
pub fn k_means_pp<const D: usize>(
    points: &[[f64; D]],
    k: usize,
    seed: u64,
    iterations: usize,
) -> (Vec<[f64; D]>, Vec<usize>) {
    if points.is_empty() || k == 0 {
        return (Vec::new(), vec![0; points.len()]);
    }
    let k = k.min(points.len());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let dist2 = |a: &[f64; D], b: &[f64; D]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
    let mut centroids = vec![points[rng.random_range(0..points.len())]];
    let mut best: Vec<f64> = points.iter().map(|p| dist2(p, &centroids[0])).collect();
    while centroids.len() < k {
        let total: f64 = best.iter().sum();
        let next = if total <= 0.0 {
            rng.random_range(0..points.len())
        } else {
            // Draw proportionally to the squared distance to the nearest centroid.
            let mut r = rng.random_range(0.0..total);
            let mut idx = points.len() - 1;
            for (i, d) in best.iter().enumerate() {
                if r < *d {
                    idx = i;
                    break;
                }
                r -= d;
            }
            idx
        };
        centroids.push(points[next]);
        for (b, p) in best.iter_mut().zip(points) {
            *b = b.min(dist2(p, &points[next]));
        }
    }
    let mut labels = vec![0usize; points.len()];
    for _ in 0..iterations {
        let mut changed = false;
        for (l, p) in labels.iter_mut().zip(points) {
            let (mut bi, mut bd) = (0, f64::INFINITY);
            for (ci, c) in centroids.iter().enumerate() {
                let d = dist2(p, c);
                if d < bd {
                    (bi, bd) = (ci, d);
                }
            }
            changed |= *l != bi;
            *l = bi;
        }
        let mut sums = vec![([0.0; D], 0usize); centroids.len()];
        for (l, p) in labels.iter().zip(points) {
            for (s, x) in sums[*l].0.iter_mut().zip(p) {
                *s += x;
            }
            sums[*l].1 += 1;
        }
        for (c, (s, count)) in centroids.iter_mut().zip(&sums) {
            if *count > 0 {
                for (ci, si) in c.iter_mut().zip(s) {
                    *ci = si / *count as f64;
                }
            }
        }
        if !changed {
            break;
        }
    }
    (centroids, labels)
}

/// Cloud form per layer and cell (`None` = clear), thesis §4.2.6: a first per-cell pass
/// (Table 4.3); where more than `fragmentation` of a layer's cloudy cells border a cell of a
/// different form, its cloudy cells are grouped by k-means++ on (x, y, time, |D|, altitude),
/// normalised, and each cluster takes the form of its mean.
pub fn coherent_forms(
    state: &AtmosphereState,
    threshold: f64,
    k: usize,
    fragmentation: f64,
    seed: u64,
) -> Vec<Vec<Option<CloudForm>>> {
    let n = state.grid.n;
    let nl = state.layers.len();
    let cloudy = |li: usize, k: usize| {
        let l = &state.layers[li];
        l.w.data()[k] > threshold && l.sigma.data()[k] > 0.0
    };
    let w_at = |li: usize, k: usize| -> f64 {
        let up = state.layers[li].d.data()[k] as f64;
        let down = if li > 0 { state.layers[li - 1].d.data()[k] as f64 } else { 0.0 };
        up.abs().max(down.abs())
    };
    let depth = |li: usize, k: usize| -> f64 {
        let (mut lo, mut hi) = (li, li);
        while lo > 0 && cloudy(lo - 1, k) {
            lo -= 1;
        }
        while hi + 1 < nl && cloudy(hi + 1, k) {
            hi += 1;
        }
        state.layers[lo..=hi].iter().map(|l| l.thickness).sum()
    };
    let mut out = Vec::with_capacity(nl);
    for li in 0..nl {
        let layer = &state.layers[li];
        let mut forms: Vec<Option<CloudForm>> = (0..n * n)
            .map(|k| cloudy(li, k).then(|| classify(layer.altitude, depth(li, k), w_at(li, k))))
            .collect();
        let cells: Vec<usize> = (0..n * n).filter(|&k| forms[k].is_some()).collect();
        let mixed = cells
            .iter()
            .filter(|&&k| {
                let (i, j) = (k % n, k / n);
                [
                    (i + 1) % n + j * n,
                    (i + n - 1) % n + j * n,
                    i + ((j + 1) % n) * n,
                    i + ((j + n - 1) % n) * n,
                ]
                .iter()
                .any(|&m| forms[m].is_some() && forms[m] != forms[k])
            })
            .count();
        if !cells.is_empty() && mixed as f64 > fragmentation * cells.len() as f64 {
            let scale = state.grid.extent();
            let points: Vec<[f64; 5]> = cells
                .iter()
                .map(|&k| {
                    let (x, y) = state.grid.centre(k);
                    [x / scale, y / scale, state.time_s / 86_400.0, w_at(li, k), layer.altitude / 10_000.0]
                })
                .collect();
            let (centroids, labels) = k_means_pp(&points, k, seed ^ li as u64, 20);
            let mean_depth: Vec<f64> = (0..centroids.len())
                .map(|c| {
                    let (s, m) = cells
                        .iter()
                        .zip(&labels)
                        .filter(|(_, l)| **l == c)
                        .fold((0.0, 0usize), |(s, m), (&k, _)| (s + depth(li, k), m + 1));
                    if m > 0 { s / m as f64 } else { layer.thickness }
                })
                .collect();
            for (&k, &l) in cells.iter().zip(&labels) {
                forms[k] = Some(classify(layer.altitude, mean_depth[l], centroids[l][3]));
            }
        }
        out.push(forms);
    }
    out
}

/// Regular voxel grid covering the atmosphere's footprint from `z_min` to `z_max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeSpec {
    /// Voxels along x and y.
    pub nxy: usize,
    /// Voxels along z.
    pub nz: usize,
    /// Bottom altitude (m).
    pub z_min: f64,
    /// Top altitude (m).
    pub z_max: f64,
    /// Noise seed.
    pub seed: u32,
}

/// Vertical placement of a layer's cloud by form (thesis §4.2.6): stratiform centred on the
/// layer, cumuliform above it (flat base), high sheets below it (flat top), cumulonimbus a
/// full thickness above. Returns (bottom, top) as offsets from the layer altitude in units of
/// its thickness.
pub fn vertical_extent(form: CloudForm) -> (f64, f64) {
    use CloudForm::*;
    match form {
        Stratus | Altostratus | Nimbostratus | Stratocumulus => (-0.25, 0.25),
        Cumulus | Altocumulus => (0.0, 0.6),
        Cumulonimbus => (0.0, 1.0),
        Cirrus | Cirrostratus | Cirrocumulus => (-0.4, 0.0),
    }
}

/// Noise (feature size in m, relative amplitude) per form: puffy cumuliform clouds get more
/// and finer detail than wispy stratiform ones.
pub fn noise_params(form: CloudForm) -> (f64, f64) {
    use CloudForm::*;
    match form {
        Cumulus | Cumulonimbus => (400.0, 0.9),
        Altocumulus | Cirrocumulus | Stratocumulus => (600.0, 0.7),
        Cirrus => (1500.0, 0.8),
        Stratus | Altostratus | Nimbostratus | Cirrostratus => (3000.0, 0.3),
    }
}

/// 3D density (condensed water, g/m³, amplified by noise) on `spec`'s voxels, x fastest then
/// y then z. Each cloudy layer cell spreads its water over its form's vertical extent with a
/// tent profile; voxel columns sample the nearest layer cell.
pub fn density_volume(
    state: &AtmosphereState,
    forms: &[Vec<Option<CloudForm>>],
    spec: &VolumeSpec,
) -> Vec<f32> {
    let (m, nz) = (spec.nxy.max(1), spec.nz.max(1));
    let n = state.grid.n;
    let dz = (spec.z_max - spec.z_min) / nz as f64;
    let noise = OpenSimplex::new(spec.seed);
    let mut out = vec![0.0f32; m * m * nz];
    for (li, layer) in state.layers.iter().enumerate() {
        for jy in 0..m {
            for ix in 0..m {
                let k = (jy * n / m) * n + ix * n / m;
                let Some(form) = forms[li][k] else { continue };
                let w = layer.w.data()[k];
                let (b, t) = vertical_extent(form);
                let (z0, z1) = (layer.altitude + b * layer.thickness, layer.altitude + t * layer.thickness);
                let (feature, amp) = noise_params(form);
                let (x, y) = state.grid.centre(k);
                for iz in 0..nz {
                    let z = spec.z_min + (iz as f64 + 0.5) * dz;
                    if z < z0 || z > z1 {
                        continue;
                    }
                    let mid = 0.5 * (z0 + z1);
                    let tent = 1.0 - (z - mid).abs() / (0.5 * (z1 - z0)).max(1e-6);
                    let nz_val = noise.get([x / feature, y / feature, z / feature, state.time_s / 600.0]);
                    let d = w * 2.0 * tent * (1.0 + amp * nz_val).max(0.0);
                    out[(iz * m + jy) * m + ix] += d as f32;
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::scenario::Scenario;

    #[test]
    fn k_means_pp_separates_clear_groups_deterministically() {
        let mut pts = Vec::new();
        for i in 0..30 {
            let e = (i % 5) as f64 * 0.01;
            pts.push([0.0 + e, 0.0]);
            pts.push([10.0 + e, 10.0]);
            pts.push([0.0 + e, 10.0]);
        }
        let (c, l) = k_means_pp(&pts, 3, 42, 50);
        assert_eq!(c.len(), 3);
        for g in 0..3 {
            let first = l[g];
            assert!((0..30).all(|i| l[3 * i + g] == first), "group {g} split");
        }
        assert_eq!(k_means_pp(&pts, 3, 42, 50).1, l, "same seed, same clusters");
    }

    #[test]
    fn density_follows_clouds_and_form_placement() {
        let s = Scenario::builtin("convection").unwrap();
        let mut st = s.build(Some(16)).unwrap();
        // One cumulus-like cell in layer 1 (1500 m), strong updraft.
        st.layers[1].w.data_mut()[5] = 1.0;
        st.layers[0].d.data_mut()[5] = 1.5;
        st.layers[1].d.data_mut()[5] = 1.5;
        let forms = coherent_forms(&st, 0.05, 4, 0.3, 1);
        assert_eq!(forms[1][5], Some(CloudForm::Cumulus));
        assert!(forms[1].iter().enumerate().all(|(k, f)| k == 5 || f.is_none()));
        let spec = VolumeSpec { nxy: 16, nz: 40, z_min: 0.0, z_max: 4000.0, seed: 3 };
        let vol = density_volume(&st, &forms, &spec);
        assert!(vol.iter().all(|d| *d >= 0.0 && d.is_finite()));
        // Density only in column 5, and only above the layer's altitude (flat base).
        for (idx, d) in vol.iter().enumerate() {
            if *d > 0.0 {
                let (col, iz) = (idx % 256, idx / 256);
                assert_eq!(col, 5);
                assert!(iz as f64 * 100.0 + 50.0 >= 1500.0, "cumulus below its base at level {iz}");
            }
        }
        assert!(vol.iter().any(|d| *d > 0.0));
    }
}
