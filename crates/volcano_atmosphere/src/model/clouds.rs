//! Cloud cover and per-cell cloud forms (thesis Table 4.3, Fig 4.5) with the thresholds of the
//! later implementation (docs/physics/atmosphere.md §5.6): vertical motion below 0.15 m/s is
//! stratiform, above 0.5 m/s cumuliform; height bands at 2 km and 6 km. The k-means++ coherence
//! pass and the 3D density volume are in [`super::volume`].

use std::collections::BTreeMap;

use serde::Serialize;

use super::fields::AtmosphereState;

/// The ten cloud forms of Table 4.3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub enum CloudForm {
    /// Low, flat, blanketing.
    Stratus,
    /// Mid, sheet-like.
    Altostratus,
    /// High, thin sheet.
    Cirrostratus,
    /// Thick, low to mid, featureless.
    Nimbostratus,
    /// High, wispy.
    Cirrus,
    /// Low, puffy.
    Cumulus,
    /// Low, puffy and cohering.
    Stratocumulus,
    /// Mid, puffy layer.
    Altocumulus,
    /// High, fine-grained sheet.
    Cirrocumulus,
    /// Towering.
    Cumulonimbus,
}

/// Stratiform/cumuliform thresholds on |vertical velocity| (m/s).
pub const STRATIFORM_BELOW: f64 = 0.15;
/// See [`STRATIFORM_BELOW`].
pub const CUMULIFORM_ABOVE: f64 = 0.5;

/// Form of a cloud at `altitude` (m) whose contiguous cloudy column is `thickness` m deep,
/// with vertical motion `w` (m/s), following Table 4.3 and Fig 4.5.
pub fn classify(altitude: f64, thickness: f64, w: f64) -> CloudForm {
    let w = w.abs();
    let convective = w > CUMULIFORM_ABOVE;
    let calm = w < STRATIFORM_BELOW;
    if convective && thickness >= 2000.0 {
        return CloudForm::Cumulonimbus;
    }
    if calm && thickness >= 2000.0 && altitude < 7000.0 {
        return CloudForm::Nimbostratus;
    }
    if altitude < 2000.0 {
        if calm {
            CloudForm::Stratus
        } else if convective {
            CloudForm::Cumulus
        } else {
            CloudForm::Stratocumulus
        }
    } else if altitude < 6000.0 {
        if calm { CloudForm::Altostratus } else { CloudForm::Altocumulus }
    } else if calm {
        CloudForm::Cirrostratus
    } else if convective {
        CloudForm::Cirrocumulus
    } else {
        CloudForm::Cirrus
    }
}

/// Fraction of free cells of each layer holding more than `threshold` g/m³ of condensed water.
pub fn cloud_cover(state: &AtmosphereState, threshold: f64) -> Vec<f64> {
    state
        .layers
        .iter()
        .map(|l| {
            let mut free = 0usize;
            let mut cloudy = 0usize;
            for (w, s) in l.w.data().iter().zip(l.sigma.data()) {
                if *s > 0.0 {
                    free += 1;
                    if *w > threshold {
                        cloudy += 1;
                    }
                }
            }
            if free == 0 { 0.0 } else { cloudy as f64 / free as f64 }
        })
        .collect()
}

/// Cloud form of every cloudy cell of every layer, counted per form. The vertical motion of a
/// cell is the larger |D| of the interfaces below and above it; the thickness is that of the
/// contiguous run of cloudy layers in its column.
pub fn cloud_forms(state: &AtmosphereState, threshold: f64) -> BTreeMap<CloudForm, usize> {
    let mut counts = BTreeMap::new();
    let nl = state.layers.len();
    for k in 0..state.grid.cells() {
        let cloudy: Vec<bool> =
            state.layers.iter().map(|l| l.w.data()[k] > threshold && l.sigma.data()[k] > 0.0).collect();
        let mut i = 0;
        while i < nl {
            if !cloudy[i] {
                i += 1;
                continue;
            }
            let start = i;
            while i < nl && cloudy[i] {
                i += 1;
            }
            let thickness: f64 = state.layers[start..i].iter().map(|l| l.thickness).sum();
            for li in start..i {
                let up = state.layers[li].d.data()[k] as f64;
                let down = if li > 0 { state.layers[li - 1].d.data()[k] as f64 } else { 0.0 };
                let form = classify(state.layers[li].altitude, thickness, up.abs().max(down.abs()));
                *counts.entry(form).or_insert(0) += 1;
            }
        }
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_4_3_bands() {
        assert_eq!(classify(800.0, 500.0, 0.05), CloudForm::Stratus);
        assert_eq!(classify(1500.0, 800.0, 1.0), CloudForm::Cumulus);
        assert_eq!(classify(1500.0, 800.0, 0.3), CloudForm::Stratocumulus);
        assert_eq!(classify(4000.0, 1000.0, 0.05), CloudForm::Altostratus);
        assert_eq!(classify(4000.0, 800.0, 0.3), CloudForm::Altocumulus);
        assert_eq!(classify(9000.0, 1000.0, 0.05), CloudForm::Cirrostratus);
        assert_eq!(classify(9000.0, 1000.0, 0.3), CloudForm::Cirrus);
        assert_eq!(classify(9000.0, 800.0, 0.8), CloudForm::Cirrocumulus);
        assert_eq!(classify(1000.0, 6000.0, 2.0), CloudForm::Cumulonimbus);
        assert_eq!(classify(3000.0, 3000.0, 0.0), CloudForm::Nimbostratus);
    }
}
