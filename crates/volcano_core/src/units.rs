//! Physical constants and unit conventions.
//!
//! Conventions used across the workspace: SI units (m, s, kg, K, Pa); Bevy's world frame is
//! y-up, so a horizontal grid coordinate `(x, y)` of a [`crate::Grid2`] maps to world `(x, z)`
//! and altitude is world `y`. Budgets (masses, volumes) are `f64`.

/// Standard gravity (m/s²), as used by the US Standard Atmosphere 1976.
pub const G0: f64 = 9.80665;
/// Universal gas constant used by the US Standard Atmosphere 1976 (J/(kmol·K)).
pub const R_STAR: f64 = 8314.32;
/// Mean molar mass of dry air in the US Standard Atmosphere 1976 (kg/kmol).
pub const M_AIR: f64 = 28.9644;
/// Specific gas constant of dry air, `R*/M` (J/(kg·K)) ≈ 287.053.
pub const R_AIR: f64 = R_STAR / M_AIR;
/// Specific gas constant of water vapour, `R*/18.015` (J/(kg·K)) ≈ 461.5.
pub const R_VAPOUR: f64 = R_STAR / 18.015;
/// Effective Earth radius for geopotential conversion in the US Standard Atmosphere 1976 (m).
pub const EARTH_RADIUS: f64 = 6_356_766.0;
/// Sea-level standard pressure (Pa).
pub const P_SEA: f64 = 101_325.0;
/// Sea-level standard temperature (K).
pub const T_SEA: f64 = 288.15;
/// The fixed rate the thesis' step lengths assume: 50 Hz (Table 3.1's 0.002 s plume step is a
/// tenth of it, Table 5.2's lava Δt is one tick). The plugins never set it: the base tick is
/// whatever `Time<Fixed>` the game runs (docs/ARCHITECTURE.md §3.1). The CLI and the tests
/// that compare with the thesis set it with `Time::<Fixed>::from_hz(THESIS_TICK_HZ)`.
pub const THESIS_TICK_HZ: f64 = 50.0;
