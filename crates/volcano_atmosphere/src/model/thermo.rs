//! Thermodynamics of moist air: barometric pressure (4.2), saturation vapour pressure (4.3,
//! Tetens over water, Arden Buck over ice), saturation humidity (4.4), moist static energy
//! (4.5), the intra-layer phase change with latent heat, and the air of a terrain wedge.
//!
//! Units: temperatures in K (°C only inside the vapour-pressure laws), pressures in Pa,
//! humidity and condensed water in g/m³ (thesis Table 4.2).

use volcano_core::units::{G0, M_AIR, P_SEA, R_AIR, R_STAR, T_SEA};

/// Molar mass of water (kg/kmol), same unit as [`M_AIR`].
pub const M_WATER: f64 = 18.015;
/// Specific heat of dry air at constant pressure (J/(kg·K)).
pub const CP_AIR: f64 = 1005.0;
/// Latent heat of vaporisation (J/kg).
pub const L_V: f64 = 2.501e6;
/// Latent heat of vaporisation per gram (J/g), for fields in g/m³.
pub const L_V_PER_G: f64 = L_V / 1000.0;
/// Poisson exponent R/c_p of dry air (potential temperature).
pub const KAPPA: f64 = R_AIR / CP_AIR;
/// Celsius offset.
pub const ZERO_CELSIUS: f64 = 273.15;

/// Mean atmospheric pressure of a layer at altitude `theta` (m): thesis eq. (4.2) with the
/// erratum of docs/physics/atmosphere.md §5.3 (the printed exponent lacks the altitude):
/// `Π_i = Π_sea · exp(−g · M_air · Θ_i / (R_0 · T_sea))`.
pub fn layer_pressure(theta: f64) -> f64 {
    P_SEA * (-G0 * M_AIR * theta / (R_STAR * T_SEA)).exp()
}

/// Saturation vapour pressure over liquid water (Pa), Tetens' formula, thesis eq. (4.3), with
/// the erratum of docs/physics/atmosphere.md §5.3: the printed law gives kPa, converted here to Pa.
pub fn saturation_pressure_water(t_kelvin: f64) -> f64 {
    let t = t_kelvin - ZERO_CELSIUS;
    1000.0 * 0.61078 * (17.27 * t / (t + 237.3)).exp()
}

/// Saturation vapour pressure over ice (Pa), Arden Buck (1981, 1996 coefficients):
/// `e_i = 611.15 · exp((23.036 − t/333.7) · t / (279.82 + t))`, t in °C. The "variant for the
/// negative case" of thesis §4.2.4.2; the later re-implementation used Buck for accuracy.
pub fn saturation_pressure_ice(t_kelvin: f64) -> f64 {
    let t = t_kelvin - ZERO_CELSIUS;
    611.15 * ((23.036 - t / 333.7) * (t / (279.82 + t))).exp()
}

/// Saturation vapour pressure (Pa) used by the model: Tetens over water at or above 0 °C,
/// Arden Buck over ice below. Temperatures are clamped to [150 K, 350 K] so the result stays
/// finite and positive.
pub fn saturation_pressure(t_kelvin: f64) -> f64 {
    let t = if t_kelvin.is_finite() { t_kelvin.clamp(150.0, 350.0) } else { T_SEA };
    if t >= ZERO_CELSIUS { saturation_pressure_water(t) } else { saturation_pressure_ice(t) }
}

/// Dry-air density (kg/m³) at pressure `pi` (Pa) and temperature `t` (K).
pub fn air_density(pi: f64, t: f64) -> f64 {
    pi / (R_AIR * t.max(150.0))
}

/// Saturation humidity (g/m³): thesis eq. (4.4) with the erratum of docs/physics/atmosphere.md §5.3.
/// The printed formula is a mixing ratio (kg of vapour per kg of dry air); multiplied here by
/// the air density (and 1000 g/kg) to compare with H in g/m³. The vapour pressure is capped at
/// half the layer pressure so the ratio stays finite (reached only above ≈80 °C at sea level).
pub fn saturation_humidity(t_kelvin: f64, pi: f64) -> f64 {
    let e = saturation_pressure(t_kelvin).min(0.5 * pi);
    let mixing = (M_WATER / M_AIR) * e / (pi - e);
    mixing * air_density(pi, t_kelvin) * 1000.0
}

/// A lower bound of [`saturation_humidity`] at pressure `pi` over every temperature in
/// `[t_lo, t_hi]` (K): the smaller of its values at the two ends, less 0.1 %. Over that range
/// the saturation humidity of eq. (4.4) rises with T up to the 350 K clamp of the vapour
/// pressure and falls beyond (the air density still falls), except for one step down of
/// 0.06 % at 0 °C, where Arden Buck over ice (611.15 Pa) hands over to Tetens over water
/// (610.78 Pa); the 0.1 % covers that step and rounding. `-1` (no bound) for an empty or
/// non-finite range.
pub fn saturation_humidity_floor(t_lo: f64, t_hi: f64, pi: f64) -> f64 {
    if !(t_lo.is_finite() && t_hi.is_finite() && t_lo <= t_hi) {
        return -1.0;
    }
    saturation_floor(saturation_humidity(t_lo, pi).min(saturation_humidity(t_hi, pi)))
}

/// The floor of [`saturation_humidity_floor`] from the smaller of the saturation humidities at
/// the two ends of a temperature range: 0.1 % below it.
pub fn saturation_floor(smaller_end: f64) -> f64 {
    smaller_end * (1.0 - 1e-3)
}

/// Moist static energy (J/kg), thesis eq. (4.5): `MSE = c_p T + g Θ + L_v Q`, with the
/// specific humidity `Q` derived from `H` (g/m³) and the air density.
pub fn moist_static_energy(t: f64, theta: f64, h: f64, pi: f64) -> f64 {
    let rho = air_density(pi, t);
    let q = h / (1000.0 * rho + h);
    CP_AIR * t + G0 * theta + L_V * q
}

/// Exner factor `(Π/Π_sea)^(R/c_p)`: `T = θ · exner` converts potential temperature θ.
pub fn exner(pi: f64) -> f64 {
    (pi / P_SEA).powf(KAPPA)
}

/// Temperature (K) and pressure (Pa) of the free air of a cell whose layer slab is cut by the
/// terrain (free fraction `sigma` < 1): that air fills `[Θ_T, top]` and sits on average
/// `Δz = (1 − σ) h / 2` above the layer's altitude Θ_i. The horizontal wind that pushed it into
/// the wedge lifted it by Δz within the layer, so it is colder by the dry adiabatic lapse
/// `g/c_p · Δz` (its potential temperature is the layer's) and at the barometric pressure of
/// eq. (4.2) at `Θ_i + Δz`. Phase change (4.3–4.4) is evaluated there; dry static energy
/// `c_p T + g z` is unchanged by the shift, so the layer keeps its T and only the latent heat
/// of what condenses or evaporates is added.
pub fn wedge_air(t: f64, altitude: f64, thickness: f64, sigma: f64) -> (f64, f64) {
    let dz = (1.0 - sigma.clamp(0.0, 1.0)) * 0.5 * thickness;
    (t - G0 / CP_AIR * dz, layer_pressure(altitude + dz))
}

/// Result of a phase change in one cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseChange {
    /// New humidity (g/m³).
    pub h: f64,
    /// New condensed water (g/m³).
    pub w: f64,
    /// New temperature (K).
    pub t: f64,
}

/// Evaporation/condensation in one cell (thesis §4.2.4.2, after eq. 4.4): the transfer
/// `ΔH = γ (H' − H) Δt` from W to H, integrated exactly over the step as
/// `(1 − e^{−γΔt})(H' − H)` so large `γΔt` (the thesis' 0.1 s⁻¹ × 30 s) cannot overshoot,
/// and limited by the water available (W when evaporating, H when condensing). Latent heat:
/// `ΔT = −ΔH · L_v / (ρ c_p)` (condensation warms, evaporation cools).
pub fn phase_change(t: f64, h: f64, w: f64, pi: f64, gamma: f64, dt: f64) -> PhaseChange {
    phase_change_fraction(t, h, w, pi, 1.0 - (-gamma * dt).exp())
}

/// [`phase_change`] with the step's equilibration fraction `1 − e^{−γΔt}` precomputed.
pub fn phase_change_fraction(t: f64, h: f64, w: f64, pi: f64, rate: f64) -> PhaseChange {
    let sat = saturation_humidity(t, pi);
    let dh = (rate * (sat - h)).clamp(-h, w);
    let rho = air_density(pi, t);
    let dt_latent = -dh * L_V_PER_G / (rho * CP_AIR);
    PhaseChange { h: h + dh, w: w - dh, t: t + dt_latent }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    /// Saturation vapour pressure tables (Pa): over water at −20, 0, 20, 40 °C and over ice at
    /// −20 °C (WMO/CRC Handbook values, Murphy & Koop 2005 agree to 0.1 %).
    #[test]
    fn saturation_pressure_within_one_percent_of_tables() {
        let water = [(-20.0, 125.4), (0.0, 611.2), (20.0, 2339.0), (40.0, 7384.0)];
        for (tc, table) in water {
            let e = saturation_pressure_water(tc + ZERO_CELSIUS);
            assert!(
                rel(e, table) < 0.01,
                "water at {tc} °C: {e} Pa vs {table} Pa ({:.3} %)",
                100.0 * rel(e, table)
            );
        }
        let ice = saturation_pressure_ice(-20.0 + ZERO_CELSIUS);
        assert!(rel(ice, 103.3) < 0.01, "ice at −20 °C: {ice} Pa vs 103.3 Pa");
        // The model's switch uses ice below 0 °C, water above.
        assert!((saturation_pressure(253.15) - ice).abs() < 1e-9);
        assert_eq!(saturation_pressure(293.15), saturation_pressure_water(293.15));
        // Ice pressure is below the supercooled-water one (the reason clouds glaciate).
        assert!(ice < saturation_pressure_water(253.15));
    }

    #[test]
    fn barometric_pressure_and_saturation_humidity() {
        assert!((layer_pressure(0.0) - P_SEA).abs() < 1e-9);
        // Scale height R*T/(gM) ≈ 8.43 km: about 0.888 Π_sea at 1 km.
        assert!(rel(layer_pressure(1000.0), P_SEA * (-1000.0 / 8434.0f64).exp()) < 1e-3);
        // 20 °C at sea level: ≈17.3 g/m³ of vapour at saturation.
        let hs = saturation_humidity(293.15, P_SEA);
        assert!((hs - 17.3).abs() < 0.5, "{hs}");
        // Finite even at absurd temperatures.
        for t in [f64::NAN, 0.0, 1e6, -50.0] {
            assert!(saturation_humidity(t, 50_000.0).is_finite());
        }
    }

    #[test]
    fn phase_change_conserves_water_and_releases_latent_heat() {
        // Supersaturated: condenses, warms.
        let pi = 90_000.0;
        let t = 280.0;
        let sat = saturation_humidity(t, pi);
        let pc = phase_change(t, sat + 3.0, 0.0, pi, 0.1, 30.0);
        assert!((pc.h + pc.w - (sat + 3.0)).abs() < 1e-12);
        assert!(pc.w > 2.5 && pc.t > t);
        // Latent heat: 2.85 g/m³ condensed warms ~1.1 kg/m³ air by ≈ 2.85·2501/(1.12·1005) K.
        let rho = air_density(pi, t);
        let expect = pc.w * L_V_PER_G / (rho * CP_AIR);
        assert!((pc.t - t - expect).abs() < 1e-9);
        // Subsaturated with little water: evaporates all of it, never negative.
        let pc = phase_change(t, 1.0, 0.2, pi, 0.1, 30.0);
        assert_eq!(pc.w, 0.0);
        assert!((pc.h - 1.2).abs() < 1e-12 && pc.t < t);
    }

    /// The wedge of a slab 800–1,700 m cut by ground at 1,520 m (σ = 0.2): its air sits 360 m
    /// above the layer's 1,200 m, 3.5 K colder and at the pressure of 1,560 m, so air at 97 %
    /// relative humidity in the open layer is supersaturated there and condenses, warming the
    /// layer by the latent heat only; the open cell stays clear.
    #[test]
    fn terrain_wedge_air_is_lifted_and_condenses_first() {
        let (t, pi) = (280.0, layer_pressure(1200.0));
        assert_eq!(wedge_air(t, 1200.0, 900.0, 1.0), (t, pi));
        let (tw, pw) = wedge_air(t, 1200.0, 900.0, 0.2);
        assert!((t - tw - 3.51).abs() < 0.01, "{tw}");
        assert!((pw - layer_pressure(1560.0)).abs() < 1e-6 && pw < pi);
        let h = 0.97 * saturation_humidity(t, pi);
        assert!(h > saturation_humidity(tw, pw), "the lifted wedge air must be supersaturated");
        let open = phase_change(t, h, 0.0, pi, 0.1, 30.0);
        let wedge = phase_change(tw, h, 0.0, pw, 0.1, 30.0);
        assert_eq!(open.w, 0.0);
        assert!(wedge.w > 0.1 && wedge.t > tw, "{wedge:?}");
    }

    /// The floor is below the saturation humidity at every temperature of its range, across
    /// the ice/water switch at 0 °C and the 350 K clamp.
    #[test]
    fn saturation_floor_bounds_every_temperature_of_its_range() {
        let pi = 80_000.0;
        for (lo, hi) in [(200.0, 300.0), (270.0, 273.15), (273.0, 273.2), (260.0, 600.0), (340.0, 420.0)] {
            let floor = saturation_humidity_floor(lo, hi, pi);
            assert!(floor > 0.0, "{lo}..{hi}");
            for k in 0..=20_000 {
                let t = lo + (hi - lo) * k as f64 / 20_000.0;
                assert!(saturation_humidity(t, pi) >= floor, "{t} K in {lo}..{hi}");
            }
        }
        assert_eq!(saturation_humidity_floor(f64::NAN, 300.0, pi), -1.0);
        assert_eq!(saturation_humidity_floor(300.0, 200.0, pi), -1.0);
    }

    #[test]
    fn moist_static_energy_grows_with_heat_height_and_moisture() {
        let base = moist_static_energy(280.0, 1000.0, 5.0, 90_000.0);
        assert!(moist_static_energy(281.0, 1000.0, 5.0, 90_000.0) - base > 1000.0);
        assert!((moist_static_energy(280.0, 1100.0, 5.0, 90_000.0) - base - G0 * 100.0).abs() < 1e-6);
        assert!(moist_static_energy(280.0, 1000.0, 6.0, 90_000.0) > base + 1500.0);
    }
}
