//! Components and messages of the plume plugin.

use bevy::ecs::entity::{Entity, MapEntities};
use bevy::prelude::{Component, Message, ReflectComponent, ReflectDefault, Vec3};
use bevy::reflect::Reflect;
use volcano_core::error::ConfigError;

use crate::model::ambient::LayeredAmbient;
use crate::model::params::{PlumeParams, Preset};
use crate::model::pyroclastic::PyroclasticParams;
use crate::model::slice::Slice;
use crate::model::spheres::{S1Sphere, SphereParams};
use crate::model::timeline::EruptionTimeline;
use crate::model::umbrella::UmbrellaSphere;

/// An explosive eruption on a [`volcano_core::Volcano`]: emits a slice every `r₀ / (2 v₀)`
/// seconds while `active`. Edits to the parameters apply to new slices. The default is the
/// thesis preset ([`Eruption::thesis`]), so a scene (`bsn!`) writes `Eruption::plinian()` or
/// patches fields, `Eruption { active: false }`; values out of range freeze the column until
/// they are fixed, as live edits do.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[require(EmissionState, PlumeAshBudget, crate::ground::PyroclasticBudget)]
#[reflect(Component, Default)]
pub struct Eruption {
    /// Slice model parameters (validated on construction; re-checked before each emission).
    pub params: PlumeParams,
    /// Sphere counts.
    pub spheres: SphereParams,
    /// Whether slices are emitted.
    pub active: bool,
    /// Umbrella spheres older than this are removed (s, in [0, 3600]). At the Plinian preset's
    /// 24 s1 spheres per second, 300 s keeps about 7,000 umbrella spheres alive.
    pub umbrella_lifetime: f64,
    /// Time constant (s, in [1, 10⁵]) of the ash fallout from umbrella spheres: each sphere
    /// releases `1 − exp(−Δt/τ)` of the ash it carries per step into the atmosphere (when
    /// coupled); what is left when it expires is released at once ([`AshReleased`]).
    pub umbrella_fallout_s: f64,
    /// Pyroclastic particles of collapsing slices (§3.6).
    pub pyroclastic: PyroclasticParams,
}

impl Default for Eruption {
    /// [`Eruption::thesis`]: thesis Table 3.1 as written.
    fn default() -> Self {
        Self::thesis()
    }
}

impl Eruption {
    /// An eruption with validated parameters.
    pub fn new(params: PlumeParams, spheres: SphereParams) -> Result<Self, ConfigError> {
        let e = Self {
            params,
            spheres,
            active: true,
            umbrella_lifetime: 300.0,
            umbrella_fallout_s: 600.0,
            pyroclastic: Default::default(),
        };
        e.validate()?;
        Ok(e)
    }

    /// Checks every field (also used each step, so edits through reflection are caught).
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.params.validate()?;
        self.spheres.validate()?;
        volcano_core::error::in_range("umbrella_lifetime", self.umbrella_lifetime, 0.0, 3_600.0)?;
        volcano_core::error::in_range("umbrella_fallout_s", self.umbrella_fallout_s, 1.0, 1e5)?;
        self.pyroclastic.validate()?;
        Ok(())
    }

    /// The thesis preset (Table 3.1, v₀ = 150 m/s): the column collapses at ≈1.9 km.
    pub fn thesis() -> Self {
        Self {
            params: PlumeParams::default(),
            spheres: SphereParams::default(),
            active: true,
            umbrella_lifetime: 900.0,
            umbrella_fallout_s: 600.0,
            pyroclastic: Default::default(),
        }
    }

    /// A Plinian column for demos (preset `plinian_showcase`): Table 3.1 with v₀ = 200 m/s,
    /// which rises to ≈10 km with an umbrella from ≈7.4 km (single-slice values, vent at sea
    /// level), and a 20 m/s wind at 12 km so the umbrella drifts.
    pub fn plinian() -> Self {
        Self { params: crate::Preset::PlinianShowcase.params(), ..Self::thesis() }
    }

    /// The physical column (preset `physical`, docs/physics/plume.md §4.5): 3 wt% gas, 1,273 K,
    /// r₀ = 100 m, v₀ = 150 m/s, 2.7·10⁷ kg/s.
    pub fn physical() -> Self {
        Self { params: crate::Preset::Physical.params(), ..Self::thesis() }
    }

    /// This eruption with the mass eruption rate that makes its column top out `km` above the
    /// vent under its own atmosphere and wind (bisection on the single-slice model,
    /// [`crate::model::inverse::mer_for_height`]; the vent follows
    /// [`PlumeParams::with_mer`] without a given exit speed). Errors when no rate in
    /// 10²–10¹⁰ kg/s reaches the height.
    pub fn with_target_height(self, km: f64) -> Result<Self, ConfigError> {
        let solved = crate::model::inverse::mer_for_height(&self.params, km * 1_000.0)?;
        let e = Self { params: solved.params, ..self };
        e.validate()?;
        Ok(e)
    }

    /// A collapsing column (preset `pyroclastic_showcase`, v₀ = 70 m/s): falls back from
    /// ≈255 m. Collapsed slices leave the column for the pyroclastic flows (§3.6).
    pub fn pyroclastic() -> Self {
        Self { params: crate::Preset::PyroclasticShowcase.params(), ..Self::thesis() }
    }
}

/// Drives the [`Eruption`] beside it from an [`EruptionTimeline`] (the vent's v₀, r₀ or mass
/// rate, the preset, whether it emits), evaluated at the start of every plume step from the
/// script's own clock, so the story is the same at any frame rate. A preset key replaces the
/// eruption's parameters once, when reached, but keeps its environment (wind profile,
/// atmosphere, humidity, vent altitude); the numeric channels then apply. `volcano` loads
/// timelines as assets (`*.timeline.ron`).
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Debug)]
pub struct EruptionScript {
    /// The keys.
    pub timeline: EruptionTimeline,
    /// Seconds of plume time since the script started.
    pub elapsed_s: f64,
    /// The preset the script applied last.
    pub applied_preset: Option<Preset>,
}

impl EruptionScript {
    /// A script from its first key, with a validated timeline.
    pub fn new(timeline: EruptionTimeline) -> Result<Self, ConfigError> {
        timeline.validate()?;
        Ok(Self { timeline, elapsed_s: 0.0, applied_preset: None })
    }
}

/// Emission bookkeeping of an [`Eruption`].
#[derive(Component, Debug, Clone, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct EmissionState {
    /// Seconds since the last slice.
    pub since_last: f64,
    /// Slices emitted so far.
    pub emitted: u64,
    /// Slices that were due at the end of the last step but not emitted (more than
    /// `model::domain::MAX_EMISSIONS_PER_STEP` per step); carried to the next steps.
    pub backlog: u64,
    /// Steps that ended with a backlog.
    pub capped_steps: u64,
}

/// Where the solid (ash) mass an eruption emitted went, as far as the plume knows (kg). The
/// rest is in live slices and umbrella spheres, or was handed to the atmosphere by the
/// coupling (which keeps its own books from there on).
#[derive(Component, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Component)]
pub struct PlumeAshBudget {
    /// Solid mass of every slice emitted at the vent.
    pub emitted_kg: f64,
    /// Solid mass of slices that collapsed into pyroclastic flows (booked there from then on).
    pub to_flows_kg: f64,
    /// Solid mass of slices or spheres removed without a place to put it (non-finite state,
    /// a slice with no ring spheres, an expired sphere's ash that no atmosphere took).
    pub lost_kg: f64,
    /// Ash released as [`AshReleased`] messages by expiring umbrella spheres and by slices the
    /// live-slice cap retired.
    pub released_kg: f64,
    /// Of `released_kg`, the ash of slices and umbrella spheres retired by the caps
    /// ([`crate::caps::PlumeCaps::max_live_slices`], `max_umbrella_spheres`).
    pub capped_kg: f64,
}

/// The ambient air of a coupled column, written by the coupling after each weather step.
/// While present on a volcano, its slices and umbrella read it instead of the eruption's
/// `PlumeParams::atmosphere` and `wind`.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub struct PlumeAmbient(pub LayeredAmbient);

/// A live column slice. Its model state is in the plume frame (z up above the vent, x/y
/// horizontal); the entity's `Transform` is kept in world space (y up).
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub struct PlumeSlice {
    /// The volcano entity that emitted it.
    #[entities]
    pub volcano: Entity,
    /// Emission index (also the id of its random stream).
    pub index: u64,
    /// Vent position in world space when emitted.
    pub vent: Vec3,
    /// Model state.
    pub state: Slice,
    /// Spin angle of a ring sphere of mean size, `∫ v / (r/2) dt` (rad, unbounded): a sphere of
    /// size factor `f` has turned by `ring_phase / f` (Ω = v / r_s, §3.5.1). One sum per slice
    /// instead of one per sphere.
    pub ring_phase: f64,
    /// Ash this slice has shed (σ_col, eq 3.9) and not yet handed to an atmosphere (kg).
    pub ash_pending: f64,
    /// A secondary column lifted off a pyroclastic flow (not emitted at the vent).
    pub secondary: bool,
}

/// An s1 sphere riding on a slice's vortex ring.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub struct S1 {
    /// The slice entity.
    #[entities]
    pub slice: Entity,
    /// Position on the ring, size factor.
    pub sphere: S1Sphere,
    /// Spin angle about the ring tangent (rad, in [0, 2π)), updated once per base tick from
    /// the slice's [`PlumeSlice::ring_phase`].
    pub spin: f64,
    /// Stable id for detail-sphere generation: `(slice index << 8) | k`.
    pub id: u64,
}

/// An s1 sphere detached into the umbrella.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub struct Umbrella {
    /// The volcano whose eruption it belongs to (its wind drifts the umbrella).
    #[entities]
    pub volcano: Entity,
    /// Kinematics.
    pub sphere: UmbrellaSphere,
    /// Radius (m).
    pub radius: f64,
    /// Density of the slice it left (kg/m³), for shading and export.
    pub density: f64,
    /// Seconds since it detached.
    pub age: f64,
    /// Vent position in world space.
    pub vent: Vec3,
    /// Stable id (as for [`S1`]).
    pub id: u64,
    /// Ash still carried (kg): its share of the slice's solid mass at detachment.
    pub ash: f64,
    /// Ash fallen out of it and not yet handed to an atmosphere (kg).
    pub ash_pending: f64,
}

/// An expiring umbrella sphere released the ash it still held (sent once per sphere; the
/// coupling puts it into the air layer at `position`).
#[derive(Message, Debug, Clone, Copy, PartialEq, MapEntities)]
pub struct AshReleased {
    /// Emitting volcano.
    #[entities]
    pub volcano: Entity,
    /// World position.
    pub position: Vec3,
    /// Ash mass (kg).
    pub mass: f64,
}

/// A slice's vertical velocity turned negative before it became buoyant (§3.6): the slice and
/// its spheres are replaced by pyroclastic particles ([`crate::PyroclasticFlowStarted`]).
#[derive(Message, Debug, Clone, Copy, PartialEq)]
pub struct PlumeCollapsed {
    /// Emitting volcano.
    pub volcano: Entity,
    /// World position of the slice when it collapsed.
    pub position: Vec3,
    /// Slice mass (kg).
    pub mass: f64,
}

/// Hand-over from the plume domain to the pyroclastic domain: a slice that collapsed this step,
/// already removed from the world with its spheres (its ash is booked as `to_flows_kg`). The
/// pyroclastic domain turns it into particles in the same base tick. Written once per
/// collapsed slice, after [`PlumeCollapsed`]; a game may read it too.
#[derive(Message, Debug, Clone, PartialEq)]
pub struct SliceCollapsed(pub PlumeSlice);

/// Hand-over from the pyroclastic domain to the plume domain: buoyant particles that lifted off
/// as a new rising slice (already numbered and booked, see `SecondaryColumnFormed`). The plume
/// domain spawns it with its ring of s1 spheres right after the lift-off, in the same step.
#[derive(Message, Debug, Clone, PartialEq)]
pub struct SecondaryColumnRising(pub PlumeSlice);

/// A slice rose through its neutral-buoyancy altitude.
#[derive(Message, Debug, Clone, Copy, PartialEq)]
pub struct NeutralBuoyancyReached {
    /// Emitting volcano.
    pub volcano: Entity,
    /// Altitude above the vent (m).
    pub altitude: f64,
    /// Vertical speed at that moment (m/s).
    pub speed: f64,
}

/// A slice reached its apex and its spheres now spread as the umbrella.
#[derive(Message, Debug, Clone, Copy, PartialEq)]
pub struct UmbrellaSpreading {
    /// Emitting volcano.
    pub volcano: Entity,
    /// Apex above the vent (m).
    pub apex: f64,
    /// Neutral-buoyancy altitude above the vent (m).
    pub neutral: f64,
}

pub use crate::model::plume_to_world;
