//! Physical and numerical parameters of the lava model, with thesis Table 5.2 defaults and
//! validation where they enter (constructor, RON).

use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::ConfigError;
use volcano_core::error::{finite, in_range, positive};

/// Gravity (m/s²).
pub const GRAVITY: f64 = 9.81;
/// Stefan–Boltzmann constant (W/m²/K⁴), thesis Table 5.2.
pub const STEFAN_BOLTZMANN: f64 = 5.67e-8;

/// How the lava viscosity depends on temperature.
#[derive(Debug, Clone, Copy, PartialEq, Reflect, Serialize, Deserialize)]
pub enum ViscosityModel {
    /// Isothermal: the same viscosity (Pa·s) everywhere.
    Constant(f64),
    /// Vogel–Fulcher–Tammann: `log10 η = a + b / (T − c)` (η in Pa·s, T in K). FLOWGO's basalt
    /// template is `a = −4.52, b = 5558, c = 582.9`.
    Vft {
        /// Additive constant.
        a: f64,
        /// Numerator (K).
        b: f64,
        /// Vogel temperature (K).
        c: f64,
    },
    /// A crystallising lava (FLOWGO's treatment, Harris & Rowland 2001): the VFT melt
    /// viscosity times the Einstein–Roscoe factor `(1 − φ/φ_m)^−2.5` (Roscoe 1952,
    /// φ_m = [`MAX_PACKING`]) of a crystal fraction φ that grows linearly from `phi_hot` at
    /// `t_hot` to `phi_cold` at `t_cold` as the lava cools (held outside that interval). A long
    /// flow stiffens by orders of magnitude as it cools toward the solidus.
    Crystallising {
        /// VFT additive constant.
        a: f64,
        /// VFT numerator (K).
        b: f64,
        /// VFT Vogel temperature (K).
        c: f64,
        /// Temperature (K) of `phi_hot`.
        t_hot: f64,
        /// Crystal fraction at `t_hot` and above.
        phi_hot: f64,
        /// Temperature (K) of `phi_cold`, below `t_hot`.
        t_cold: f64,
        /// Crystal fraction at `t_cold` and below, under [`MAX_PACKING`].
        phi_cold: f64,
    },
}

/// Crystal fraction at which a crystal-bearing lava locks up (Einstein–Roscoe φ_m; Marsh 1981).
pub const MAX_PACKING: f64 = 0.6;

impl ViscosityModel {
    /// FLOWGO basalt: `log10 η = −4.52 + 5558/(T − 582.9)`.
    pub const FLOWGO_BASALT: Self = Self::Vft { a: -4.52, b: 5558.0, c: 582.9 };

    /// A channel-fed basalt: FLOWGO's melt with 10 % crystals at the liquidus (1473 K), 50 %
    /// at the solidus (1273 K): ≈ 100 Pa·s at 1450 K, ≈ 5·10³ at 1350 K, ≈ 2·10⁵ at 1280 K.
    pub const CHANNEL_BASALT: Self = Self::Crystallising {
        a: -4.52,
        b: 5558.0,
        c: 582.9,
        t_hot: 1473.0,
        phi_hot: 0.1,
        t_cold: 1273.0,
        phi_cold: 0.5,
    };

    /// Viscosity (Pa·s) at temperature `t` (K). For VFT the temperature is floored at `c + 1 K`
    /// and the result clamped to [1e-2, 1e12] so the flux never sees NaN or infinity.
    pub fn viscosity(&self, t: f64) -> f64 {
        match *self {
            Self::Constant(eta) => eta,
            Self::Vft { a, b, c } => {
                let dt = (t - c).max(1.0);
                10f64.powf(a + b / dt).clamp(1e-2, 1e12)
            }
            Self::Crystallising { a, b, c, t_hot, phi_hot, t_cold, phi_cold } => {
                let melt = 10f64.powf(a + b / (t - c).max(1.0));
                let x = ((t_hot - t) / (t_hot - t_cold)).clamp(0.0, 1.0);
                let phi = phi_hot + (phi_cold - phi_hot) * x;
                (melt * (1.0 - phi / MAX_PACKING).powf(-2.5)).clamp(1e-2, 1e12)
            }
        }
    }

    fn validate(&self) -> Result<(), ConfigError> {
        match *self {
            Self::Constant(eta) => {
                in_range("viscosity", eta, 1e-2, 1e12)?;
            }
            Self::Vft { a, b, c } => {
                finite("vft_a", a)?;
                positive("vft_b", b)?;
                in_range("vft_c", c, 0.0, 2000.0)?;
            }
            Self::Crystallising { a, b, c, t_hot, phi_hot, t_cold, phi_cold } => {
                Self::Vft { a, b, c }.validate()?;
                in_range("crystals t_hot", t_hot, 300.0, 2500.0)?;
                in_range("crystals t_cold", t_cold, 300.0, t_hot - 1.0)?;
                in_range("crystals phi_hot", phi_hot, 0.0, 0.95 * MAX_PACKING)?;
                in_range("crystals phi_cold", phi_cold, phi_hot, 0.95 * MAX_PACKING)?;
            }
        }
        Ok(())
    }
}

/// Parameters of the flow, thermal and surface layers. Defaults are thesis Table 5.2 plus
/// docs/physics/lava.md §6.3 choices (emissivity 0.95, convection 60 W/m²/K, FLOWGO viscosity).
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LavaParams {
    /// Lava density ρ (kg/m³).
    pub density: f64,
    /// Thermal conductivity k (W/m/K).
    pub conductivity: f64,
    /// Heat capacity C_p (J/kg/K).
    pub heat_capacity: f64,
    /// Air temperature T_e (K).
    pub air_temperature: f64,
    /// Liquidus, the default eruption temperature T_l (K).
    pub liquidus: f64,
    /// Solidus T_s (K): lava colder than this freezes into the ground.
    pub solidus: f64,
    /// Surface emissivity for radiative cooling.
    pub emissivity: f64,
    /// Convective heat-transfer coefficient at the top (W/m²/K).
    pub convection: f64,
    /// Latent heat of crystallisation (J/kg), released between liquidus and solidus
    /// (basalt: 3.5–4.2·10⁵); 0 = none, as in the thesis.
    pub latent_heat: f64,
    /// Heat-transfer coefficient through the base into the ground (W/m²/K); 0 = insulated.
    pub base_heat_transfer: f64,
    /// Whether the lava cools at all (false = isothermal run).
    pub cooling: bool,
    /// Viscosity law.
    pub viscosity: ViscosityModel,
    /// Bingham yield strength (Pa); 0 = Newtonian.
    pub yield_strength: f64,
    /// Fraction of the explicit stability limit used for each substep, in (0, 1].
    pub cfl: f64,
    /// Most substeps per step; beyond this the mobility is capped (the flow is slowed, never
    /// made unstable) and the step report says so.
    pub max_substeps: u32,
    /// Lava thinner than this (m) is treated as absent by the surface layer and the summaries.
    pub min_thickness: f64,
    /// Ratio of crust to lava viscosity in eq (5.4) (used by folds).
    pub crust_viscosity_ratio: f64,
    /// Crust thickness (m) at which the surface velocity is fully smoothed (crust rigid).
    pub rigid_crust: f64,
    /// Stretching that leaves the crust thinner than this fraction of `2√(κt)` resets the
    /// contact time to `t = h²/(4κ)` (thesis §5.4.2).
    pub crust_reset_ratio: f64,
    /// Whether the crust slows the flow under it: a rigid crust turns the free-surface
    /// (half-Poiseuille) flux `h³/3` into the no-slip-top flux `h³/12` (factor 1/4, blended by
    /// `crust/rigid_crust`). Off for isothermal analytic runs.
    pub crust_drag: bool,
    /// Inflation (m) of lava under a rigid crust, since the crust became rigid, that tears the
    /// crust (a breakout).
    pub breakout_inflation: f64,
    /// Radius (m) of the crust torn by a breakout.
    pub breakout_radius: f64,
    /// Lagrangian surface samples per cell at most (thesis §5.4.2; [`super::samples`]);
    /// 0 = crust from the grid alone.
    pub surface_samples: u32,
    /// The samples move and update every this many steps, with the elapsed time (their
    /// physics is exact in the time step, and they move ≪ 1 cell per step); in between the
    /// grid carries the crust. 5 (0.1 s) keeps their cost near a fifth.
    pub surface_sample_every: u32,
}

impl Default for LavaParams {
    fn default() -> Self {
        Self {
            density: 2700.0,
            conductivity: 2.7,
            heat_capacity: 1000.0,
            air_temperature: 300.0,
            liquidus: 1473.0,
            solidus: 1273.0,
            emissivity: 0.95,
            convection: 60.0,
            latent_heat: 4.0e5,
            base_heat_transfer: 0.0,
            cooling: true,
            viscosity: ViscosityModel::FLOWGO_BASALT,
            yield_strength: 0.0,
            cfl: 0.8,
            max_substeps: 256,
            min_thickness: 1e-3,
            crust_viscosity_ratio: 1e3,
            rigid_crust: 0.03,
            crust_reset_ratio: 0.9,
            crust_drag: true,
            breakout_inflation: 0.3,
            breakout_radius: 1.0,
            surface_samples: 1,
            surface_sample_every: 5,
        }
    }
}

impl LavaParams {
    /// Isothermal lava of constant viscosity `eta` (Pa·s), no cooling, no crust drag.
    pub fn isothermal(eta: f64) -> Result<Self, ConfigError> {
        let p = Self {
            viscosity: ViscosityModel::Constant(eta),
            cooling: false,
            crust_drag: false,
            ..Self::default()
        };
        p.validate()?;
        Ok(p)
    }

    /// Thermal diffusivity κ = k/(ρ C_p) (m²/s); 1e-6 with Table 5.2 values.
    pub fn kappa(&self) -> f64 {
        self.conductivity / (self.density * self.heat_capacity)
    }

    /// Checks every field; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("density", self.density, 100.0, 10_000.0)?;
        positive("conductivity", self.conductivity)?;
        positive("heat_capacity", self.heat_capacity)?;
        in_range("air_temperature", self.air_temperature, 150.0, 1000.0)?;
        in_range("liquidus", self.liquidus, 500.0, 2500.0)?;
        in_range("solidus", self.solidus, self.air_temperature, self.liquidus)?;
        in_range("emissivity", self.emissivity, 0.0, 1.0)?;
        in_range("convection", self.convection, 0.0, 1e4)?;
        in_range("latent_heat", self.latent_heat, 0.0, 1e7)?;
        in_range("base_heat_transfer", self.base_heat_transfer, 0.0, 1e4)?;
        self.viscosity.validate()?;
        in_range("yield_strength", self.yield_strength, 0.0, 1e6)?;
        if !(self.cfl > 0.0 && self.cfl <= 1.0) {
            return Err(ConfigError::InvalidParameter {
                name: "cfl",
                value: self.cfl,
                reason: "must be in (0, 1]".into(),
            });
        }
        in_range("max_substeps", self.max_substeps as f64, 1.0, 100_000.0)?;
        in_range("surface_samples", self.surface_samples as f64, 0.0, 16.0)?;
        in_range("surface_sample_every", self.surface_sample_every as f64, 1.0, 1000.0)?;
        in_range("min_thickness", self.min_thickness, 1e-9, 0.1)?;
        in_range("crust_viscosity_ratio", self.crust_viscosity_ratio, 1.0, 1e12)?;
        positive("rigid_crust", self.rigid_crust)?;
        in_range("crust_reset_ratio", self.crust_reset_ratio, 0.0, 1.0)?;
        in_range("breakout_inflation", self.breakout_inflation, 0.01, 100.0)?;
        in_range("breakout_radius", self.breakout_radius, 0.0, 100.0)?;
        Ok(())
    }

    /// Parses and validates a RON text (missing fields take their defaults).
    pub fn from_ron(text: &str) -> Result<Self, ConfigError> {
        let p: Self = ron::from_str(text)?;
        p.validate()?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flowgo_viscosity_at_liquidus_and_solidus() {
        let v = ViscosityModel::FLOWGO_BASALT;
        // log10 η(1473) = −4.52 + 5558/890.1 = 1.7243 → 53.0 Pa·s
        assert!((v.viscosity(1473.0) - 10f64.powf(-4.52 + 5558.0 / 890.1)).abs() < 1e-9);
        assert!((v.viscosity(1473.0) - 53.0).abs() < 0.5);
        // colder is stiffer
        assert!(v.viscosity(1273.0) > 10.0 * v.viscosity(1473.0));
        assert!(v.viscosity(f64::NAN).is_finite());
    }

    #[test]
    fn crystals_stiffen_a_cooling_basalt_by_einstein_roscoe() {
        let (melt, lava) = (ViscosityModel::FLOWGO_BASALT, ViscosityModel::CHANNEL_BASALT);
        lava.validate().unwrap();
        // φ = 0.1 + 0.4 (1473 − T)/200; factor (1 − φ/0.6)^−2.5 (Roscoe 1952).
        for (t, phi) in [(1473.0, 0.1), (1373.0, 0.3), (1273.0, 0.5), (1500.0, 0.1), (1000.0, 0.5)] {
            let factor = lava.viscosity(t) / melt.viscosity(t);
            let roscoe = (1.0f64 - phi / 0.6).powf(-2.5);
            assert!((factor / roscoe - 1.0).abs() < 1e-9, "{t} K: {factor} vs {roscoe}");
        }
        let eta = |t| lava.viscosity(t);
        assert!((60.0..200.0).contains(&eta(1450.0)), "{}", eta(1450.0));
        assert!((2e3..1e4).contains(&eta(1350.0)), "{}", eta(1350.0));
        assert!((1e5..4e5).contains(&eta(1280.0)), "{}", eta(1280.0));
        let bad = ViscosityModel::Crystallising {
            a: -4.52,
            b: 5558.0,
            c: 582.9,
            t_hot: 1273.0,
            phi_hot: 0.1,
            t_cold: 1473.0,
            phi_cold: 0.5,
        };
        assert!(bad.validate().is_err(), "t_cold above t_hot");
    }

    #[test]
    fn defaults_valid_and_kappa_is_table_5_2() {
        let p = LavaParams::default();
        p.validate().unwrap();
        assert!((p.kappa() - 1e-6).abs() < 1e-15);
    }

    #[test]
    fn shipped_preset_is_the_default() {
        let p = LavaParams::from_ron(include_str!("../../presets/pahoehoe.ron")).unwrap();
        assert_eq!(p, LavaParams::default());
    }

    /// A misspelt field is an error naming it, not a value silently left at its default.
    #[test]
    fn a_misspelt_field_is_an_error_naming_it() {
        let e = LavaParams::from_ron("(yeild_strength: 50.0)").unwrap_err().to_string();
        assert!(e.contains("yeild_strength"), "{e}");
        let e =
            ron::from_str::<crate::model::folds::FoldParams>("(max_particle: 10)").unwrap_err().to_string();
        assert!(e.contains("max_particle"), "{e}");
        assert_eq!(LavaParams::from_ron("(yield_strength: 50.0)").unwrap().yield_strength, 50.0);
    }

    #[test]
    fn bad_params_rejected() {
        let p = LavaParams { emissivity: f64::NAN, ..Default::default() };
        assert!(p.validate().is_err());
        assert!(LavaParams::isothermal(-5.0).is_err());
        let p = LavaParams { solidus: 1600.0, ..Default::default() };
        assert!(p.validate().is_err());
        assert!(LavaParams::from_ron("(cfl: 2.0)").is_err());
        let p = LavaParams::from_ron("(yield_strength: 100.0, viscosity: Constant(1000.0))").unwrap();
        assert_eq!(p.viscosity, ViscosityModel::Constant(1000.0));
    }
}
