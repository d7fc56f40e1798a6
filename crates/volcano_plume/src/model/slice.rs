//! One column slice (thesis §3.4): state, forces (3.4–3.6), entrainment (3.7), mixing (3.8),
//! mass update (3.9) and the velocity update (3.3).
//!
//! Model frame: `z` is up and measured above the vent; `x, y` horizontal. Budgets are f64.
//!
//! Readings settled in docs/physics/plume.md §4.1 (checked by an independent re-implementation):
//! - entrained mass per step is the ring volume times the air density,
//!   `M_a = ρ_a π((τU_e + r)² − r²) |v| Δt` (the printed `ρ_a U_e v Δt²` has units of kg/m);
//! - eq 3.3 uses `M^{i−1}` = the mass before this step's entrainment, i.e. momentum is kept
//!   while entrained (still) air is added;
//! - contraction on mixing (`V' = V T^{i+1}/T^i`) is a switch.

use bevy::math::{DQuat, DVec2, DVec3};
use bevy::reflect::Reflect;
use volcano_core::atmosphere::AtmosphereProfile;
use volcano_core::units::G0;

use super::params::{Dynamics, PlumeParams};

/// Density floor for sedimentation (kg/m³), far below any air density in the troposphere.
pub const MIN_DENSITY: f64 = 1e-3;

/// Phase of a slice's life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Reflect)]
pub enum Phase {
    /// Rising, denser than the air (momentum-driven).
    Jet,
    /// Rising, lighter than the air.
    Buoyant,
    /// Reached its apex after having been buoyant: spreads as the umbrella.
    Umbrella,
    /// Vertical velocity turned negative before it became buoyant: collapses.
    Collapsed,
}

/// State of one slice.
#[derive(Debug, Clone, PartialEq, Reflect)]
pub struct Slice {
    /// Characteristic size r (m): radius of the slice (and its length for the thesis' slice,
    /// `V = π r³`).
    pub r: f64,
    /// Length of the slice along its motion (m): `r` for the thesis' slice; for a slice of a
    /// sustained column the distance to the next one, `|v| Δt_e` (`model::column`).
    pub length: f64,
    /// Centre position (m), z above the vent.
    pub position: DVec3,
    /// Velocity (m/s).
    pub velocity: DVec3,
    /// Density (kg/m³).
    pub density: f64,
    /// Temperature (K).
    pub temperature: f64,
    /// Mass M (kg).
    pub mass: f64,
    /// Phase.
    pub phase: Phase,
    /// Age (s).
    pub age: f64,
    /// Highest altitude reached (m above the vent).
    pub apex: f64,
    /// Altitude where it first became lighter than the air.
    pub buoyant_from: Option<f64>,
    /// Altitude where, after being buoyant, it became as dense as the air again.
    pub neutral_altitude: Option<f64>,
    /// Vertical speed when it crossed the neutral altitude (for the umbrella, §3.5.2).
    pub neutral_speed: Option<f64>,
    /// Mass ejected from the vent (kg).
    pub initial_mass: f64,
    /// Air mass entrained so far (kg).
    pub entrained_mass: f64,
    /// Mass lost by sedimentation so far (kg).
    pub sedimented_mass: f64,
    /// Solid (ash) mass carried (kg): `(1 − n) M₀` at the vent, less what sedimented.
    pub solid_mass: f64,
    /// Water carried (kg): the magmatic gas `n M₀` plus the vapour of the entrained air.
    pub water_mass: f64,
}

/// What one step changed, for budgets and messages.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SliceStepReport {
    /// Air mass entrained during the step (kg).
    pub entrained: f64,
    /// Mass sedimented during the step (kg).
    pub sedimented: f64,
    /// The slice became buoyant during this step.
    pub became_buoyant: bool,
    /// The slice crossed its neutral-buoyancy altitude during this step.
    pub reached_neutral: bool,
    /// The slice reached its apex (entered the umbrella phase) during this step.
    pub reached_apex: bool,
    /// The slice collapsed during this step.
    pub collapsed: bool,
    /// Column slices: the speed setting the slice's length was below
    /// [`crate::model::column::MIN_LENGTH_SPEED`] and was raised to it (near the apex).
    pub length_speed_floored: bool,
}

/// Ambient conditions a slice reads: air profile and wind.
pub struct SliceEnv<'a> {
    /// Air profile by altitude above sea level.
    pub air: &'a dyn AtmosphereProfile,
    /// Altitude of the vent above sea level (m).
    pub vent_altitude: f64,
    /// Wind at an altitude above the vent (m/s).
    pub wind: &'a dyn Fn(f64) -> DVec2,
}

impl Slice {
    /// A new slice at the vent (§3.4.1): size r₀, velocity v₀ along `direction` (normally +z).
    /// The column's slice is a cylinder of radius r₀ and length `v₀ Δt_e` at the vent
    /// density ([`PlumeParams::vent_density`]).
    pub fn at_vent(p: &PlumeParams) -> Self {
        let (rho0, length) = (p.vent_density(), p.vent_slice_length());
        let volume = if p.dynamics == Dynamics::Thesis {
            std::f64::consts::PI * p.r0.powi(3)
        } else {
            std::f64::consts::PI * p.r0 * p.r0 * length
        };
        let mass = rho0 * volume;
        Self {
            r: p.r0,
            length,
            position: DVec3::ZERO,
            velocity: DVec3::Z * p.v0,
            density: rho0,
            temperature: p.t0,
            mass,
            phase: Phase::Jet,
            age: 0.0,
            apex: 0.0,
            buoyant_from: None,
            neutral_altitude: None,
            neutral_speed: None,
            initial_mass: mass,
            entrained_mass: 0.0,
            sedimented_mass: 0.0,
            solid_mass: (1.0 - p.gas_fraction) * mass,
            water_mass: p.gas_fraction * mass,
        }
    }

    /// Volume (m³): `π r³` for a slice as long as it is wide (every thesis slice), else the
    /// cylinder `π r² · length`.
    pub fn volume(&self) -> f64 {
        if self.length == self.r {
            std::f64::consts::PI * self.r.powi(3)
        } else {
            std::f64::consts::PI * self.r * self.r * self.length
        }
    }

    /// One step of the thesis' slice ([`Dynamics::Thesis`], eqs 3.1–3.10) of a rising slice;
    /// [`Slice::step`] (in [`super`]) chooses it or the physical column and filters the
    /// phases and `dt` first.
    pub(crate) fn step_thesis(&mut self, p: &PlumeParams, env: &SliceEnv, dt: f64) -> SliceStepReport {
        let mut report = SliceStepReport::default();
        let air = env.air.sample(env.vent_altitude + self.position.z);
        let (rho_a, t_a) = (air.density, air.temperature);
        let wind = (env.wind)(self.position.z);
        let speed = self.velocity.length();
        let rising = self.velocity.z >= 0.0;

        // Entrainment velocity, eq 3.7: U_e = k_s |v − v_w cos θ| + k_w |v_w sin θ|.
        let vw = wind.length();
        let cos_theta =
            if speed > 0.0 && vw > 0.0 { self.velocity.dot(wind.extend(0.0)) / (speed * vw) } else { 0.0 };
        let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
        let u_e = p.ks * (speed - vw * cos_theta).abs() + p.kw * (vw * sin_theta).abs();

        // Entrained ring of air (§3.4.3): π((τU_e + r)² − r²) · |v| Δt, mass ρ_a × volume.
        let ring = std::f64::consts::PI * ((p.tau * u_e + self.r).powi(2) - self.r.powi(2)) * speed * dt;
        let m_air = rho_a * ring;

        // Mixing temperature, eq 3.8 (constant heat capacity).
        let m_before = self.mass;
        let t_new = (m_air * t_a + m_before * self.temperature) / (m_air + m_before);
        // Volumes from the perfect gas law; the slice's own contraction is the switch.
        let v_slice = if p.contraction { self.volume() * t_new / self.temperature } else { self.volume() };
        let v_air = ring * t_new / t_a;
        let volume = v_slice + v_air;
        // Sedimentation, eq 3.9 with σ_col as a density decrement rate (kg/m³/s), never taking
        // the slice below a density floor nor more solid than it carries (ash cannot sediment
        // out of pure gas).
        let sed = (p.sigma_col * self.volume() * dt)
            .min((m_before - MIN_DENSITY * self.volume()).max(0.0))
            .min(self.solid_mass.max(0.0));
        // Water vapour of the entrained air (g/m³ → kg), kept apart from the dry air so the
        // coupled atmosphere receives the column's moisture (§4.3.3).
        let vapour = 1e-3 * env.air.humidity(env.vent_altitude + self.position.z).max(0.0) * ring;
        let mass = m_before + m_air - sed;

        self.temperature = t_new;
        self.r = (volume / std::f64::consts::PI).cbrt();
        self.length = self.r;
        self.mass = mass;
        self.density = mass / volume;
        self.entrained_mass += m_air;
        self.sedimented_mass += sed;
        self.solid_mass -= sed;
        self.water_mass += vapour;
        report.entrained = m_air;
        report.sedimented = sed;

        // Forces with the updated geometry: weight + buoyancy (3.4), vertical.
        let g = G0;
        let f_vertical = -mass * g + rho_a * volume * g;
        // Eq 3.3: v^{i+1} = (M^{i−1}/M^i) v^i + Δt F/M^i, M^{i−1} = mass before entrainment.
        let mut v = self.velocity * (m_before / mass) + DVec3::Z * (dt * f_vertical / mass);
        // Friction, eq 3.5: −½ ρ_a C_d S |v| v, S = 2πr². Quadratic drag integrated
        // implicitly (v / (1 + c|v|Δt)) so it can never reverse the velocity.
        let s_lat = 2.0 * std::f64::consts::PI * self.r * self.r;
        let c_drag = 0.5 * rho_a * p.drag_coefficient * s_lat / mass;
        v /= 1.0 + c_drag * v.length() * dt;
        // Wind, eq 3.6: λ S_eff |v_w − v_xy| (v_w − v_xy), S_eff = 2r². Stiff for light
        // slices (λ = 600): the relative horizontal velocity u obeys du/dt = −k|u|u, whose exact
        // solution over Δt is u / (1 + k|u|Δt). Exact, stable for any Δt.
        let k_wind = p.wind_coefficient * 2.0 * self.r * self.r / mass;
        let u = v.truncate() - wind;
        let u = u / (1.0 + k_wind * u.length() * dt);
        v = (wind + u).extend(v.z);

        self.velocity = v;
        self.position += v * dt;
        self.age += dt;
        self.apex = self.apex.max(self.position.z);
        self.update_phase(env, &mut report, rising);
        report
    }

    /// Phases, evaluated after the velocity update (§3.6): buoyant once lighter than the air,
    /// neutral when it becomes as dense again, apex (umbrella) when the vertical velocity of a
    /// buoyant slice turns from up (`rising`, before this step) to down, collapse when it
    /// turns negative before the slice was ever buoyant. A buoyant slice that starts out
    /// sinking (a secondary column carrying a flow's downward momentum) is not at an apex: it
    /// sinks until its buoyancy turns it round.
    pub(crate) fn update_phase(&mut self, env: &SliceEnv, report: &mut SliceStepReport, rising: bool) {
        // The air is sampled only when the comparison can change a phase: before the slice
        // was ever buoyant, or while buoyant below its neutral altitude (a slice past its
        // neutral altitude, most secondary columns' long tail, skips one whole air sample).
        let needs_air =
            self.buoyant_from.is_none() || (self.phase == Phase::Buoyant && self.neutral_altitude.is_none());
        let lighter = needs_air && self.density < env.air.density(env.vent_altitude + self.position.z);
        if self.buoyant_from.is_none() && lighter {
            self.buoyant_from = Some(self.position.z);
            self.phase = Phase::Buoyant;
            report.became_buoyant = true;
        }
        if self.phase == Phase::Buoyant && !lighter && self.neutral_altitude.is_none() {
            self.neutral_altitude = Some(self.position.z);
            self.neutral_speed = Some(self.velocity.z.max(0.0));
            report.reached_neutral = true;
        }
        if self.velocity.z < 0.0 {
            if self.buoyant_from.is_none() {
                self.phase = Phase::Collapsed;
                report.collapsed = true;
            } else if rising {
                self.phase = Phase::Umbrella;
                report.reached_apex = true;
                if self.neutral_altitude.is_none() {
                    // Stopped while still lighter than the air (e.g. drag): neutral here.
                    self.neutral_altitude = Some(self.position.z);
                    self.neutral_speed = Some(0.0);
                    report.reached_neutral = true;
                }
            }
        }
    }

    /// Orientation of the slice (§3.4.3: slices stay orthogonal to their trajectory): the
    /// rotation taking the slice frame's axis (+z) to the direction of motion, the shortest
    /// arc. Its local x/y span the slice's plane, where the s1 vortex ring lies.
    pub fn rotation(&self) -> DQuat {
        DQuat::from_rotation_arc(DVec3::Z, self.velocity.normalize_or(DVec3::Z))
    }

    /// Whether every field is finite (debug checks and fuzzing).
    pub fn is_finite(&self) -> bool {
        self.r.is_finite()
            && self.position.is_finite()
            && self.velocity.is_finite()
            && self.density.is_finite()
            && self.temperature.is_finite()
            && self.mass.is_finite()
    }
}
