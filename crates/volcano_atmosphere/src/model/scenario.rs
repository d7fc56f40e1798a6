//! Scenario files (RON): grid, terrain, layers with their initial fields (constant,
//! prevailing wind, toroidal simplex noise, painted spots) and timeline events (thesis
//! §4.2.7.1 authoring). Every value is validated on load; unknown fields are errors.

use bevy::math::Vec2;
use noise::{NoiseFn, OpenSimplex};
use serde::{Deserialize, Serialize};
use volcano_core::atmosphere::AtmosphereModel;
use volcano_core::error::{finite, in_range, positive};
use volcano_core::{ConfigError, LandCover, StratovolcanoParams, Terrain};

use super::fields::{AtmosphereState, GridSpec, Ground, LayerFields, layer_geometry};
use super::params::AtmosphereParams;
use super::terrain::{sample_terrain, update_masks};
use super::thermo::saturation_humidity;

/// Toroidal simplex noise: amplitude × OpenSimplex sampled on a 4D torus so it tiles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseSpec {
    /// Peak amplitude (field units).
    pub amplitude: f64,
    /// Feature size (m).
    pub scale_m: f64,
    /// Seed.
    pub seed: u32,
}

/// A painted Gaussian bump: `amount · exp(−r²/radius²)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spot {
    /// Centre x (m, domain centred on 0, +x east).
    pub x_m: f64,
    /// Centre y (m, +y north).
    pub y_m: f64,
    /// Radius (m).
    pub radius_m: f64,
    /// Peak value added (field units).
    pub amount: f64,
}

/// An initial scalar field: constant + noise + painted spots.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FieldInit {
    /// Constant part.
    pub base: f64,
    /// Optional simplex noise.
    pub noise: Option<NoiseSpec>,
    /// Painted spots.
    pub spots: Vec<Spot>,
}

/// One layer of a scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerSpec {
    /// Θ_i, altitude (m); layers listed bottom to top.
    pub altitude_m: f64,
    /// Temperature offset (K) from the scenario's profile at this altitude.
    #[serde(default)]
    pub temperature_offset_k: FieldInit,
    /// Relative humidity (fraction of saturation, 0–1.5) of the initial vapour.
    #[serde(default)]
    pub relative_humidity: FieldInit,
    /// Initial condensed water (g/m³).
    #[serde(default)]
    pub water: FieldInit,
    /// Prevailing wind (m/s, x east, y north).
    #[serde(default)]
    pub wind: (f32, f32),
    /// Noise added to both wind components (m/s).
    #[serde(default)]
    pub wind_noise: Option<NoiseSpec>,
    /// Relaxation toward the prevailing wind (s); none = free.
    #[serde(default)]
    pub wind_relaxation_s: Option<f64>,
}

/// Terrain generators, sampled at the atmosphere's cell centres (sea level 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum WeatherTerrain {
    /// Flat land at a height.
    Flat {
        /// Height (m).
        height_m: f64,
        /// Land cover.
        cover: LandCover,
    },
    /// A north–south Gaussian ridge through the centre (orographic lift), `half_length_m`
    /// long each way from the centre with rounded ends.
    Ridge {
        /// Crest height (m).
        height_m: f64,
        /// Gaussian half-width (m).
        half_width_m: f64,
        /// Half length (m) along y.
        half_length_m: f64,
    },
    /// A north–south strip of land `width_m` wide in the sea (two coasts), smooth shores.
    Coast {
        /// Land strip width (m).
        width_m: f64,
        /// Land height (m).
        height_m: f64,
    },
    /// The foundation's procedural stratovolcano (`volcano_core`), sampled at the cell centres.
    Stratovolcano(StratovolcanoParams),
    /// Round islands in the sea.
    Archipelago {
        /// Island count.
        count: u32,
        /// Island radius (m).
        radius_m: f64,
        /// Island height (m).
        height_m: f64,
        /// Placement seed.
        seed: u64,
    },
}

/// What a timeline event does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum EventAction {
    /// Sets the layer's prevailing wind (and its current wind) to `(u, v)` m/s.
    SetWind(f32, f32),
    /// Adds simplex-noise turbulence to the layer's wind.
    Turbulence(NoiseSpec),
    /// Paints a spot into a field.
    Paint(FieldKind, Spot),
    /// Sets a field to `value` in the band `x_from_m ≤ x < x_to_m` (a boundary inflow).
    Band {
        /// Field painted.
        field: FieldKind,
        /// Band start (m).
        x_from_m: f64,
        /// Band end (m).
        x_to_m: f64,
        /// Value set.
        value: f64,
    },
}

/// Paintable fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FieldKind {
    /// Temperature (K, added).
    Temperature,
    /// Absolute humidity (g/m³).
    Humidity,
    /// Condensed water (g/m³).
    Water,
    /// Ash (g/m³).
    Ash,
}

/// A timed event on one layer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Event {
    /// Simulated time (s) at which it fires.
    pub at_s: f64,
    /// Layer index (0 = lowest).
    pub layer: usize,
    /// What happens.
    pub action: EventAction,
}

impl Event {
    /// Checks the event against an atmosphere of `layers` layers; the error names the field.
    /// Scenarios check their events when loaded; events a game pushes into an
    /// `AtmosphereTimeline` are checked when they fire.
    pub fn validate(&self, layers: usize) -> Result<(), ConfigError> {
        in_range("event at_s", self.at_s, 0.0, 1e9)?;
        if self.layer >= layers {
            return Err(ConfigError::InvalidParameter {
                name: "event layer",
                value: self.layer as f64,
                reason: format!("must be a layer index below {layers}"),
            });
        }
        match &self.action {
            EventAction::SetWind(u, v) => {
                in_range("event wind u", *u as f64, -100.0, 100.0)?;
                in_range("event wind v", *v as f64, -100.0, 100.0)?;
            }
            EventAction::Turbulence(n) => check_noise(&Some(n.clone()))?,
            EventAction::Paint(_, s) => check_spot(s)?,
            EventAction::Band { x_from_m, x_to_m, value, .. } => {
                finite("event x_from_m", *x_from_m)?;
                finite("event x_to_m", *x_to_m)?;
                in_range("event value", *value, -1e3, 1e3)?;
            }
        }
        Ok(())
    }
}

/// Diagnostics a scenario asks the runner for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Diagnostic {
    /// Onshore wind at local noon and at 03:00.
    ShoreBreeze,
    /// Vertical velocity and cloud over windward and lee slopes.
    Slopes,
}

/// A whole scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Scenario")]
pub struct WeatherScenario {
    /// Name.
    pub name: String,
    /// Cells per side (power of two).
    pub grid: usize,
    /// Domain side (m).
    pub extent_m: f64,
    /// Default step (s).
    pub dt: f64,
    /// Default number of steps.
    pub steps: u32,
    /// Local solar time at the start (h).
    pub start_hour: f64,
    /// Day of the year.
    pub day_of_year: f64,
    /// Latitude (degrees).
    pub latitude_deg: f64,
    /// Vertical profile giving each layer's base temperature.
    #[serde(default)]
    pub profile: AtmosphereModel,
    /// Terrain.
    pub terrain: WeatherTerrain,
    /// Initial water in land ground (g/m²).
    #[serde(default = "default_ground_water")]
    pub ground_water_g_m2: f64,
    /// Water in the active layer of water bodies (g/m²).
    #[serde(default = "default_sea_water")]
    pub sea_water_g_m2: f64,
    /// Model coefficients (defaults for anything not given).
    #[serde(default)]
    pub params: AtmosphereParams,
    /// Layers, bottom to top.
    pub layers: Vec<LayerSpec>,
    /// Timeline.
    #[serde(default)]
    pub events: Vec<Event>,
    /// Diagnostics for the summary.
    #[serde(default)]
    pub diagnostics: Vec<Diagnostic>,
}

fn default_ground_water() -> f64 {
    5_000.0
}
fn default_sea_water() -> f64 {
    1.0e6
}

/// Built-in scenarios (five weather scenarios and `eruption`), shipped as RON assets.
pub const BUILTIN: [(&str, &str); 6] = [
    ("convection", include_str!("../../scenarios/convection.ron")),
    ("island", include_str!("../../scenarios/island.ron")),
    ("sea-breeze", include_str!("../../scenarios/sea-breeze.ron")),
    ("orographic", include_str!("../../scenarios/orographic.ron")),
    ("mixed", include_str!("../../scenarios/mixed.ron")),
    ("eruption", include_str!("../../scenarios/eruption.ron")),
];

fn check_noise(n: &Option<NoiseSpec>) -> Result<(), ConfigError> {
    if let Some(n) = n {
        in_range("noise amplitude", n.amplitude, -1e3, 1e3)?;
        positive("noise scale_m", n.scale_m)?;
    }
    Ok(())
}

fn check_spot(s: &Spot) -> Result<(), ConfigError> {
    finite("spot x_m", s.x_m)?;
    finite("spot y_m", s.y_m)?;
    positive("spot radius_m", s.radius_m)?;
    in_range("spot amount", s.amount, -1e3, 1e3)?;
    Ok(())
}

fn check_field(f: &FieldInit) -> Result<(), ConfigError> {
    in_range("field base", f.base, -1e3, 1e3)?;
    check_noise(&f.noise)?;
    f.spots.iter().try_for_each(check_spot)
}

impl WeatherScenario {
    /// Parses and validates a RON scenario.
    pub fn from_ron(text: &str) -> Result<Self, ConfigError> {
        let s: WeatherScenario = ron::from_str(text)?;
        s.validate()?;
        Ok(s)
    }

    /// Reads, parses and validates a RON scenario file; an error names the file.
    pub fn load(path: &std::path::Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ConfigError::Io { path: path.display().to_string(), message: e.to_string() })?;
        Self::from_ron(&text).map_err(|e| e.in_file(path))
    }

    /// A built-in scenario by name.
    pub fn builtin(name: &str) -> Result<Self, ConfigError> {
        let text = BUILTIN.iter().find(|(n, _)| *n == name).map(|(_, t)| *t).ok_or_else(|| {
            ConfigError::UnknownName {
                kind: "scenario",
                name: name.into(),
                known: BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
            }
        })?;
        Self::from_ron(text)
    }

    /// Checks every value; the error names the field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("extent_m", self.extent_m, 100.0, 1e7)?;
        GridSpec::new(self.grid, self.extent_m / self.grid.max(1) as f64)?;
        super::step::check_dt(self.dt)?;
        in_range("start_hour", self.start_hour, 0.0, 24.0)?;
        in_range("day_of_year", self.day_of_year, 1.0, 366.0)?;
        in_range("latitude_deg", self.latitude_deg, -90.0, 90.0)?;
        in_range("ground_water_g_m2", self.ground_water_g_m2, 0.0, 1e8)?;
        in_range("sea_water_g_m2", self.sea_water_g_m2, 0.0, 1e9)?;
        self.params.validate()?;
        match &self.terrain {
            WeatherTerrain::Flat { height_m, .. } => {
                in_range("terrain height_m", *height_m, -500.0, 9000.0).map(|_| ())?
            }
            WeatherTerrain::Ridge { height_m, half_width_m, half_length_m } => {
                in_range("terrain height_m", *height_m, 0.0, 9000.0)?;
                positive("terrain half_width_m", *half_width_m)?;
                positive("terrain half_length_m", *half_length_m)?;
            }
            WeatherTerrain::Coast { width_m, height_m } => {
                positive("terrain width_m", *width_m)?;
                in_range("terrain height_m", *height_m, 0.0, 9000.0)?;
            }
            WeatherTerrain::Stratovolcano(_) => {}
            WeatherTerrain::Archipelago { count, radius_m, height_m, .. } => {
                in_range("terrain count", *count as f64, 1.0, 1000.0)?;
                positive("terrain radius_m", *radius_m)?;
                in_range("terrain height_m", *height_m, 0.0, 9000.0)?;
            }
        }
        if let WeatherTerrain::Stratovolcano(p) = &self.terrain {
            p.validate()?;
        }
        let alts: Vec<f64> = self.layers.iter().map(|l| l.altitude_m).collect();
        layer_geometry(&alts)?;
        if self.layers.len() > 32 {
            return Err(ConfigError::InvalidParameter {
                name: "layers",
                value: self.layers.len() as f64,
                reason: "at most 32 layers".into(),
            });
        }
        for l in &self.layers {
            check_field(&l.temperature_offset_k)?;
            check_field(&l.relative_humidity)?;
            in_range("relative_humidity base", l.relative_humidity.base, 0.0, 1.5)?;
            check_field(&l.water)?;
            in_range("water base", l.water.base, 0.0, 100.0)?;
            in_range("wind u", l.wind.0 as f64, -100.0, 100.0)?;
            in_range("wind v", l.wind.1 as f64, -100.0, 100.0)?;
            check_noise(&l.wind_noise)?;
            if let Some(t) = l.wind_relaxation_s {
                positive("wind_relaxation_s", t)?;
            }
        }
        for e in &self.events {
            e.validate(self.layers.len())?;
        }
        Ok(())
    }

    /// Builds the initial state on an `n × n` grid (the scenario's own if `None`), keeping
    /// the extent in metres.
    pub fn build(&self, grid: Option<usize>) -> Result<AtmosphereState, ConfigError> {
        self.validate()?;
        let n = grid.unwrap_or(self.grid);
        let g = GridSpec::new(n, self.extent_m / n as f64)?;
        let (height, cover) = match &self.terrain {
            WeatherTerrain::Stratovolcano(p) => sample_terrain(&p.generate()?, g),
            _ => self.terrain_fields(g),
        };
        self.build_on(g, height, cover)
    }

    /// Builds the initial state over a game's own foundation [`Terrain`] (sampled at the cell
    /// centres) instead of the scenario's terrain.
    pub fn build_with_terrain(
        &self,
        grid: Option<usize>,
        terrain: &Terrain,
    ) -> Result<AtmosphereState, ConfigError> {
        self.validate()?;
        let n = grid.unwrap_or(self.grid);
        let g = GridSpec::new(n, self.extent_m / n as f64)?;
        let (height, cover) = sample_terrain(terrain, g);
        self.build_on(g, height, cover)
    }

    fn build_on(
        &self,
        g: GridSpec,
        height: Vec<f32>,
        cover: Vec<LandCover>,
    ) -> Result<AtmosphereState, ConfigError> {
        let alts: Vec<f64> = self.layers.iter().map(|l| l.altitude_m).collect();
        let geometry = layer_geometry(&alts)?;
        let profile = self.profile.profile();
        let mut layers = Vec::new();
        for (spec, &(bottom, thickness)) in self.layers.iter().zip(&geometry) {
            let t0 = profile.temperature(spec.altitude_m) as f32;
            let mut layer = LayerFields::new(g, spec.altitude_m, bottom, thickness, t0);
            let off = sample_field(g, &spec.temperature_offset_k);
            let rh = sample_field(g, &spec.relative_humidity);
            let wat = sample_field(g, &spec.water);
            for k in 0..g.cells() {
                let t = (t0 as f64 + off[k]).clamp(150.0, 350.0);
                layer.t.data_mut()[k] = t as f32;
                layer.h.data_mut()[k] = rh[k].clamp(0.0, 1.5) * saturation_humidity(t, layer.pi);
                layer.w.data_mut()[k] = wat[k].max(0.0);
            }
            layer.wind = Vec2::new(spec.wind.0, spec.wind.1);
            layer.wind_relaxation_s = spec.wind_relaxation_s;
            layer.u.data_mut().fill(spec.wind.0);
            layer.v.data_mut().fill(spec.wind.1);
            if let Some(nz) = &spec.wind_noise {
                add_noise(g, layer.u.data_mut(), nz, 0);
                add_noise(g, layer.v.data_mut(), nz, 1);
            }
            layers.push(layer);
        }
        let t_ground: Vec<f32> = height
            .iter()
            .map(|&h| (profile.temperature(h as f64) + self.layers[0].temperature_offset_k.base) as f32)
            .collect();
        let water: Vec<f64> = cover
            .iter()
            .map(|&c| if c == LandCover::Water { self.sea_water_g_m2 } else { self.ground_water_g_m2 })
            .collect();
        let mut ground = Ground {
            height: g.grid(0.0),
            cover: g.grid(LandCover::Ground),
            t: g.grid(0.0),
            water: g.grid(0.0),
            sunlit: g.grid(1.0),
            sunlit_for: None,
            lowest: vec![0; g.cells()],
            ash: g.grid(0.0),
        };
        ground.height.data_mut().copy_from_slice(&height);
        ground.cover.data_mut().copy_from_slice(&cover);
        ground.t.data_mut().copy_from_slice(&t_ground);
        ground.water.data_mut().copy_from_slice(&water);
        let mut state = AtmosphereState {
            grid: g,
            layers,
            ground,
            time_s: 0.0,
            start_hour: self.start_hour,
            day_of_year: self.day_of_year,
            latitude_deg: self.latitude_deg,
            precipitated: 0.0,
        };
        update_masks(&mut state);
        // No water inside terrain.
        for layer in state.layers.iter_mut() {
            for k in 0..g.cells() {
                if layer.sigma.data()[k] <= 0.0 {
                    layer.h.data_mut()[k] = 0.0;
                    layer.w.data_mut()[k] = 0.0;
                }
            }
        }
        Ok(state)
    }

    fn terrain_fields(&self, g: GridSpec) -> (Vec<f32>, Vec<LandCover>) {
        let l = g.extent();
        let mut height = vec![0.0f32; g.cells()];
        let mut cover = vec![LandCover::Water; g.cells()];
        // Shortest periodic offset.
        let wrap = |d: f64| d - l * (d / l).round();
        for k in 0..g.cells() {
            let (x, y) = g.centre(k);
            let (h, c) = match &self.terrain {
                WeatherTerrain::Flat { height_m, cover } => (*height_m, *cover),
                WeatherTerrain::Ridge { height_m, half_width_m, half_length_m } => {
                    let r = wrap(x) / half_width_m;
                    let beyond = ((wrap(y).abs() - half_length_m) / half_width_m).max(0.0);
                    (height_m * (-r * r - beyond * beyond).exp() + 10.0, LandCover::Vegetation)
                }
                WeatherTerrain::Coast { width_m, height_m } => {
                    // Smooth plateau: 0 in the sea, height_m on land, shores 1 km wide.
                    let inland = 0.5 * width_m - wrap(x).abs();
                    let s = 0.5 * (1.0 + (inland / 500.0).tanh());
                    (height_m * s, if inland > 0.0 { LandCover::Ground } else { LandCover::Water })
                }
                WeatherTerrain::Stratovolcano(_) => (0.0, LandCover::Water), // sampled in `build`
                WeatherTerrain::Archipelago { count, radius_m, height_m, seed } => {
                    let mut best = 0.0f64;
                    for c in 0..*count as u64 {
                        let (cx, cy) = island_centre(*seed, c, l);
                        let (dx, dy) = (wrap(x - cx), wrap(y - cy));
                        let r = (dx * dx + dy * dy).sqrt() / radius_m;
                        best = best.max(if r < 1.0 { height_m * (1.0 - r * r) } else { 0.0 });
                    }
                    (best, if best > 0.0 { LandCover::Vegetation } else { LandCover::Water })
                }
            };
            height[k] = h as f32;
            cover[k] = c;
        }
        (height, cover)
    }
}

/// Deterministic island centre from `(seed, index)`, inside the middle 70 % of the domain.
fn island_centre(seed: u64, index: u64, l: f64) -> (f64, f64) {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ (index.wrapping_mul(0x9E37_79B9_7F4A_7C15)));
    (rng.random_range(-0.35..0.35) * l, rng.random_range(-0.35..0.35) * l)
}

/// Samples a [`FieldInit`] at every cell centre.
pub fn sample_field(g: GridSpec, f: &FieldInit) -> Vec<f64> {
    let mut out = vec![f.base; g.cells()];
    if let Some(nz) = &f.noise {
        let mut tmp = vec![0.0f32; g.cells()];
        add_noise(g, &mut tmp, nz, 0);
        out.iter_mut().zip(&tmp).for_each(|(o, t)| *o += *t as f64);
    }
    for s in &f.spots {
        add_spot(g, &mut out, s);
    }
    out
}

/// Adds a Gaussian spot (periodic distance) to a field.
pub fn add_spot(g: GridSpec, field: &mut [f64], s: &Spot) {
    let l = g.extent();
    let wrap = |d: f64| d - l * (d / l).round();
    for (k, v) in field.iter_mut().enumerate() {
        let (x, y) = g.centre(k);
        let (dx, dy) = (wrap(x - s.x_m), wrap(y - s.y_m));
        *v += s.amount * (-(dx * dx + dy * dy) / (s.radius_m * s.radius_m)).exp();
    }
}

/// Adds tileable simplex noise (4D torus embedding) to an f32 field; `salt` decorrelates
/// components sharing a spec.
pub fn add_noise(g: GridSpec, field: &mut [f32], nz: &NoiseSpec, salt: u32) {
    let noise = OpenSimplex::new(nz.seed.wrapping_add(salt.wrapping_mul(7919)));
    let l = g.extent();
    let radius = l / (std::f64::consts::TAU * nz.scale_m);
    for (k, v) in field.iter_mut().enumerate() {
        let (x, y) = g.centre(k);
        let (a, b) = (std::f64::consts::TAU * x / l, std::f64::consts::TAU * y / l);
        let p = [radius * a.cos(), radius * a.sin(), radius * b.cos(), radius * b.sin()];
        *v += (nz.amplitude * noise.get(p)) as f32;
    }
}
