//! Procedural amplification (thesis §4.2.6), model side: coherent cloud forms by k-means++
//! where the per-cell classification fragments, and the voxel grid the clouds are amplified
//! onto (the amplification itself is [`super::amplify`]). Rendering (the lit cloud pass
//! of `volcano_render::clouds`) is done elsewhere.

use bevy::reflect::Reflect;
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
    let centroids = k_means_pp_seeds(points, k, seed);
    k_means_from(points, centroids, iterations)
}

fn dist2<const D: usize>(a: &[f64; D], b: &[f64; D]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>()
}

/// The k-means++ seeding alone: `min(k, n)` points drawn with probability proportional to
/// their squared distance to the nearest seed already drawn.
pub fn k_means_pp_seeds<const D: usize>(points: &[[f64; D]], k: usize, seed: u64) -> Vec<[f64; D]> {
    if points.is_empty() || k == 0 {
        return Vec::new();
    }
    let k = k.min(points.len());
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
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
    centroids
}

/// Lloyd iterations from given centroids (a warm start keeps the clusters of an earlier
/// clustering). A centroid left without points keeps its place. Returns (centroids, labels).
pub fn k_means_from<const D: usize>(
    points: &[[f64; D]],
    mut centroids: Vec<[f64; D]>,
    iterations: usize,
) -> (Vec<[f64; D]>, Vec<usize>) {
    let mut labels = vec![0usize; points.len()];
    if centroids.is_empty() {
        return (centroids, labels);
    }
    for it in 0..iterations.max(1) {
        let mut changed = it == 0;
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

/// Seconds that weigh as much in the time feature of the 5D cell vectors as the domain's
/// width does in position: two rebuilds a minute apart are close, a day apart far.
pub const COHERENCE_TIME_S: f64 = 3_600.0;
/// Convection (m/s) per unit of the C feature, about the range of layer-scale convective
/// velocities. The classification thresholds (0.15, 0.5 m/s) are then 0.07 apart, a few cells
/// of a 64² grid: cells of one form speckled through a cloud mass of another are grouped with
/// their neighbours (the point of the pass), while masses tens of cells wide apart stay
/// apart. At 1 m/s per unit, k-means splits a checkerboard deck by form instead of by place
/// and changes nothing.
pub const CONVECTION_SCALE: f64 = 5.0;
/// Altitude (m) per unit of the altitude feature.
pub const ALTITUDE_SCALE: f64 = 10_000.0;

/// What one clustering leaves for the next (thesis §4.2.6, temporal coherence): the cloudy
/// cells it grouped, as 5D vectors (x, y, time, C, altitude, normalised) with their cloud
/// depth, and the cluster means. The next clustering groups the new cells together with
/// these, starting from these means, so a cloud advected between two rebuilds stays in its
/// cluster and keeps its form instead of being re-classified from a fresh random seeding.
#[derive(Debug, Clone, Default, PartialEq, Reflect)]
pub struct ClusterMemory {
    /// 5D vectors of the last rebuild's cloudy cells.
    pub cells: Vec<[f64; 5]>,
    /// Depth of the contiguous cloudy column of each (m).
    pub depths: Vec<f64>,
    /// Cluster means of the last k-means pass (empty if it did not run).
    pub centroids: Vec<[f64; 5]>,
    /// Whether the last rebuild found its first pass fragmented and ran k-means.
    pub clustered: bool,
}

/// Cloud form per layer and cell (`None` = clear) without memory of earlier rebuilds (a
/// one-off classification, e.g. the stand-alone run's summary); see [`coherent_forms_with`].
pub fn coherent_forms(
    state: &AtmosphereState,
    threshold: f64,
    k: usize,
    fragmentation: f64,
    seed: u64,
) -> Vec<Vec<Option<CloudForm>>> {
    coherent_forms_with(state, threshold, k, fragmentation, seed, &mut ClusterMemory::default())
}

/// Cloud form per layer and cell (`None` = clear), thesis §4.2.6. A first per-cell pass
/// classifies on altitude, cloud depth and convection C (Table 4.3; C_i of the layer's top or
/// bottom, the larger, not the total vertical velocity D = C + U). Where more than
/// `fragmentation` of the cloudy cells border a cell of another form in their layer, all
/// cloudy cells of all layers are grouped by k-means on the printed 5D vectors (position,
/// time, convection, altitude), together with the cells of the previous rebuild from
/// `memory` and starting from its cluster means (k-means++ seeding when there are none);
/// each cluster takes the form of its means and mean depth. `memory` is then replaced by
/// this rebuild's cells and means.
pub fn coherent_forms_with(
    state: &AtmosphereState,
    threshold: f64,
    k: usize,
    fragmentation: f64,
    seed: u64,
    memory: &mut ClusterMemory,
) -> Vec<Vec<Option<CloudForm>>> {
    let n = state.grid.n;
    let nl = state.layers.len();
    let cloudy = |li: usize, k: usize| {
        let l = &state.layers[li];
        l.w.data()[k] > threshold && l.sigma.data()[k] > 0.0
    };
    let c_at = |li: usize, k: usize| -> f64 {
        let up = state.layers[li].c.data()[k] as f64;
        let down = if li > 0 { state.layers[li - 1].c.data()[k] as f64 } else { 0.0 };
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
    let mut out: Vec<Vec<Option<CloudForm>>> = (0..nl)
        .map(|li| {
            let alt = state.layers[li].altitude;
            (0..n * n).map(|k| cloudy(li, k).then(|| classify(alt, depth(li, k), c_at(li, k)))).collect()
        })
        .collect();
    let mut cells: Vec<(usize, usize)> = Vec::new();
    let mut mixed = 0usize;
    for (li, forms) in out.iter().enumerate() {
        for k in (0..n * n).filter(|&k| forms[k].is_some()) {
            cells.push((li, k));
            let (i, j) = (k % n, k / n);
            let neighbours = [
                (i + 1) % n + j * n,
                (i + n - 1) % n + j * n,
                i + ((j + 1) % n) * n,
                i + ((j + n - 1) % n) * n,
            ];
            if neighbours.iter().any(|&m| forms[m].is_some() && forms[m] != forms[k]) {
                mixed += 1;
            }
        }
    }
    let scale = state.grid.extent();
    let points: Vec<[f64; 5]> = cells
        .iter()
        .map(|&(li, k)| {
            let (x, y) = state.grid.centre(k);
            [
                x / scale,
                y / scale,
                state.time_s / COHERENCE_TIME_S,
                c_at(li, k) / CONVECTION_SCALE,
                state.layers[li].altitude / ALTITUDE_SCALE,
            ]
        })
        .collect();
    let depths: Vec<f64> = cells.iter().map(|&(li, k)| depth(li, k)).collect();
    let fragmented = !cells.is_empty() && mixed as f64 > fragmentation * cells.len() as f64;
    if !fragmented || k == 0 {
        *memory = ClusterMemory { cells: points, depths, centroids: Vec::new(), clustered: false };
        return out;
    }
    // The space-time set: the previous rebuild's cells, then this one's.
    let old = if memory.cells.len() == memory.depths.len() { memory.cells.len() } else { 0 };
    let mut all = memory.cells[..old].to_vec();
    all.extend_from_slice(&points);
    let mut all_depths = memory.depths[..old].to_vec();
    all_depths.extend_from_slice(&depths);
    let start = if memory.centroids.len() == k.min(all.len())
        && memory.centroids.iter().flatten().all(|v| v.is_finite())
    {
        memory.centroids.clone()
    } else {
        k_means_pp_seeds(&all, k, seed)
    };
    let (centroids, labels) = k_means_from(&all, start, 20);
    let mut mean_depth = vec![(0.0, 0usize); centroids.len()];
    for (&l, &d) in labels.iter().zip(&all_depths) {
        mean_depth[l].0 += d;
        mean_depth[l].1 += 1;
    }
    let form_of: Vec<CloudForm> = centroids
        .iter()
        .zip(&mean_depth)
        .map(|(c, &(s, m))| {
            let d = if m > 0 { s / m as f64 } else { 0.0 };
            classify(c[4] * ALTITUDE_SCALE, d, c[3] * CONVECTION_SCALE)
        })
        .collect();
    for (&(li, k), &l) in cells.iter().zip(&labels[old..]) {
        out[li][k] = Some(form_of[l]);
    }
    *memory = ClusterMemory { cells: points, depths, centroids, clustered: true };
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::scenario::WeatherScenario;

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

    /// A calm layer (D = C + U = 0) whose convection C is strong: Table 4.3 keys on
    /// convection, so the cell is cumuliform. (Classified on |D| it would be stratus.)
    #[test]
    fn first_pass_reads_convection_not_the_total_vertical_velocity() {
        let s = WeatherScenario::builtin("convection").unwrap();
        let mut st = s.build(Some(16)).unwrap();
        st.layers[1].w.data_mut()[5] = 1.0;
        for li in [0, 1] {
            st.layers[li].c.data_mut()[5] = 1.0;
            st.layers[li].up.data_mut()[5] = -1.0;
            st.layers[li].d.data_mut()[5] = 0.0;
        }
        let forms = coherent_forms(&st, 0.05, 4, 0.3, 1);
        assert_eq!(forms[1][5], Some(CloudForm::Cumulus));
    }

    /// A 1.5 km deck whose convection alternates cell by cell between 0.2 and 0.7 m/s: the
    /// first pass is a checkerboard of stratocumulus and cumulus (fully fragmented), so k-means
    /// runs, and each cluster takes the form of its mean convection, 0.45 m/s: stratocumulus.
    #[test]
    fn a_fragmented_deck_is_clustered_into_one_form() {
        let s = WeatherScenario::builtin("convection").unwrap();
        let mut st = s.build(Some(16)).unwrap();
        let n = st.grid.n;
        let block: Vec<usize> = (2..10).flat_map(|j| (2..10).map(move |i| j * n + i)).collect();
        for &k in &block {
            st.layers[1].w.data_mut()[k] = 1.0;
            st.layers[1].c.data_mut()[k] = if (k % n + k / n).is_multiple_of(2) { 0.2 } else { 0.7 };
        }
        let first: Vec<_> =
            block.iter().map(|&k| classify(1500.0, 800.0, st.layers[1].c.data()[k] as f64)).collect();
        assert!(first.contains(&CloudForm::Cumulus) && first.contains(&CloudForm::Stratocumulus));
        let mut memory = ClusterMemory::default();
        let forms = coherent_forms_with(&st, 0.05, 4, 0.3, 1, &mut memory);
        assert!(memory.clustered, "the fragmented branch ran");
        assert_eq!(memory.cells.len(), block.len());
        assert!(
            block.iter().all(|&k| forms[1][k] == Some(CloudForm::Stratocumulus)),
            "{:?}",
            block.iter().map(|&k| forms[1][k]).collect::<Vec<_>>()
        );
    }

    /// A speckled deck (first pass fragmented) whose convection wavers around the cumuliform
    /// threshold from one rebuild to the next (0.53, 0.47, 0.53, … m/s on average): without
    /// memory each rebuild re-classifies the whole deck from its own mean and it flickers
    /// between cumulus and stratocumulus; clustered together with the previous rebuild's cells
    /// it keeps one form.
    #[test]
    fn a_deck_wavering_at_a_threshold_does_not_flicker() {
        let s = WeatherScenario::builtin("convection").unwrap();
        let base = s.build(Some(16)).unwrap();
        let n = base.grid.n;
        let block: Vec<usize> = (2..10).flat_map(|j| (2..10).map(move |i| j * n + i)).collect();
        let state_at = |step: usize| {
            let mut st = base.clone();
            st.time_s = 3_600.0 + 60.0 * step as f64;
            let mean = if step.is_multiple_of(2) { 0.53 } else { 0.47 };
            for &k in &block {
                st.layers[1].w.data_mut()[k] = 1.0;
                st.layers[1].c.data_mut()[k] =
                    mean + if (k % n + k / n).is_multiple_of(2) { 0.3 } else { -0.3 };
            }
            st
        };
        let deck_form = |forms: &[Vec<Option<CloudForm>>]| {
            let f = forms[1][block[0]];
            assert!(block.iter().all(|&k| forms[1][k] == f), "one form over the deck");
            f.unwrap()
        };
        let mut memory = ClusterMemory::default();
        let (mut with, mut without) = (Vec::new(), Vec::new());
        for step in 0..6 {
            let st = state_at(step);
            with.push(deck_form(&coherent_forms_with(&st, 0.05, 2, 0.3, 0, &mut memory)));
            assert!(memory.clustered);
            without.push(deck_form(&coherent_forms(&st, 0.05, 2, 0.3, 0)));
        }
        let flips = |v: &[CloudForm]| v.windows(2).filter(|w| w[0] != w[1]).count();
        assert_eq!(flips(&without), 5, "the memory-less pass flickers: {without:?}");
        assert_eq!(flips(&with[1..]), 0, "with memory: {with:?}");
    }
}
