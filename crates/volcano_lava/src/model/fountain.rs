//! A Hawaiian lava fountain (docs/physics/fountain.md §8.1): clots of lava thrown up from a vent or a
//! fissure, flying ballistically through still air with quadratic drag and cooling by radiation
//! until they fall back onto the ground, where the vent's lava feeds the flow. The clots are a
//! sample of the lava erupted (each stands for `ρ Q / clots_per_s` kg); what they lose in heat
//! on the way, with the sensible heat of the magmatic water, is the fountain's heat flux into
//! the air, which drives its gas plume.
//!
//! - Flight: `dv/dt = g − k |v| v`, `k = 3 ρ_air C_d / (4 ρ_clot d)` (a sphere of diameter `d`).
//!   Going straight up from `u` the top is `ln(1 + k u²/g) / (2k)` (→ `u²/2g` without drag):
//!   [`top_height`].
//! - Cooling: a lumped clot radiating to the air, `ρ c (d/6) dT/dt = −ε σ (T⁴ − T_a⁴)`; from `T₀`
//!   into air at 0 K, `T(t) = (T₀⁻³ + 18 ε σ t / (ρ c d))^{−1/3}`.
//!
//! Engine-free: [`Fountain::step`] takes the vent, the air and a ground height function.

use bevy::math::DVec3;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use volcano_core::error::{ConfigError, in_range};

/// Stefan–Boltzmann constant (W m⁻² K⁻⁴).
pub const STEFAN_BOLTZMANN: f64 = 5.670_374e-8;
/// Specific heat of water vapour at constant pressure (J/(kg K)), for the magmatic gas.
pub const CP_VAPOUR: f64 = 2_000.0;
/// Drag coefficient of a rough clot (a sphere at high Reynolds number).
pub const CLOT_DRAG_COEFFICIENT: f64 = 1.0;
/// Gravity (m/s²).
const G: f64 = volcano_core::units::G0;
/// Longest flight step (s): the clots' flights are integrated in steps no longer than this.
const MAX_FLIGHT_STEP: f64 = 0.02;

/// What a fountain throws.
#[derive(Debug, Clone, Copy, PartialEq, bevy::reflect::Reflect)]
pub struct FountainParams {
    /// Launch speed of the fastest clots (m/s, in [1, 400]); the others leave slower, their
    /// drag-free tops spread evenly over 0.1–1 of the fastest's.
    pub exit_speed: f64,
    /// Half-angle of the launch cone about the vertical (degrees, in [0, 45]).
    pub spread_deg: f64,
    /// Clot diameter (m, in [0.005, 2]).
    pub clot_diameter: f64,
    /// Clot density (kg/m³, in [200, 3000]): vesicular spatter is lighter than the flow.
    pub clot_density: f64,
    /// Emissivity of the clots' surface (in [0.1, 1]).
    pub emissivity: f64,
    /// Specific heat of the lava (J/(kg K), in [500, 3000]).
    pub specific_heat: f64,
    /// Magmatic water released at the vent (mass fraction of the lava, in [0, 0.1]).
    pub water_fraction: f64,
    /// Clots launched per second, a sample of the lava (in [0, 10⁵]).
    pub clots_per_s: f64,
    /// Most clots in flight (in [0, 10⁶]); launches beyond it are skipped and counted.
    pub max_clots: usize,
}

impl Default for FountainParams {
    /// A 100 m basaltic fountain of 20 cm spatter clots (1,500 kg/m³; exit speed ≈ 51.8 m/s
    /// against the drag of air at 1.2 kg/m³), 0.4 wt% water, 400 clots a second.
    fn default() -> Self {
        Self {
            exit_speed: 51.8,
            spread_deg: 6.0,
            clot_diameter: 0.2,
            clot_density: 1_500.0,
            emissivity: 0.95,
            specific_heat: 1_200.0,
            water_fraction: 0.004,
            clots_per_s: 400.0,
            max_clots: 4_000,
        }
    }
}

impl FountainParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("fountain exit_speed", self.exit_speed, 1.0, 400.0)?;
        in_range("fountain spread_deg", self.spread_deg, 0.0, 45.0)?;
        in_range("fountain clot_diameter", self.clot_diameter, 0.005, 2.0)?;
        in_range("fountain clot_density", self.clot_density, 200.0, 3_000.0)?;
        in_range("fountain emissivity", self.emissivity, 0.1, 1.0)?;
        in_range("fountain specific_heat", self.specific_heat, 500.0, 3_000.0)?;
        in_range("fountain water_fraction", self.water_fraction, 0.0, 0.1)?;
        in_range("fountain clots_per_s", self.clots_per_s, 0.0, 1e5)?;
        in_range("fountain max_clots", self.max_clots as f64, 0.0, 1e6)?;
        Ok(())
    }

    /// The exit speed that throws these clots `height` m up through air of density
    /// `air_density` ([`top_height`] inverted: `√(g (e^{2kH} − 1) / k)`, `√(2 g H)` without
    /// drag).
    pub fn speed_for_height(&self, height: f64, air_density: f64) -> f64 {
        let (h, k) = (height.max(0.0), self.drag_constant(air_density));
        if k <= 0.0 { (2.0 * G * h).sqrt() } else { (G * (2.0 * k * h).exp_m1() / k).sqrt() }
    }

    /// The drag constant `k` (1/m) of these clots in air of density `air_density`.
    pub fn drag_constant(&self, air_density: f64) -> f64 {
        3.0 * air_density * CLOT_DRAG_COEFFICIENT / (4.0 * self.clot_density * self.clot_diameter)
    }
}

/// The top (m above the launch) of a clot thrown straight up at `u` m/s with drag constant
/// `k` (1/m): `ln(1 + k u²/g) / (2k)`, `u²/2g` for `k = 0`.
pub fn top_height(u: f64, k: f64) -> f64 {
    if k <= 0.0 { u * u / (2.0 * G) } else { (k * u * u / G).ln_1p() / (2.0 * k) }
}

/// One clot in flight (world frame, y up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Clot {
    /// Position (m).
    pub position: DVec3,
    /// Velocity (m/s).
    pub velocity: DVec3,
    /// Temperature (K), the lumped clot's.
    pub temperature: f64,
    /// Lava mass it stands for (kg).
    pub mass: f64,
}

/// Where and what a fountain erupts this step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FountainSource {
    /// The vent's centre (world, y = the ground there).
    pub vent: DVec3,
    /// Half a fissure, centre to one end (world); zero for a point vent.
    pub fissure: DVec3,
    /// Radius of the vent (m).
    pub radius: f64,
    /// Lava erupted (m³/s of dense lava).
    pub rate: f64,
    /// Its temperature (K).
    pub temperature: f64,
    /// Its density (kg/m³).
    pub lava_density: f64,
}

/// The air the clots fly through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FountainAir {
    /// Temperature (K).
    pub temperature: f64,
    /// Density (kg/m³).
    pub density: f64,
}

/// What a [`Fountain::step`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FountainReport {
    /// Clots launched.
    pub launched: u32,
    /// Clots that fell back to the ground.
    pub landed: u32,
    /// Launches skipped at `max_clots` (a limiter).
    pub capped: u32,
    /// Lava mass launched, landed and skipped (kg).
    pub launched_kg: f64,
    /// Lava mass that landed (kg).
    pub landed_kg: f64,
    /// Heat given to the air by the clots' cooling and the magmatic water (J).
    pub heat_j: f64,
    /// Magmatic water released (kg).
    pub vapour_kg: f64,
}

/// A lava fountain: its clots in flight and its random stream.
#[derive(Debug, Clone, PartialEq)]
pub struct Fountain {
    params: FountainParams,
    clots: Vec<Clot>,
    rng: ChaCha8Rng,
    /// Fraction of a clot due, carried to the next step.
    carry: f64,
    /// Lava mass in flight (kg).
    airborne_kg: f64,
}

impl Fountain {
    /// A fountain with nothing in flight; `rng` draws the launches.
    pub fn new(params: FountainParams, rng: ChaCha8Rng) -> Result<Self, ConfigError> {
        params.validate()?;
        Ok(Self { params, clots: Vec::new(), rng, carry: 0.0, airborne_kg: 0.0 })
    }

    /// Its parameters.
    pub fn params(&self) -> &FountainParams {
        &self.params
    }

    /// Replaces its parameters (validated; the clots in flight keep flying).
    pub fn set_params(&mut self, params: FountainParams) -> Result<(), ConfigError> {
        params.validate()?;
        self.params = params;
        Ok(())
    }

    /// The clots in flight.
    pub fn clots(&self) -> &[Clot] {
        &self.clots
    }

    /// Lava mass in flight (kg).
    pub fn airborne_kg(&self) -> f64 {
        self.airborne_kg
    }

    /// Advances `dt` seconds: launches the clots due (none when `source` is `None` or erupts
    /// nothing), flies and cools every clot, lands those below `ground(x, z)`. Non-finite clots
    /// are dropped (their mass counted as landed).
    pub fn step(
        &mut self,
        dt: f64,
        source: Option<&FountainSource>,
        air: FountainAir,
        ground: impl Fn(f64, f64) -> f64,
    ) -> FountainReport {
        let mut report = FountainReport::default();
        if !(dt > 0.0 && dt.is_finite()) {
            return report;
        }
        let p = self.params;
        if let Some(src) = source.filter(|s| s.rate > 0.0 && s.rate.is_finite()) {
            let kg_per_s = src.lava_density * src.rate;
            report.vapour_kg = p.water_fraction * kg_per_s * dt;
            report.heat_j += report.vapour_kg * CP_VAPOUR * (src.temperature - air.temperature).max(0.0);
            if p.clots_per_s > 0.0 {
                let due = self.carry + p.clots_per_s * dt;
                let n = due.floor();
                self.carry = due - n;
                let mass = kg_per_s / p.clots_per_s;
                for i in 0..n as u64 {
                    report.launched_kg += mass;
                    if self.clots.len() >= p.max_clots {
                        report.capped += 1;
                        report.landed_kg += mass;
                        continue;
                    }
                    // Launched through the step, so a long step does not throw a sheet.
                    let age = dt * (i as f64 + self.rng.random::<f64>()) / n.max(1.0);
                    let clot = self.launch(src, mass);
                    self.clots.push(clot);
                    self.airborne_kg += mass;
                    report.launched += 1;
                    let last = self.clots.len() - 1;
                    self.fly(last, dt - age, air, &mut report.heat_j);
                }
            }
        }
        let launched_now = report.launched as usize;
        let old = self.clots.len() - launched_now;
        for i in 0..old {
            self.fly(i, dt, air, &mut report.heat_j);
        }
        // Land: below the ground, or no longer finite.
        let mut landed_kg = 0.0;
        let mut landed = 0u32;
        self.clots.retain(|c| {
            let alive = c.position.is_finite()
                && c.velocity.is_finite()
                && c.temperature.is_finite()
                && !(c.velocity.y < 0.0 && c.position.y < ground(c.position.x, c.position.z));
            if !alive {
                landed_kg += c.mass;
                landed += 1;
            }
            alive
        });
        self.airborne_kg -= landed_kg;
        if self.clots.is_empty() {
            self.airborne_kg = 0.0;
        }
        report.landed += landed;
        report.landed_kg += landed_kg;
        report
    }

    /// A clot leaving `src`: from a random point of the vent's disc (or along its fissure), at
    /// √0.1–1 × the exit speed, in a cone of `spread_deg` about the vertical.
    fn launch(&mut self, src: &FountainSource, mass: f64) -> Clot {
        let rng = &mut self.rng;
        let (a, r) = (std::f64::consts::TAU * rng.random::<f64>(), src.radius * rng.random::<f64>().sqrt());
        let along = 2.0 * rng.random::<f64>() - 1.0;
        let at = src.vent + src.fissure * along + DVec3::new(r * a.cos(), 0.0, r * a.sin());
        let theta = self.params.spread_deg.to_radians() * rng.random::<f64>().sqrt();
        let phi = std::f64::consts::TAU * rng.random::<f64>();
        // Tops spread evenly from a tenth of the fountain's height to all of it (speed² is
        // uniform), so the fountain is densest low down and thins toward its top.
        let speed = self.params.exit_speed * (0.1 + 0.9 * rng.random::<f64>()).sqrt();
        let dir = DVec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
        Clot { position: at, velocity: dir * speed, temperature: src.temperature, mass }
    }

    /// Flies and cools clot `i` for `t` seconds (steps ≤ 0.02 s: velocity semi-implicit,
    /// position by the mean velocity); adds the heat it lost to `heat`.
    fn fly(&mut self, i: usize, t: f64, air: FountainAir, heat: &mut f64) {
        let p = self.params;
        let k = p.drag_constant(air.density);
        let cool =
            6.0 * p.emissivity * STEFAN_BOLTZMANN / (p.clot_density * p.specific_heat * p.clot_diameter);
        let ta4 = air.temperature.powi(4);
        let c = &mut self.clots[i];
        let t0 = c.temperature;
        let n = (t / MAX_FLIGHT_STEP).ceil().max(1.0);
        let h = t / n;
        for _ in 0..n as u32 {
            let speed = c.velocity.length();
            // Drag implicit in |v| (stable for any step): v' = (v + g h) / (1 + k |v| h).
            let v0 = c.velocity;
            c.velocity = (v0 + DVec3::new(0.0, -G, 0.0) * h) / (1.0 + k * speed * h);
            c.position += 0.5 * (v0 + c.velocity) * h;
            // Radiation, explicit (the step is far below T / (dT/dt) for clots ≥ 5 mm).
            c.temperature -= h * cool * (c.temperature.powi(4) - ta4);
            c.temperature = c.temperature.max(air.temperature);
        }
        *heat += c.mass * p.specific_heat * (t0 - c.temperature);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    const AIR: FountainAir = FountainAir { temperature: 290.0, density: 1.2 };

    fn fountain(params: FountainParams) -> Fountain {
        Fountain::new(params, ChaCha8Rng::seed_from_u64(7)).unwrap()
    }

    fn source(rate: f64) -> FountainSource {
        FountainSource {
            vent: DVec3::new(100.0, 50.0, -20.0),
            fissure: DVec3::ZERO,
            radius: 10.0,
            rate,
            temperature: 1_420.0,
            lava_density: 2_600.0,
        }
    }

    /// Flies one clot thrown straight up at `u` until it falls; its highest point.
    fn top_of_one(params: FountainParams, u: f64, air: FountainAir) -> f64 {
        let mut f = fountain(params);
        f.clots.push(Clot {
            position: DVec3::ZERO,
            velocity: DVec3::new(0.0, u, 0.0),
            temperature: 1400.0,
            mass: 1.0,
        });
        let mut top: f64 = 0.0;
        let mut heat = 0.0;
        while f.clots[0].velocity.y > 0.0 || f.clots[0].position.y > 0.0 {
            f.fly(0, 0.01, air, &mut heat);
            top = top.max(f.clots[0].position.y);
        }
        top
    }

    #[test]
    fn a_clot_thrown_up_tops_out_where_the_quadratic_drag_law_says() {
        let p = FountainParams::default();
        let k = p.drag_constant(AIR.density);
        for u in [20.0, 60.0, 150.0] {
            let (numeric, exact) = (top_of_one(p, u, AIR), top_height(u, k));
            assert!((numeric / exact - 1.0).abs() < 5e-3, "u = {u}: {numeric:.1} m vs {exact:.1} m");
        }
        // Drag matters for 20 cm spatter at 150 m/s (two thirds of the drag-free height) and
        // hardly for 2 m bombs of dense rock.
        assert!(top_height(150.0, k) < 0.7 * top_height(150.0, 0.0));
        assert!((top_height(p.speed_for_height(100.0, AIR.density), k) - 100.0).abs() < 1e-9);
        assert!(
            (p.exit_speed - p.speed_for_height(100.0, 1.2)).abs() < 0.05,
            "the default is a 100 m fountain"
        );
        let bomb = FountainParams { clot_diameter: 2.0, clot_density: 3_000.0, ..p };
        let h = top_of_one(bomb, 60.0, AIR);
        assert!((h / top_height(60.0, 0.0) - 1.0).abs() < 0.03, "{h} m vs {} m", top_height(60.0, 0.0));
    }

    #[test]
    fn a_clot_cools_as_the_radiation_law_says() {
        // Into air at (nearly) 0 K: T(t) = (T₀⁻³ + 18 ε σ t / (ρ c d))^{-1/3}.
        let p = FountainParams::default();
        let cold = FountainAir { temperature: 1.0, density: 1.2 };
        let mut f = fountain(p);
        f.clots.push(Clot { position: DVec3::ZERO, velocity: DVec3::ZERO, temperature: 1_400.0, mass: 2.0 });
        let mut heat = 0.0;
        for _ in 0..100 {
            f.fly(0, 0.1, cold, &mut heat);
        }
        let a = 18.0 * p.emissivity * STEFAN_BOLTZMANN / (p.clot_density * p.specific_heat * p.clot_diameter);
        let exact = (1_400f64.powi(-3) + a * 10.0).powf(-1.0 / 3.0);
        let t = f.clots[0].temperature;
        assert!((t / exact - 1.0).abs() < 2e-3, "{t:.1} K vs {exact:.1} K");
        assert!(
            1_400.0 - t > 25.0 && 1_400.0 - t < 60.0,
            "20 cm clots of 1,500 kg/m³ lose ≈ 40 K in 10 s: {t}"
        );
        assert!((heat - 2.0 * p.specific_heat * (1_400.0 - t)).abs() < 1e-6);
    }

    #[test]
    fn a_fountain_is_as_high_as_its_exit_speed_and_keeps_its_mass() {
        let p = FountainParams::default();
        let mut f = fountain(p);
        let src = source(20.0);
        let (mut top, mut sum) = (0.0f64, FountainReport::default());
        for _ in 0..50 * 20 {
            let r = f.step(0.02, Some(&src), AIR, |_, _| 50.0);
            top = top.max(f.clots().iter().map(|c| c.position.y - 50.0).fold(0.0, f64::max));
            sum.launched += r.launched;
            sum.landed += r.landed;
            sum.launched_kg += r.launched_kg;
            sum.landed_kg += r.landed_kg;
            sum.heat_j += r.heat_j;
            sum.vapour_kg += r.vapour_kg;
            assert!(f.clots().iter().all(|c| c.temperature <= 1_420.0 && c.temperature > AIR.temperature));
        }
        // The fastest clots leave at the exit speed within the cone: the top is that of a
        // vertical throw at it (100 m), reached to within a few per cent.
        let limit = top_height(p.exit_speed, p.drag_constant(AIR.density));
        assert!(top <= limit && top > 0.95 * limit, "top {top:.1} m, limit {limit:.1} m");
        assert_eq!(sum.launched, 400 * 20);
        // Flights of 3–8 s: about 2,000 clots in the air once the fountain is steady.
        assert!(
            sum.landed > 5_000 && f.clots().len() < 3_000,
            "{} landed, {} in flight",
            sum.landed,
            f.clots().len()
        );
        let kg = 2_600.0 * 20.0 * 20.0;
        assert!((sum.launched_kg / kg - 1.0).abs() < 1e-9);
        assert!((sum.landed_kg + f.airborne_kg() - sum.launched_kg).abs() < 1e-9 * kg);
        assert!((sum.vapour_kg - p.water_fraction * kg).abs() < 1e-9 * kg);
        // Heat: the gas's sensible heat plus what the clots radiated (tens of kelvin each).
        let gas = sum.vapour_kg * CP_VAPOUR * (1_420.0 - AIR.temperature);
        let clots = (sum.heat_j - gas) / (sum.landed_kg * p.specific_heat);
        assert!(clots > 5.0 && clots < 200.0, "mean cooling per kilogram landed: {clots:.1} K");
    }

    #[test]
    fn fountains_are_deterministic_capped_and_drop_broken_clots() {
        let run = |params: FountainParams| {
            let mut f = fountain(params);
            let mut capped = 0;
            for _ in 0..200 {
                capped += f.step(0.02, Some(&source(5.0)), AIR, |_, _| 50.0).capped;
            }
            (f, capped)
        };
        let (a, _) = run(FountainParams::default());
        let (b, _) = run(FountainParams::default());
        assert_eq!(a, b);
        let (c, capped) = run(FountainParams { max_clots: 50, ..FountainParams::default() });
        assert!(c.clots().len() <= 50 && capped > 1_000, "{} clots, {capped} capped", c.clots().len());
        let mut d = a.clone();
        d.clots[3].position.x = f64::NAN;
        let n = d.clots().len();
        let r = d.step(0.02, None, AIR, |_, _| 50.0);
        assert!(d.clots().iter().all(|c| c.position.is_finite()));
        assert!(r.landed >= 1 && d.clots().len() < n);
        assert!(FountainParams { exit_speed: f64::NAN, ..FountainParams::default() }.validate().is_err());
        assert!(
            Fountain::new(
                FountainParams { spread_deg: 60.0, ..Default::default() },
                ChaCha8Rng::seed_from_u64(1)
            )
            .is_err()
        );
    }
}
