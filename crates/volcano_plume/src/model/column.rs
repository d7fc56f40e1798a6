//! A slice of a sustained eruption column ([`Dynamics::Column`](super::Dynamics::Column), the
//! `physical` preset; docs/physics/plume.md §4.5). The thesis' structure is kept — Lagrangian
//! slices that entrain air (eq 3.7), feel weight, buoyancy, drag and wind (3.4–3.6), phases
//! jet → buoyant → umbrella or collapse (§3.6) — with what a sustained column needs:
//!
//! - **The slice is a segment of the column** (the wake of the slice ahead): a cylinder of
//!   radius `r` and length `h = |v| Δt_e`, the distance to the next slice emitted `Δt_e` later.
//!   It entrains only through its side, `2π r h`, and (being shielded by the slice ahead) the
//!   preset gives it no form drag. With this geometry the slice's equations are exactly the
//!   steady top-hat plume of Woods (1988) written along the trajectory: with the mass flux
//!   `Q = M / Δt_e`, `dM/dt = ρ_a U_e 2π r h` is `dQ/ds = 2π r ρ_a U_e` and
//!   `d(Mv)/dt = g (ρ_a − ρ) V` is `d(Q v)/ds = g (ρ_a − ρ) π r²`. A single slice therefore
//!   predicts the whole column's top, and every slice of the in-game column follows it.
//! - **Expansion with falling pressure**: the volume follows the equation of state of the
//!   mixture, `V = (m_air R_a + m_water R_v) T / p + m_solid / ρ_s` (Woods 1988, eq 2, with the
//!   entrained air added), `p` the ambient pressure at the slice.
//! - **Enthalpy**: entrained air brings `c_a T_a`; rising does work against gravity,
//!   `d(M c_p T)/dt = c_a T_a dM/dt − M g v_z` (Woods 1988, eq 6 without the kinetic term,
//!   which is < 3 % of the enthalpy at 275 m/s). Heat capacities are per phase.
//! - **Entrainment**: the thesis' eq 3.7, `U_e = k_s |v − v_w cos θ| + k_w |v_w sin θ|`, through
//!   the side, with the constant top-hat coefficient of Morton et al. (1956) and Woods (1988)
//!   (`k_s = 0.09`). A gas-thrust factor `(ρ/ρ_a)^{1/2}` (Ricou & Spalding 1961) is not used:
//!   it lowers the collapse threshold of the 100 m, 3 wt% vent from 72 to 60 m/s, away from
//!   the Woods-type value of ≈ 72 m/s.
//! - **Wind** enters through the horizontal momentum of the entrained air
//!   (`M v ← M v + m_a v_w`, Bursik 2001); the thesis' λ force (eq 3.6) is kept as a
//!   coefficient the preset sets to 0.
//!
//! Latent heat of condensing water is left out (matters for weak plumes in moist air, Woods
//! 1993); the entrained air's vapour is carried as water.

use bevy::math::DVec3;
use volcano_core::units::{G0, R_AIR};

use super::params::{PlumeParams, R_VAPOUR};
use super::slice::{MIN_DENSITY, Slice, SliceEnv, SliceStepReport};

/// Specific heat of dry air at constant pressure (J/kg/K).
pub const CP_AIR: f64 = 1_004.0;
/// Specific heat of water vapour at constant pressure (J/kg/K).
pub const CP_VAPOUR: f64 = 1_850.0;
/// Specific heat of the solid pyroclasts (J/kg/K), Woods (1988).
pub const CP_SOLID: f64 = 1_100.0;
/// Smallest speed (m/s) used for a slice's length `|v| Δt_e`: at the apex the speed tends to 0
/// and the steady column's radius to infinity; the floor keeps it finite (a few times the
/// radius at the neutral level) and is reported ([`SliceStepReport::length_speed_floored`]). It
/// acts only in the last seconds below the apex: tops with 0.1, 1 and 2 m/s agree to the
/// metre (10⁴–10⁹ kg/s).
pub const MIN_LENGTH_SPEED: f64 = 1.0;

/// Heat capacity of the slice (J/K).
fn heat_capacity(solid: f64, water: f64, dry_air: f64) -> f64 {
    solid * CP_SOLID + water * CP_VAPOUR + dry_air * CP_AIR
}

/// Volume (m³) of the mixture by its equation of state at temperature `t` and pressure `p`:
/// gas phases perfect, the solid incompressible.
pub fn mixture_volume(solid: f64, water: f64, dry_air: f64, t: f64, p: f64, rho_s: f64) -> f64 {
    (dry_air * R_AIR + water * R_VAPOUR) * t / p + solid / rho_s
}

/// Advances a column slice by `dt` (see the module doc). The caller (`Slice::step`) has
/// checked the phase and `dt`.
pub(crate) fn step(s: &mut Slice, p: &PlumeParams, env: &SliceEnv, dt: f64) -> SliceStepReport {
    let mut report = SliceStepReport::default();
    let z_abs = env.vent_altitude + s.position.z;
    let air = env.air.sample(z_abs);
    let (rho_a, t_a) = (air.density, air.temperature);
    let wind = (env.wind)(s.position.z);
    let speed = s.velocity.length();
    let rising = s.velocity.z >= 0.0;

    // Entrainment velocity, eq 3.7.
    let vw = wind.length();
    let cos_theta =
        if speed > 0.0 && vw > 0.0 { s.velocity.dot(wind.extend(0.0)) / (speed * vw) } else { 0.0 };
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let u_e = p.ks * (speed - vw * cos_theta).abs() + p.kw * (vw * sin_theta).abs();
    // Air through the slice's side, 2π r h, during dt.
    let side = 2.0 * std::f64::consts::PI * s.r * s.length;
    let air_volume = side * u_e * dt;
    let m_air = rho_a * air_volume;
    let vapour = (1e-3 * env.air.humidity(z_abs).max(0.0) * air_volume).min(m_air);

    // Sedimentation as in the thesis' slice (σ_col as a density decrement rate).
    let m_before = s.mass;
    let volume_before = s.volume();
    let sed = (p.sigma_col * volume_before * dt)
        .min((m_before - MIN_DENSITY * volume_before).max(0.0))
        .min(s.solid_mass.max(0.0));

    // Enthalpy: the slice's, the entrained air's, less the work of rising v_z dt.
    let dry_before = (m_before - s.solid_mass - s.water_mass).max(0.0);
    let c_before = heat_capacity(s.solid_mass, s.water_mass, dry_before);
    let enthalpy = c_before * s.temperature + ((m_air - vapour) * CP_AIR + vapour * CP_VAPOUR) * t_a
        - m_before * G0 * s.velocity.z * dt
        - sed * CP_SOLID * s.temperature;
    let solid = s.solid_mass - sed;
    let water = s.water_mass + vapour;
    let mass = m_before + m_air - sed;
    let dry = (mass - solid - water).max(0.0);
    let temperature = enthalpy / heat_capacity(solid, water, dry);

    // Volume from the equation of state at the ambient pressure.
    let volume = mixture_volume(solid, water, dry, temperature, air.pressure, p.solid_density);

    s.temperature = temperature;
    s.mass = mass;
    s.density = mass / volume;
    s.entrained_mass += m_air;
    s.sedimented_mass += sed;
    s.solid_mass = solid;
    s.water_mass = water;
    report.entrained = m_air;
    report.sedimented = sed;

    // Momentum: the slice's plus the entrained air's horizontal (wind) momentum, then weight
    // and buoyancy (eq 3.3–3.4 with the air's momentum, Bursik 2001).
    let f_vertical = (rho_a * volume - mass) * G0;
    let mut v =
        (s.velocity * m_before + wind.extend(0.0) * m_air) / mass + DVec3::Z * (dt * f_vertical / mass);
    // Geometry before the forces that need it: length from the speed, radius from the volume.
    let length_speed = v.length();
    report.length_speed_floored = length_speed < MIN_LENGTH_SPEED;
    s.length = length_speed.max(MIN_LENGTH_SPEED) * p.emission_interval();
    s.r = (volume / (std::f64::consts::PI * s.length)).sqrt();
    // Form drag (eq 3.5) on the slice's front π r², implicit as in the thesis' slice; the
    // physical preset sets C_d = 0 (the slice ahead shields it).
    let c_drag = 0.5 * rho_a * p.drag_coefficient * std::f64::consts::PI * s.r * s.r / mass;
    v /= 1.0 + c_drag * v.length() * dt;
    // The thesis' wind force (eq 3.6) on the side section 2 r h, exact relaxation; 0 in the preset.
    let k_wind = p.wind_coefficient * 2.0 * s.r * s.length / mass;
    let u = v.truncate() - wind;
    let u = u / (1.0 + k_wind * u.length() * dt);
    v = (wind + u).extend(v.z);

    s.velocity = v;
    s.position += v * dt;
    s.age += dt;
    s.apex = s.apex.max(s.position.z);
    s.update_phase(env, &mut report, rising);
    report
}
