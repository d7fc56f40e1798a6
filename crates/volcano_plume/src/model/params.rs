//! Eruption parameters (thesis Table 3.1) with validation, and presets.

use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::atmosphere::{AtmosphereModel, AtmosphereProfile};
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
    /// authors' released prototype (docs/physics/plume.md §4.1).
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
    /// With [`Dynamics::Column`] it also sets the vent density ([`PlumeParams::vent_density`]).
    pub gas_fraction: f64,
    /// Which slice equations run: the thesis' (Table 3.1 reading, docs/physics/plume.md §4.1)
    /// or the physical column (§4.5). The thesis' ones by default.
    pub dynamics: Dynamics,
    /// Density of the solid (ash) phase (kg/m³), for the vent density and the column's
    /// equation of state ([`Dynamics::Column`] only). 2,500 kg/m³ as the dense-rock density of
    /// Mastin et al. (2009).
    pub solid_density: f64,
    /// Relative humidity (0–1) of the ambient air of a stand-alone run (a coupled column reads
    /// the simulated atmosphere's moisture instead). 0: the dry standard profile.
    pub relative_humidity: f64,
    /// Seconds between the column's slices ([`Dynamics::Column`]); 0 (the default) takes
    /// `r₀/v₀`, a first slice as long as it is wide. The column's dynamics do not depend on it
    /// (every extensive quantity of a slice scales with it): it sets how finely the column is
    /// cut into slices, i.e. how many entities it takes.
    pub slice_interval: f64,
    /// Spreading coefficient λ of the umbrella as a gravity current ([`Dynamics::Column`]),
    /// `R = (3 λ N Q / 2π)^{1/3} t^{2/3}` (Woods & Kienle 1994; λ = 0.2 from Suzuki &
    /// Koyaguchi 2009, as used by Costa et al. 2013).
    pub umbrella_lambda: f64,
}

/// The slice equations a [`PlumeParams`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Reflect, Serialize, Deserialize)]
pub enum Dynamics {
    /// The thesis' slice (§3.4 as read in docs/physics/plume.md §4.1): `V = π r³`, a slice every
    /// `r₀/(2v₀)`, the ring entrainment of eq 3.7, contraction on mixing, the `v r/d` umbrella.
    #[default]
    Thesis,
    /// A slice of a sustained column (docs/physics/plume.md §4.5, `model::column`): a cylinder as
    /// long as the distance to the next slice, volume from the equation of state of gas and
    /// solid (expands as the pressure falls), Woods' (1988) entrainment and enthalpy, a
    /// gravity-current umbrella. Reduces to Woods' steady top-hat plume.
    Column,
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
            dynamics: Dynamics::Thesis,
            solid_density: 2_500.0,
            relative_humidity: 0.0,
            slice_interval: 0.0,
            umbrella_lambda: 0.2,
        }
    }
}

/// Named parameter sets, shipped as RON files in `crates/volcano_plume/presets/` (the files are
/// the source of truth and document what each changes from Table 3.1 and why).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Reflect, Serialize, Deserialize)]
pub enum Preset {
    /// The thesis as written: Table 3.1, v₀ = 150 m/s, contraction on, the printed ISA law.
    /// With these values the column collapses at ≈1.9 km (docs/physics/plume.md §4.1).
    Thesis,
    /// Table 3.1 at v₀ = 200 m/s with a light wind: a Plinian column with an umbrella (Fig 3.4).
    PlinianShowcase,
    /// Table 3.1 at v₀ = 70 m/s: a collapsing column (Fig 3.6).
    PyroclasticShowcase,
    /// The physical column ([`Dynamics::Column`]) calibrated against Mastin et al. (2009) and
    /// Costa et al. (2016): 3 wt% gas, 1,273 K, r₀ = 100 m, v₀ = 150 m/s (2.7·10⁷ kg/s).
    Physical,
}

impl Preset {
    /// Every preset.
    pub const ALL: [Preset; 4] =
        [Preset::Thesis, Preset::PlinianShowcase, Preset::PyroclasticShowcase, Preset::Physical];

    /// File name stem of the preset.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Thesis => "thesis",
            Preset::PlinianShowcase => "plinian_showcase",
            Preset::PyroclasticShowcase => "pyroclastic_showcase",
            Preset::Physical => "physical",
        }
    }

    /// The preset's RON text.
    pub fn ron(self) -> &'static str {
        match self {
            Preset::Thesis => include_str!("../../presets/thesis.ron"),
            Preset::PlinianShowcase => include_str!("../../presets/plinian_showcase.ron"),
            Preset::PyroclasticShowcase => include_str!("../../presets/pyroclastic_showcase.ron"),
            Preset::Physical => include_str!("../../presets/physical.ron"),
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
        in_range("solid_density", self.solid_density, 100.0, 5_000.0)?;
        in_range("relative_humidity", self.relative_humidity, 0.0, 1.0)?;
        in_range("umbrella_lambda", self.umbrella_lambda, 0.01, 10.0)?;
        in_range("slice_interval", self.slice_interval, 0.0, 600.0)?;
        if self.dynamics == Dynamics::Column {
            // The mixture must hold some gas to expand, and the vent density must be finite.
            in_range("gas_fraction", self.gas_fraction, 1e-3, 0.99)?;
        }
        self.wind.validate()
    }

    /// Parses and validates a RON text (missing fields take the thesis values).
    pub fn from_ron(text: &str) -> Result<Self, ConfigError> {
        let p: Self = ron::from_str(text)?;
        p.validate()?;
        Ok(p)
    }

    /// Seconds between slice emissions: `r₀ / (2 v₀)` for the thesis (§3.4.1); for the column
    /// `slice_interval`, or `r₀ / v₀` when it is 0. A column slice leaves the vent as a
    /// cylinder of radius r₀ and length `v₀ Δt_e`, so it carries exactly the vent's mass flux
    /// `ρ₀ π r₀² v₀` over the interval.
    pub fn emission_interval(&self) -> f64 {
        match self.dynamics {
            Dynamics::Thesis => self.r0 / (2.0 * self.v0),
            Dynamics::Column if self.slice_interval > 0.0 => self.slice_interval,
            Dynamics::Column => self.r0 / self.v0,
        }
    }

    /// Length of a slice at the vent (m): `r₀` for the thesis, `v₀ Δt_e` for the column.
    pub fn vent_slice_length(&self) -> f64 {
        match self.dynamics {
            Dynamics::Thesis => self.r0,
            Dynamics::Column => self.v0 * self.emission_interval(),
        }
    }

    /// The ambient air of a stand-alone run: the chosen profile at `relative_humidity`.
    pub fn air(&self) -> super::humid::HumidAir {
        super::humid::HumidAir { base: self.atmosphere, relative_humidity: self.relative_humidity }
    }

    /// Density of the erupted mixture at the vent (kg/m³): `rho0` for the thesis; for the
    /// column the gas–solid mixture at the vent's ambient pressure (pressure-balanced vent),
    /// `1/ρ = n R_v T₀ / p + (1 − n)/ρ_s` (Woods 1988, eq 2).
    pub fn vent_density(&self) -> f64 {
        match self.dynamics {
            Dynamics::Thesis => self.rho0,
            Dynamics::Column => {
                let p = self.air().pressure(self.vent_altitude);
                mixture_density(self.gas_fraction, self.t0, p, self.solid_density)
            }
        }
    }

    /// Mass delivered per second by the emitted slices (kg/s): a slice's mass over the
    /// emission interval. The column's equals the vent flux `ρ₀ π r₀² v₀` (the mass eruption
    /// rate); the thesis' is twice it (a slice of `π r₀³` every `r₀/(2v₀)`).
    pub fn mass_eruption_rate(&self) -> f64 {
        let volume = std::f64::consts::PI * self.r0 * self.r0 * self.vent_slice_length();
        self.vent_density() * volume / self.emission_interval()
    }

    /// The column's exit speed for a mass eruption rate when none is given (m/s):
    /// `v₀ = 40 · (MER / 10⁴ kg/s)^0.18`, 40 m/s at 10⁴ kg/s, 318 m/s at 10⁹. The column's
    /// collapse threshold at a fixed rate grows about as `MER^0.2` (17 m/s at 10⁴ kg/s, 170 m/s
    /// at 10⁹ for 3 wt% and 1,273 K), so this keeps a margin of ≥ 1.5 over 10²–10¹⁰ kg/s
    /// (tested from 10⁴ to 10⁹ with a 20 % slower vent; docs/physics/plume.md §4.5).
    pub fn default_exit_speed(mer: f64) -> f64 {
        40.0 * (mer / 1e4).powf(0.18)
    }

    /// These parameters with the vent sized for a mass eruption rate `mer` (kg/s): the exit
    /// speed `v0` if given, else [`PlumeParams::default_exit_speed`]; the radius from
    /// `MER = ρ₀ π r₀² v₀`. Errors if `mer` or the resulting vent is out of range.
    pub fn with_mer(&self, mer: f64, v0: Option<f64>) -> Result<Self, ConfigError> {
        in_range("mer", mer, 1.0, 1e11)?;
        let mut p = self.clone();
        p.v0 = v0.unwrap_or_else(|| Self::default_exit_speed(mer));
        let rho = p.vent_density();
        let r0 = match p.dynamics {
            Dynamics::Column => (mer / (rho * std::f64::consts::PI * p.v0)).sqrt(),
            Dynamics::Thesis => (mer / (2.0 * rho * std::f64::consts::PI * p.v0)).sqrt(),
        };
        p.r0 = r0;
        p.validate()?;
        Ok(p)
    }
}

/// Density of a gas–solid mixture (kg/m³) of gas mass fraction `n` (water vapour, perfect
/// gas) at temperature `t` (K) and pressure `p` (Pa), solid density `rho_s`:
/// `1/ρ = n R_v T/p + (1 − n)/ρ_s` (Woods 1988, eq 2).
pub fn mixture_density(n: f64, t: f64, p: f64, rho_s: f64) -> f64 {
    1.0 / (n * R_VAPOUR * t / p + (1.0 - n) / rho_s)
}

/// Gas constant of water vapour (J/kg/K), kept here for the crate's public path.
pub use volcano_core::units::R_VAPOUR;

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
        assert_eq!(Preset::Physical.params().dynamics, Dynamics::Column);
        assert!(Preset::by_name("vesuvius").unwrap_err().to_string().contains("plinian_showcase"));
    }
}
