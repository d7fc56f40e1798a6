//! The lubrication (Jeffreys) flux of the lava sheet (docs/physics/lava.md §6.1; it replaces the
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
    (ga, ha, ma): (f64, f64, f64),
    (gb, hb, mb): (f64, f64, f64),
) -> (f64, f64, f64) {
    let grad = ((gb + hb) - (ga + ha)) * inv_dx;
    let hd = if grad < 0.0 { ha } else { hb };
    // Evaluated for every face and selected at the end (no early return), so the row loops
    // of `flow_rows` stay branch-free; a dry donor or a flat face gives exactly zeros.
    let mut m = 0.5 * (ma + mb) * slope_factor((gb - ga) * inv_dx);
    if yield_over_rho_g > 0.0 {
        m *= bingham_factor(hd, yield_over_rho_g / grad.abs());
    }
    let q = -m * grad;
    // Kinematic wave speed ∂q/∂h ≈ 3q/h with the thickness that dominates the mobility.
    let w = 3.0 * q.abs() / ha.max(hb);
    if hd <= 0.0 || grad == 0.0 { (0.0, 0.0, 0.0) } else { (q, m, w) }
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
