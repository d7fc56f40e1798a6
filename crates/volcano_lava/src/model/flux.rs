//! The lubrication (Jeffreys) flux of the lava sheet (docs/ARCHITECTURE.md §6.1; it replaces the
//! thesis' virtual-pipes simulator, §5.4): the laws the flow substep ([`super::flow`]) and its
//! row loops evaluate per face and per cell, as plain functions. Kept apart from both so neither
//! module depends on the other.

use super::params::ViscosityModel;

/// Slope correction turning the small-slope lubrication flux `ρ g h_v³ G/(3η)` (vertical
/// thickness h_v, ground gradient G = tan θ) into Jeffreys' exact sheet flux on an incline,
/// `ρ g h_n³ sin θ/(3η)` with `h_n = h_v cos θ`: the factor is `cos⁴ θ = 1/(1 + G²)²`.
#[inline]
pub fn slope_factor(ground_gradient: f64) -> f64 {
    let c2 = 1.0 / (1.0 + ground_gradient * ground_gradient);
    c2 * c2
}

/// Bingham factor of the lubrication flux (Liu & Mei 1989): with plug height
/// `h₀ = τ_y/(ρ g |∇s|)` and `r = h₀/h`, the flux is multiplied by `1 − 3r/2 + r³/2`, and is
/// zero when `h ≤ h₀` (the basal stress does not exceed the yield strength).
#[inline]
pub fn bingham_factor(h: f64, plug: f64) -> f64 {
    if plug >= h {
        0.0
    } else {
        let r = plug / h;
        1.0 - 1.5 * r + 0.5 * r * r * r
    }
}

/// Lubrication (Jeffreys) flux per unit width (m²/s) across one face, from cell `a` to cell
/// `b` (positive = a → b), and its stability measures `(q, mobility, wave speed)`:
/// `q = −M_f · ∂s/∂n · cos⁴θ · bingham`, with the face mobility `M_f` the mean of the two cells'
/// mobilities `ρ g h³/(3η(T))` (second-order in the interior; at a front it is half the wet
/// cell's, so lava advances into dry cells). A face whose donor (higher surface) cell is dry
/// carries no lava: the flow's limiter scales it to zero.
#[inline(always)]
pub(super) fn face_flux(
    inv_dx: f64,
    yield_over_rho_g: f64,
    a: (f64, f64, f64),
    b: (f64, f64, f64),
) -> (f64, f64, f64) {
    let FaceTerms { q, m, q3, hm, zero } = face_terms(inv_dx, yield_over_rho_g, a, b);
    // Kinematic wave speed ∂q/∂h ≈ 3q/h with the thickness that dominates the mobility.
    let w = q3 / hm;
    if zero { (0.0, 0.0, 0.0) } else { (q, m, w) }
}

/// The terms of [`face_flux`] before its selection: flux `q`, face mobility `m`, the wave
/// speed's numerator `3|q|` and denominator `max(h_a, h_b)`, and `zero` (dry donor or flat
/// face: the face's three values are zeros).
pub(super) struct FaceTerms {
    pub q: f64,
    pub m: f64,
    pub q3: f64,
    pub hm: f64,
    pub zero: bool,
}

/// See [`face_flux`] and [`FaceTerms`].
#[inline(always)]
pub(super) fn face_terms(
    inv_dx: f64,
    yield_over_rho_g: f64,
    (ga, ha, ma): (f64, f64, f64),
    (gb, hb, mb): (f64, f64, f64),
) -> FaceTerms {
    let grad = ((gb + hb) - (ga + ha)) * inv_dx;
    let hd = if grad < 0.0 { ha } else { hb };
    // Evaluated for every face and selected at the end (no early return), so the row loops
    // of `flow_rows` stay branch-free; a dry donor or a flat face gives exactly zeros.
    let mut m = 0.5 * (ma + mb) * slope_factor((gb - ga) * inv_dx);
    if yield_over_rho_g > 0.0 {
        m *= bingham_factor(hd, yield_over_rho_g / grad.abs());
    }
    let q = -m * grad;
    FaceTerms { q, m, q3: 3.0 * q.abs(), hm: ha.max(hb), zero: hd <= 0.0 || grad == 0.0 }
}

/// The wave speed of [`face_flux`] from its terms, `q3 / hm`, as computed there.
#[inline(always)]
pub(super) fn wave_speed(q3: f64, hm: f64) -> f64 {
    q3 / hm
}

/// An upper bound of [`wave_speed`]`(q3, hm)` for `q3 ≥ 0` without its division:
/// `q3 · 2⁻ᵉ`, where `2ᵉ ≤ hm` is `hm`'s power of two (`+∞` for a zero, subnormal, huge,
/// negative or non-finite `hm`). `2⁻ᵉ ≥ 1/hm` exactly and rounding is monotonic, so the
/// rounded product is at least the rounded quotient (and less than twice it); `0 × ∞` gives
/// NaN only where the speed is 0 or NaN, which the maxima ignore alike.
#[inline(always)]
pub(super) fn wave_speed_bound(q3: f64, hm: f64) -> f64 {
    let e = hm.to_bits() >> 52; // biased exponent (a set sign bit makes it ≥ 2048)
    let inv = if (1..=2045).contains(&e) { f64::from_bits((2046 - e) << 52) } else { f64::INFINITY };
    q3 * inv
}

/// Cell mobility `ρ g h³/(3η(T))` (m³/s per unit gradient) times the crust factor `fac`
/// (`rg3` = ρ g/3). Zero where there is no lava.
#[inline]
pub(super) fn mobility(model: ViscosityModel, rg3: f64, h: f64, t: f64, fac: f64) -> f64 {
    match model {
        ViscosityModel::Constant(eta) => rg3 / eta * fac * h * h * h,
        model => {
            if h > 0.0 {
                rg3 * fac / model.viscosity(t) * h * h * h
            } else {
                0.0
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bound is never below the wave speed and less than about twice it, over thicknesses
    /// and fluxes spanning many binades, powers of two and the special cases.
    #[test]
    fn wave_speed_bound_is_an_upper_bound_within_two() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let special = [0.0, 5e-324, 2.2e-308, 1e-300, 0.25, 0.5, 1.0, 1.5, 3.0, 1e300, 1.7e308, f64::MAX];
        for &hm in special.iter().chain([f64::INFINITY, f64::NAN, -1.0, -0.0].iter()) {
            for &q3 in &special {
                let (w, b) = (wave_speed(q3, hm), wave_speed_bound(q3, hm));
                // NaN (0 × ∞) only where the speed is 0 or NaN: the maxima ignore both.
                assert!(w.is_nan() || b >= w || (b.is_nan() && w == 0.0), "{q3} / {hm}: {b} < {w}");
            }
        }
        // A positive number 2^k × (1 + a random fraction), k in [-80, 80).
        let mut value = || {
            let r = next();
            f64::from_bits(((1023 - 80 + (r >> 56) % 160) << 52) | (r & ((1 << 52) - 1)))
        };
        for _ in 0..200_000 {
            let (hm, q3) = (value(), 3.0 * value());
            let (w, b) = (wave_speed(q3, hm), wave_speed_bound(q3, hm));
            assert!(b >= w, "{q3} / {hm}: {b} < {w}");
            assert!(b <= 2.0 * w * (1.0 + 1e-15), "{q3} / {hm}: {b} > 2 × {w}");
        }
    }
}
