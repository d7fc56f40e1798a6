//! Procedural amplification of the clouds (thesis §4.2.6), the voxel side: the condensed water
//! of every cloudy layer cell, interpolated between cell centres, is spread over a vertical
//! extent placed by the cell's cloud form (stratiform centred on the layer, cumuliform above it
//! with a flat base, high sheets below it with a flat top: the thesis' offsets), whose depth
//! grows with the water and is displaced by a slow relief noise, and is then upsampled with a
//! time-varying fractal ("harmonic") noise whose feature size and amplitude are keyed to the
//! form. Which form each cell has is [`super::volume`]'s business; how the volume is lit is the
//! renderer's (`volcano_render::clouds`).
//!
//! The thesis gives the placement and that the noise is harmonic and type-keyed, not the
//! profiles, the depth rule or the noise parameters: those are this module's reading, chosen
//! so that cumulus read as towers and decks do not read as layer-thick slabs.

use noise::{Fbm, MultiFractal, NoiseFn, OpenSimplex};

use super::clouds::CloudForm;
use super::fields::AtmosphereState;
use super::volume::VolumeSpec;

/// Vertical placement of a layer's cloud by form (thesis §4.2.6): stratiform centred on the
/// layer, cumuliform above it (flat base), high sheets below it (flat top), cumulonimbus a
/// full thickness above. Returns the largest (bottom, top) as offsets from the layer altitude
/// in units of its thickness; how much of it a cloud fills is [`extent_fraction`].
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
/// and finer detail than wispy stratiform ones (thesis §4.2.6).
pub fn noise_params(form: CloudForm) -> (f64, f64) {
    use CloudForm::*;
    match form {
        Cumulus | Cumulonimbus => (800.0, 0.9),
        Altocumulus | Cirrocumulus | Stratocumulus => (600.0, 0.7),
        Cirrus => (1500.0, 0.8),
        Stratus | Altostratus | Nimbostratus | Cirrostratus => (3000.0, 0.3),
    }
}

/// Which face of its extent a cloud form keeps fixed (thesis §4.2.6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Anchor {
    /// Flat base at the layer, growing upward (cumuliform).
    Base,
    /// Centred on the layer, thinning from both faces (stratiform).
    Centre,
    /// Flat top at the layer, hanging downward (cirriform).
    Top,
}

/// The face a form's extent is anchored to, from [`vertical_extent`].
pub fn anchor(form: CloudForm) -> Anchor {
    let (b, t) = vertical_extent(form);
    if b == 0.0 {
        Anchor::Base
    } else if t == 0.0 {
        Anchor::Top
    } else {
        Anchor::Centre
    }
}

/// Condensed water (g/m³) at which a cloud fills its form's whole vertical extent.
pub const FULL_EXTENT_WATER: f64 = 0.5;

/// Smallest fraction of its form's extent a cloud fills, however little water it holds.
pub const MIN_EXTENT_FRACTION: f64 = 0.3;

/// Relative amplitude of the relief noise that displaces a cloud's free face(s).
pub const RELIEF: f64 = 0.35;

/// Standard deviation of one octave of 4D OpenSimplex noise, measured (test
/// `detail_noise_has_about_the_assumed_spread`).
pub const SIMPLEX_SD: f64 = 0.31;

/// Standard deviation of the detail fBm with `octaves` octaves (persistence ½, normalised by
/// the sum of the octaves' weights as the `noise` crate does): [`SIMPLEX_SD`] · √(Σ aᵢ²) / Σ aᵢ,
/// the octaves being nearly independent. Dividing by it gives the noise unit spread.
pub fn detail_sd(octaves: usize) -> f64 {
    let weights = (1..=octaves.max(1)).map(|i| 0.5f64.powi(i as i32));
    let (sum, sum_sq) = weights.fold((0.0, 0.0), |(s, q), a| (s + a, q + a * a));
    SIMPLEX_SD * sum_sq.sqrt() / sum
}

/// How far a cloud holding little water is pushed toward breaking up, in units of the detail
/// noise's spread (see [`breakup`]).
pub const BREAKUP: f64 = 1.5;

/// Density multiplier of the detail noise `u` (the fBm divided by its [`detail_sd`]: unit
/// spread) for a form of noise amplitude `amp` holding `w` g/m³:
/// max(0, 1 + amp · (u − [`BREAKUP`] · (1 − `extent_fraction(w)`))). A wet cloud (whole
/// extent) varies by ± `amp` around its water; a thin one is shifted down so that only the
/// noise's crests keep density: thin cumulus break up into separate cells, wet ones stay
/// whole, and stratiform forms (small `amp`) stay sheets. Coverage is read from the water,
/// as in the usual coverage remap of real-time clouds; the thesis only says the noise
/// amplitude is keyed to the form.
pub fn breakup(u: f64, amp: f64, w: f64) -> f64 {
    (1.0 + amp * (u - BREAKUP * (1.0 - extent_fraction(w)))).max(0.0)
}

/// Fraction of its form's vertical extent that a cloud of `w` g/m³ of condensed water fills:
/// √(w / [`FULL_EXTENT_WATER`]), between [`MIN_EXTENT_FRACTION`] and 1. Deeper convection
/// condenses more water, so wetter cumulus stand taller (towers) and wetter decks are
/// thicker; the layer's water stays the same, only how high it is drawn changes.
pub fn extent_fraction(w: f64) -> f64 {
    if w.is_nan() {
        return MIN_EXTENT_FRACTION;
    }
    (w.max(0.0) / FULL_EXTENT_WATER).sqrt().clamp(MIN_EXTENT_FRACTION, 1.0)
}

/// Altitudes (bottom, top) in m of a `form` cloud of `w` g/m³ in a layer at `altitude` of
/// `thickness` m, its free face(s) displaced by `relief` (a noise value in about −1..1, scaled
/// by [`RELIEF`]); the anchored face stays at the thesis' placement.
pub fn cloud_extent(form: CloudForm, altitude: f64, thickness: f64, w: f64, relief: f64) -> (f64, f64) {
    let (b, t) = vertical_extent(form);
    let depth = (t - b) * thickness * extent_fraction(w) * (1.0 + RELIEF * relief).max(0.2);
    match anchor(form) {
        Anchor::Base => (altitude + b * thickness, altitude + b * thickness + depth),
        Anchor::Top => (altitude + t * thickness - depth, altitude + t * thickness),
        Anchor::Centre => {
            let mid = altitude + 0.5 * (b + t) * thickness;
            (mid - 0.5 * depth, mid + 0.5 * depth)
        }
    }
}

/// Density profile across a cloud's extent, `s` = 0 at its bottom and 1 at its top, with mean
/// 1 over 0..1 (so a column holds the cell's water times its depth before the noise):
/// - [`Anchor::Base`]: a sharp base (full density 10 % of the depth above it) fading as
///   1 − s² to a rounded top;
/// - [`Anchor::Top`]: the same upside down (sharp top, fading bottom);
/// - [`Anchor::Centre`]: 1 − (2s − 1)², densest mid-layer, both faces soft.
///
/// Zero outside 0..1.
pub fn profile(anchor: Anchor, s: f64) -> f64 {
    if !(0.0..=1.0).contains(&s) {
        return 0.0;
    }
    // ∫₀¹ min(s/0.1, 1)(1 − s²) ds = (0.05 − 0.000 25) + (0.9 − 0.999/3) = 0.616 75.
    const BASE_MEAN: f64 = 0.616_75;
    let sharp = |s: f64| (s / 0.1).min(1.0) * (1.0 - s * s) / BASE_MEAN;
    match anchor {
        Anchor::Base => sharp(s),
        Anchor::Top => sharp(1.0 - s),
        Anchor::Centre => 1.5 * (1.0 - (2.0 * s - 1.0).powi(2)),
    }
}

/// Octaves of the detail noise of a form with `feature` m features on voxels `voxel` m wide:
/// halving the feature each octave, down to no finer than two voxels (finer detail would alias),
/// 1 to 3.
pub fn octaves(feature: f64, voxel: f64) -> usize {
    let mut n = 1;
    while n < 3 && feature / 2f64.powi(n as i32) >= 2.0 * voxel {
        n += 1;
    }
    n
}

/// Noise generators for the forms present (built once per volume).
struct FormNoise {
    detail: [Option<(Fbm<OpenSimplex>, f64)>; 10],
    relief: OpenSimplex,
    seed: u32,
    voxel: f64,
}

impl FormNoise {
    fn new(seed: u32, voxel: f64) -> Self {
        Self { detail: Default::default(), relief: OpenSimplex::new(seed.wrapping_add(101)), seed, voxel }
    }

    /// The form's detail fBm and the factor that gives it unit spread.
    fn detail(&mut self, form: CloudForm) -> &(Fbm<OpenSimplex>, f64) {
        let (feature, _) = noise_params(form);
        let (seed, voxel) = (self.seed, self.voxel);
        self.detail[form as usize].get_or_insert_with(|| {
            let n = octaves(feature, voxel);
            (Fbm::<OpenSimplex>::new(seed).set_octaves(n).set_frequency(1.0 / feature), 1.0 / detail_sd(n))
        })
    }
}

/// 3D density (condensed water, g/m³, amplified by noise) on `spec`'s voxels, x fastest then
/// y then z (thesis §4.2.6). For every layer and voxel column, the water of the cloudy cells
/// is interpolated bilinearly between the four nearest cell centres (cells without a form add
/// none) and the column takes the form of the heaviest of them; the water is spread over
/// [`cloud_extent`] (relief: a slow 3D noise at twice the form's feature size) with
/// [`profile`], times [`breakup`] of an fBm detail noise at the voxel's own position and the
/// weather time. Layers add up where their clouds overlap.
pub fn density_volume(
    state: &AtmosphereState,
    forms: &[Vec<Option<CloudForm>>],
    spec: &VolumeSpec,
) -> Vec<f32> {
    let (m, nz) = (spec.nxy.max(1), spec.nz.max(1));
    let n = state.grid.n;
    let extent = state.grid.extent();
    let voxel = extent / m as f64;
    let dz = (spec.z_max - spec.z_min) / nz as f64;
    let mut noise = FormNoise::new(spec.seed, voxel);
    let t = state.time_s / 600.0;
    let mut out = vec![0.0f32; m * m * nz];
    // Cell coordinate of a voxel centre along one axis: i0, i1 and the weight of i1.
    let axis = |i: usize| {
        let g = ((i as f64 + 0.5) * n as f64 / m as f64 - 0.5).clamp(0.0, (n - 1) as f64);
        let i0 = (g.floor() as usize).min(n - 1);
        (i0, (i0 + 1).min(n - 1), g - i0 as f64)
    };
    for (li, layer) in state.layers.iter().enumerate() {
        let water = layer.w.data();
        for jy in 0..m {
            let (j0, j1, fy) = axis(jy);
            for ix in 0..m {
                let (i0, i1, fx) = axis(ix);
                let corners = [
                    (j0 * n + i0, (1.0 - fx) * (1.0 - fy)),
                    (j0 * n + i1, fx * (1.0 - fy)),
                    (j1 * n + i0, (1.0 - fx) * fy),
                    (j1 * n + i1, fx * fy),
                ];
                let mut w = 0.0;
                let mut heaviest: Option<(f64, CloudForm)> = None;
                for (k, wt) in corners {
                    let Some(f) = forms[li][k] else { continue };
                    let part = wt * water[k].max(0.0);
                    w += part;
                    if wt > 0.0 && heaviest.is_none_or(|(h, _)| part > h) {
                        heaviest = Some((part, f));
                    }
                }
                let Some((_, form)) = heaviest else { continue };
                if w <= 0.0 {
                    continue;
                }
                let x = -0.5 * extent + (ix as f64 + 0.5) * voxel;
                let y = -0.5 * extent + (jy as f64 + 0.5) * voxel;
                let (feature, amp) = noise_params(form);
                let relief =
                    noise.relief.get([x / (2.0 * feature), y / (2.0 * feature), li as f64 * 7.31 + t]);
                let (z0, z1) = cloud_extent(form, layer.altitude, layer.thickness, w, relief);
                let anchor = anchor(form);
                let (detail, unit) = noise.detail(form);
                let lo = ((z0 - spec.z_min) / dz - 0.5).ceil().max(0.0);
                let hi = ((z1 - spec.z_min) / dz - 0.5).floor().min(nz as f64 - 1.0);
                if hi < lo {
                    continue;
                }
                for iz in lo as usize..=hi as usize {
                    let z = spec.z_min + (iz as f64 + 0.5) * dz;
                    let p = profile(anchor, (z - z0) / (z1 - z0).max(1e-6));
                    // The fBm scales every coordinate by 1 / feature: time is passed pre-multiplied.
                    let d = w * p * breakup(unit * detail.get([x, y, z, t * feature]), amp, w);
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
    use crate::model::scenario::WeatherScenario;
    use crate::model::volume::coherent_forms;

    /// The `convection` scenario on 16² cells (layer 1 at 1.5 km) with no cloud anywhere.
    fn clear() -> AtmosphereState {
        let mut st = WeatherScenario::builtin("convection").unwrap().build(Some(16)).unwrap();
        for layer in &mut st.layers {
            layer.w.data_mut().fill(0.0);
        }
        st
    }

    /// Layer 1 filled with `form` everywhere, water `w(i, j)` per cell.
    fn deck(
        st: &mut AtmosphereState,
        form: CloudForm,
        w: impl Fn(usize, usize) -> f64,
    ) -> Vec<Vec<Option<CloudForm>>> {
        let n = st.grid.n;
        for (k, v) in st.layers[1].w.data_mut().iter_mut().enumerate() {
            *v = w(k % n, k / n) as _;
        }
        let mut forms = vec![vec![None; n * n]; st.layers.len()];
        forms[1] = vec![Some(form); n * n];
        forms
    }

    /// Highest occupied voxel centre (m) of every voxel column, `None` where empty.
    fn tops(vol: &[f32], spec: &VolumeSpec) -> Vec<Option<f64>> {
        let (m, dz) = (spec.nxy, (spec.z_max - spec.z_min) / spec.nz as f64);
        (0..m * m)
            .map(|c| (0..spec.nz).rev().find(|&iz| vol[iz * m * m + c] > 0.0))
            .map(|iz| iz.map(|iz| spec.z_min + (iz as f64 + 0.5) * dz))
            .collect()
    }

    #[test]
    fn density_follows_clouds_and_form_placement() {
        let s = WeatherScenario::builtin("convection").unwrap();
        let mut st = s.build(Some(16)).unwrap();
        // A 2 × 2 cumulus-like block in layer 1 (1500 m), strong updraft.
        let block = [5, 6, 21, 22];
        for k in block {
            st.layers[1].w.data_mut()[k] = 1.0;
            st.layers[0].c.data_mut()[k] = 1.5;
            st.layers[1].c.data_mut()[k] = 1.5;
        }
        let forms = coherent_forms(&st, 0.05, 4, 0.3, 1);
        assert!(block.iter().all(|&k| forms[1][k] == Some(CloudForm::Cumulus)));
        assert!(forms[1].iter().enumerate().all(|(k, f)| block.contains(&k) || f.is_none()));
        let spec = VolumeSpec { nxy: 16, nz: 40, z_min: 0.0, z_max: 4000.0, seed: 3 };
        let vol = density_volume(&st, &forms, &spec);
        assert!(vol.iter().all(|d| *d >= 0.0 && d.is_finite()));
        // Density only in the block's columns (voxels on the cell centres), and only above the
        // layer's altitude (flat base).
        for (idx, d) in vol.iter().enumerate() {
            if *d > 0.0 {
                let (col, iz) = (idx % 256, idx / 256);
                assert!(block.contains(&col), "cloud in column {col}");
                assert!(iz as f64 * 100.0 + 50.0 >= 1500.0, "cumulus below its base at level {iz}");
            }
        }
        assert!(vol.iter().any(|d| *d > 0.0));
    }

    /// Every profile has mean 1 over the extent (midpoint rule, 10,000 samples) and is sharp at
    /// its anchored face, soft at its free one(s).
    #[test]
    fn profiles_have_unit_mean_and_a_sharp_anchored_face() {
        for a in [Anchor::Base, Anchor::Centre, Anchor::Top] {
            let mean = (0..10_000).map(|i| profile(a, (i as f64 + 0.5) / 10_000.0)).sum::<f64>() / 10_000.0;
            assert!((mean - 1.0).abs() < 1e-4, "{a:?}: mean {mean}");
            assert_eq!((profile(a, -0.01), profile(a, 1.01)), (0.0, 0.0), "{a:?} outside its extent");
        }
        // Base: full density 15 % above the base, a fifth of it near the top.
        assert!(profile(Anchor::Base, 0.15) > 5.0 * profile(Anchor::Base, 0.95));
        assert!(profile(Anchor::Top, 0.85) > 5.0 * profile(Anchor::Top, 0.05));
        assert!(profile(Anchor::Centre, 0.5) > 5.0 * profile(Anchor::Centre, 0.02));
    }

    /// The noise is sampled per voxel, not at the cell centre (where the 4 × 4 voxels of one
    /// 400 m cell would be identical at every altitude, and a cloud would have no structure
    /// below the cell size): a uniform cumulus deck varies inside every cell.
    #[test]
    fn a_uniform_deck_has_structure_inside_each_cell() {
        let mut st = clear();
        let forms = deck(&mut st, CloudForm::Cumulus, |_, _| 0.5);
        let base = st.layers[1].altitude;
        let spec = VolumeSpec { nxy: 64, nz: 60, z_min: base, z_max: base + 1200.0, seed: 3 };
        let vol = density_volume(&st, &forms, &spec);
        let iz = 5; // 100 m above the base: inside every column's extent.
        let mut cvs = Vec::new();
        for cj in 2..14 {
            for ci in 2..14 {
                let v: Vec<f64> =
                    (0..16).map(|q| vol[(iz * 64 + cj * 4 + q / 4) * 64 + ci * 4 + q % 4] as f64).collect();
                let mean = v.iter().sum::<f64>() / 16.0;
                let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 16.0).sqrt();
                assert!(mean > 0.0, "cell ({ci}, {cj}) empty at 100 m above the base");
                cvs.push(sd / mean);
            }
        }
        let mean_cv = cvs.iter().sum::<f64>() / cvs.len() as f64;
        assert!(mean_cv > 0.05, "voxels inside a cell vary by {mean_cv:.4} of their mean");
    }

    /// Thesis Table 4.3: cumulus develop vertically. A deck holding 0.05 g/m³ in its western
    /// half and 0.8 g/m³ in its eastern half: the wet half's tops stand at least twice as high
    /// above the (shared, flat) base. With a fixed extent both would reach 0.6 thickness.
    #[test]
    fn wetter_cumulus_stand_taller_on_the_same_flat_base() {
        let mut st = clear();
        let forms = deck(&mut st, CloudForm::Cumulus, |i, _| if i < 8 { 0.05 } else { 0.8 });
        let base = st.layers[1].altitude;
        let spec = VolumeSpec { nxy: 16, nz: 120, z_min: base - 300.0, z_max: base + 1500.0, seed: 3 };
        let vol = density_volume(&st, &forms, &spec);
        let (m, dz) = (16, 15.0);
        let tops = tops(&vol, &spec);
        let mean_height = |cols: std::ops::Range<usize>| {
            let h: Vec<f64> = (1..15)
                .flat_map(|j| cols.clone().map(move |i| j * m + i))
                .filter_map(|c| tops[c])
                .map(|t| t - base)
                .collect();
            assert!(h.len() > 20, "{} of 70 columns hold cloud", h.len());
            h.iter().sum::<f64>() / h.len() as f64
        };
        let (dry, wet) = (mean_height(1..6), mean_height(10..15));
        assert!(wet > 2.0 * dry, "tops {dry:.0} m (dry) vs {wet:.0} m (wet) above the base");
        // The base stays flat: no cloud below it, and most cloudy columns start in the first
        // voxel above it (the others begin higher where the detail noise breaks them up).
        let starts: Vec<f64> = (0..m * m)
            .filter_map(|c| (0..spec.nz).find(|&iz| vol[iz * m * m + c] > 0.0))
            .map(|iz| spec.z_min + (iz as f64 + 0.5) * dz)
            .collect();
        assert!(starts.iter().all(|&z| z >= base), "cloud below the base");
        let flat = starts.iter().filter(|&&z| z < base + dz).count() as f64 / starts.len() as f64;
        assert!(flat > 0.6, "{:.0} % of the columns start at the base", 100.0 * flat);
    }

    /// A uniform stratus deck is not a slab: its top varies across the deck by more than two
    /// voxels (the relief noise). A tent profile would give one flat top.
    #[test]
    fn a_uniform_stratus_deck_has_relief() {
        let mut st = clear();
        let forms = deck(&mut st, CloudForm::Stratus, |_, _| 0.3);
        let alt = st.layers[1].altitude;
        let spec = VolumeSpec { nxy: 64, nz: 100, z_min: alt - 500.0, z_max: alt + 500.0, seed: 3 };
        let vol = density_volume(&st, &forms, &spec);
        let tops: Vec<f64> = tops(&vol, &spec).into_iter().map(Option::unwrap).collect();
        let (lo, hi) = tops.iter().fold((f64::MAX, f64::MIN), |(a, b), &t| (a.min(t), b.max(t)));
        assert!(hi - lo > 20.0, "deck top spans {lo:.0}–{hi:.0} m");
        assert!(
            hi <= alt + 0.25 * st.layers[1].thickness * (1.0 + RELIEF) + 10.0,
            "top {hi} above the stratiform extent"
        );
    }

    /// Bad water (NaN, negative) in a cell leaves no NaN and no negative density.
    #[test]
    fn bad_water_leaves_the_volume_finite() {
        let mut st = clear();
        let forms = deck(&mut st, CloudForm::Cumulus, |i, j| match (i + j) % 3 {
            0 => f64::NAN,
            1 => -2.0,
            _ => 0.4,
        });
        let spec = VolumeSpec { nxy: 32, nz: 30, z_min: 0.0, z_max: 3000.0, seed: 3 };
        let vol = density_volume(&st, &forms, &spec);
        assert!(vol.iter().all(|d| d.is_finite() && *d >= 0.0));
        assert!(vol.iter().any(|d| *d > 0.0));
    }

    /// The detail noise has unit spread after [`detail_sd`] (within 25 %) for 1, 2 and 3
    /// octaves, so [`breakup`]'s thresholds mean what they say.
    #[test]
    fn detail_noise_has_about_the_assumed_spread() {
        for (form, voxel) in
            [(CloudForm::Cumulus, 50.0), (CloudForm::Cumulus, 300.0), (CloudForm::Cumulus, 400.0)]
        {
            let mut noise = FormNoise::new(7, voxel);
            let (feature, _) = noise_params(form);
            let (fbm, unit) = noise.detail(form);
            let unit = *unit;
            let v: Vec<f64> = (0..20_000)
                .map(|i| {
                    let (a, b) = ((i % 141) as f64, (i / 141) as f64);
                    unit * fbm.get([
                        a * 0.37 * feature,
                        b * 0.41 * feature,
                        0.29 * feature * (a + b),
                        3.0 * feature,
                    ])
                })
                .collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt();
            let n = octaves(feature, voxel);
            assert!(mean.abs() < 0.1 && (sd - 1.0).abs() < 0.25, "{n} octaves: mean {mean:.3}, sd {sd:.3}");
        }
    }

    /// A thin cumulus deck (0.05 g/m³) breaks up into separate cells, a wet one (0.8 g/m³)
    /// stays nearly whole: the share of empty voxels 100 m above the base (about half against
    /// the one in eight where unit noise falls below −1 / 0.9).
    #[test]
    fn thin_cumulus_break_up_and_wet_ones_stay_whole() {
        let empty_share = |w: f64| {
            let mut st = clear();
            let forms = deck(&mut st, CloudForm::Cumulus, |_, _| w);
            let base = st.layers[1].altitude;
            let spec = VolumeSpec { nxy: 64, nz: 24, z_min: base, z_max: base + 1200.0, seed: 3 };
            let vol = density_volume(&st, &forms, &spec);
            let level = &vol[2 * 64 * 64..3 * 64 * 64];
            level.iter().filter(|d| **d == 0.0).count() as f64 / level.len() as f64
        };
        let (thin, wet) = (empty_share(0.05), empty_share(0.8));
        assert!(thin > 0.35 && wet < 0.2 && thin > 2.0 * wet, "empty share: thin {thin:.2}, wet {wet:.2}");
    }

    /// The finest octave is at least two voxels wide, and one more octave would not be.
    #[test]
    fn detail_octaves_stop_at_two_voxels() {
        for (feature, voxel) in
            [(400.0, 100.0), (400.0, 200.0), (3000.0, 100.0), (600.0, 50.0), (100.0, 200.0)]
        {
            let n = octaves(feature, voxel);
            assert!((1..=3).contains(&n));
            let finest = feature / 2f64.powi(n as i32 - 1);
            assert!(n == 1 || finest >= 2.0 * voxel, "{feature} m on {voxel} m voxels: {n} octaves");
            assert!(n == 3 || finest / 2.0 < 2.0 * voxel, "{feature} m on {voxel} m voxels: {n} octaves");
        }
    }
}
