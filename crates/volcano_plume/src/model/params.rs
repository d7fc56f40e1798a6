//! Eruption parameters (thesis Table 3.1) with validation, and presets.

use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::atmosphere::AtmosphereModel;
use volcano_core::error::{ConfigError, in_range, positive};

use super::wind::WindProfile;

/// Parameters of the slice model. Defaults are the thesis' Table 3.1 (see [`Preset::Thesis`]).
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlumeParams {
    /// Ejection speed v₀ (m/s).
    pub v0: f64,
    /// Vent radius r₀ (m); the first slice's size.
    pub r0: f64,
    /// Initial density ρ₀ of the mixture (kg/m³).
    pub rho0: f64,
    /// Initial temperature T₀ (K).
    pub t0: f64,
    /// Drag coefficient C_d of eq 3.5 (dimensionless).
    pub drag_coefficient: f64,
    /// Wind force coefficient λ of eq 3.6 (kg/m³).
    pub wind_coefficient: f64,
    /// Entrainment coefficient k_s (still air), eq 3.7.
    pub ks: f64,
    /// Entrainment coefficient k_w (cross wind), eq 3.7.
    pub kw: f64,
    /// Air entrainment time τ (s): the ring of entrained air spans `[r, r + τ U_e]`.
    pub tau: f64,
    /// Column sedimentation σ_col, read as a density decrement rate (kg/m³/s): the slice loses
    /// `σ_col · V · Δt` kg per step (how the authors' prototype applies Table 3.1's value).
    pub sigma_col: f64,
    /// Time step of the slice integration (s); Table 3.1: 0.002 s.
    pub dt: f64,
    /// Contraction on mixing (`V' = V T^{i+1}/T^i`, as in the text). Off reproduces the
    /// authors' released prototype (docs/ARCHITECTURE.md §4.1).
    pub contraction: bool,
    /// Ambient air profile.
    pub atmosphere: AtmosphereModel,
    /// Altitude of the vent above sea level (m).
    pub vent_altitude: f64,
    /// Wind by altitude above the vent.
    pub wind: WindProfile,
    /// Magmatic gas (water vapour) mass fraction n of the erupted mixture. The rest, `1 − n`,
    /// is solid (ash) that the column sheds into the atmosphere when coupled. The thesis has
    /// no gas fraction; 0.03 (3 wt%, the usual Plinian value, e.g. Woods 1988) is the default.
    pub gas_fraction: f64,
}

impl Default for PlumeParams {
    fn default() -> Self {
        Self {
            v0: 150.0,
            r0: 100.0,
            rho0: 200.0,
            t0: 1273.0,
            drag_coefficient: 0.04,
            wind_coefficient: 600.0,
            ks: 0.09,
            kw: 0.9,
            tau: 5.0,
            sigma_col: 5e-8,
            dt: 0.002,
            contraction: true,
            atmosphere: AtmosphereModel::Thesis,
            vent_altitude: 0.0,
            wind: WindProfile::Calm,
            gas_fraction: 0.03,
        }
    }
}

/// Named parameter sets, shipped as RON files in `crates/volcano_plume/presets/` (the files are
/// the source of truth and document what each changes from Table 3.1 and why).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Reflect, Serialize, Deserialize)]
pub enum Preset {
    /// The thesis as written: Table 3.1, v₀ = 150 m/s, contraction on, the printed ISA law.
    /// With these values the column collapses at ≈1.9 km (docs/ARCHITECTURE.md §4.1).
    Thesis,
    /// Table 3.1 at v₀ = 200 m/s with a light wind: a Plinian column with an umbrella (Fig 3.4).
    PlinianShowcase,
    /// Table 3.1 at v₀ = 70 m/s: a collapsing column (Fig 3.6).
    PyroclasticShowcase,
}

impl Preset {
    /// Every preset.
    pub const ALL: [Preset; 3] = [Preset::Thesis, Preset::PlinianShowcase, Preset::PyroclasticShowcase];

    /// File name stem of the preset.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Thesis => "thesis",
            Preset::PlinianShowcase => "plinian_showcase",
            Preset::PyroclasticShowcase => "pyroclastic_showcase",
        }
    }

    /// The preset's RON text.
    pub fn ron(self) -> &'static str {
        match self {
            Preset::Thesis => include_str!("../../presets/thesis.ron"),
            Preset::PlinianShowcase => include_str!("../../presets/plinian_showcase.ron"),
            Preset::PyroclasticShowcase => include_str!("../../presets/pyroclastic_showcase.ron"),
        }
    }

    /// The preset by file name stem.
    pub fn by_name(name: &str) -> Result<Self, ConfigError> {
        Self::ALL.into_iter().find(|p| p.name() == name).ok_or_else(|| ConfigError::UnknownName {
            kind: "plume preset",
            name: name.to_string(),
            known: Self::ALL.map(Preset::name).join(", "),
        })
    }

    /// The parameters of this preset. The embedded files are checked by the crate's tests, so
    /// the fallback to Table 3.1 cannot be reached in a released build.
    pub fn params(self) -> PlumeParams {
        PlumeParams::from_ron(self.ron()).unwrap_or_default()
    }
}

impl PlumeParams {
    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("v0", self.v0, 0.1, 1_000.0)?;
        in_range("r0", self.r0, 0.1, 5_000.0)?;
        in_range("rho0", self.rho0, 1e-3, 3_000.0)?;
        in_range("t0", self.t0, 200.0, 2_000.0)?;
        in_range("drag_coefficient", self.drag_coefficient, 0.0, 10.0)?;
        in_range("wind_coefficient", self.wind_coefficient, 0.0, 1e5)?;
        in_range("ks", self.ks, 0.0, 1.0)?;
        in_range("kw", self.kw, 0.0, 5.0)?;
        in_range("tau", self.tau, 0.0, 100.0)?;
        in_range("sigma_col", self.sigma_col, 0.0, 1e-2)?;
        positive("dt", self.dt)?;
        in_range("dt", self.dt, 1e-5, 0.1)?;
        in_range("vent_altitude", self.vent_altitude, -1_000.0, 9_000.0)?;
        in_range("gas_fraction", self.gas_fraction, 0.0, 0.99)?;
        self.wind.validate()
    }

    /// Parses and validates a RON text (missing fields take the thesis values).
    pub fn from_ron(text: &str) -> Result<Self, ConfigError> {
        let p: Self = ron::from_str(text)?;
        p.validate()?;
        Ok(p)
    }

    /// Seconds between slice emissions, `r₀ / (2 v₀)` (§3.4.1).
    pub fn emission_interval(&self) -> f64 {
        self.r0 / (2.0 * self.v0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_presets_parse_and_validate() {
        for p in Preset::ALL {
            PlumeParams::from_ron(p.ron()).unwrap_or_else(|e| panic!("{}: {e}", p.name()));
            assert_eq!(Preset::by_name(p.name()).unwrap(), p);
        }
        assert_eq!(Preset::Thesis.params(), PlumeParams::default(), "thesis.ron is Table 3.1");
        assert_eq!(Preset::PlinianShowcase.params().v0, 200.0);
        assert_eq!(Preset::PyroclasticShowcase.params().v0, 70.0);
        assert!(Preset::by_name("vesuvius").unwrap_err().to_string().contains("plinian_showcase"));
    }
}
