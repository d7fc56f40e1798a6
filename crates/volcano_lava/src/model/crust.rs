//! The crust's laws (thesis §5.4.2): its thickness from the time of contact with the air
//! (eq 5.1 and its inverse, the reset rule) and the thresholds of the no-crust and divergence
//! rules. Plain functions shared by the grid ([`super::surface`]) and the Lagrangian samples
//! ([`super::samples`]), which both apply them.

/// Crust thickness (m) above which divergence changes the crust (thesis §5.4.2: 1 cm).
pub const DIVERGENCE_MIN_CRUST: f64 = 0.01;
/// Lava thinner than this (m) and moving carries no crust (thesis §5.4.2: 20 cm).
pub const NO_CRUST_BELOW: f64 = 0.2;
/// Speed (m/s) above which lava counts as moving for the no-crust rule.
pub const MOVING_SPEED: f64 = 1e-3;

/// Crust thickness after `t` seconds of contact with the air, `2√(κt)` (thesis eq 5.1).
///
/// Its rate of change is `(1/h_crust) ∂h_crust/∂t = 1/(2t)`. Eq 5.2 as printed
/// (`(1/h) ∂h_crust/∂t = 1/t`) is inconsistent with 5.1; see docs/physics/lava.md §6. The code
/// follows eq 5.1 (the surface update integrates it exactly as `h ← √(h² + 4κ dt)`).
pub fn crust_from_contact(kappa: f64, t: f64) -> f64 {
    2.0 * (kappa * t.max(0.0)).sqrt()
}

/// Contact time giving crust `h`, `t = h²/(4κ)`: the reset after stretching (thesis §5.4.2).
pub fn contact_from_crust(kappa: f64, h: f64) -> f64 {
    h * h / (4.0 * kappa)
}

/// `eˣ`, by its Taylor series to x⁴ when |x| < 10⁻² (relative error < 10⁻¹², the usual
/// case: divergence × 0.02 s), else `f64::exp`. The divergence factor of eq (5.3) is
/// evaluated for every crusted cell each step, and `exp` would be most of the crust update.
#[inline]
pub fn exp_small(x: f64) -> f64 {
    if x.abs() < 1e-2 { exp_taylor(x) } else { x.exp() }
}

/// The Taylor polynomial of `eˣ` to x⁴ that [`exp_small`] uses for |x| < 10⁻² (the crust
/// update's vectorised loop evaluates it everywhere and redoes the other cells).
#[inline(always)]
pub fn exp_taylor(x: f64) -> f64 {
    1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0))))
}

/// Ratio of the surface speed to the depth-averaged speed of a Jeffreys (half-Poiseuille)
/// profile, `u(h)/ū = 3/2`.
pub const SURFACE_TO_MEAN: f64 = 1.5;
