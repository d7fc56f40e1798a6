//! Components, messages and the gameplay query of the lava plugin.

use bevy::ecs::entity::{Entity, MapEntities};
use bevy::ecs::reflect::ReflectComponent;
use bevy::ecs::system::SystemParam;
use bevy::prelude::{Component, Message, Query, ReflectDefault, Res, Transform, Vec2, Vec3, Vec3Swizzles};
use bevy::reflect::Reflect;
use volcano_core::ConfigError;
use volcano_core::error::{in_range, positive};

use crate::model::breakout::BreakoutState;
use crate::model::field::{Edges, FlowField, Placement};
use crate::model::folds::{FoldParams, FoldSystem};
use crate::model::params::LavaParams;
use crate::model::surface::SurfaceState;
use crate::model::thermal::surface_temperature;

/// A lava field (a *patch*): a local grid placed on a terrain, with its edges and lava
/// parameters. The grid is centred on `placement.centre` (x, z) moved by the x and z of the
/// entity's `Transform` translation, so `(LavaField::square(256, 2.0)?,
/// Transform::from_xyz(x, 0.0, z))` puts a 512 m patch centred on (x, z); without a
/// `Transform` the centre is a world position ([`field_placement`]). The plugin builds its
/// [`LavaState`] at the next lava step by resampling the `Terrain` whose grid contains the
/// whole patch (the finest if several do; flat ground at altitude 0 if the world has no
/// terrain at all; rejected if terrains exist but none contains it), and writes the lava that
/// freezes back into that terrain. Moving the entity rebuilds the field where it now is (its
/// lava is lost). Parameter edits apply live (re-validated each step; an invalid edit freezes
/// the field until fixed).
/// The default is [`LavaField::new`] of the default [`Placement`] and [`LavaParams`], so a
/// scene (`bsn!`) patches only the fields it sets: `LavaField { placement: Placement { centre:
/// Vec2::ZERO, nx: 256, ny: 256, cell: 1.0 } }` beside a `Transform`.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct LavaField {
    /// Grid placement and size.
    pub placement: Placement,
    /// Edge behaviour.
    pub edges: Edges,
    /// Lava parameters.
    pub params: LavaParams,
    /// Fold parameters (layer 3).
    pub folds: FoldParams,
    /// Seed of the fold layer's random choices (rolling over/under).
    pub seed: u64,
}

impl Default for LavaField {
    /// 512² cells of 0.5 m centred on its entity ([`Placement::default`]), thesis Table
    /// 5.2 parameters, open edges, seed 0: what [`LavaField::new`] gives for the defaults.
    fn default() -> Self {
        Self::unchecked(Placement::default(), LavaParams::default())
    }
}

impl LavaField {
    /// A validated field with open edges (lava leaving the grid is booked as outflow).
    pub fn new(placement: Placement, params: LavaParams) -> Result<Self, ConfigError> {
        placement.validate()?;
        params.validate()?;
        Ok(Self::unchecked(placement, params))
    }

    /// The field with open edges, default folds and seed 0, without checking the values.
    fn unchecked(placement: Placement, params: LavaParams) -> Self {
        let open = crate::model::field::Edge::Open;
        let edges = Edges { west: open, east: open, south: open, north: open };
        Self { placement, edges, params, folds: FoldParams::default(), seed: 0 }
    }

    /// A validated square field of `cells × cells` cells of `cell` m, centred on its entity's
    /// `Transform`, with the default lava parameters and open edges.
    pub fn square(cells: usize, cell: f64) -> Result<Self, ConfigError> {
        Self::new(Placement { centre: Vec2::ZERO, nx: cells, ny: cells, cell }, LavaParams::default())
    }
}

/// The world placement of `field` on an entity with `transform` (if any): its centre moved by
/// the translation's x and z. A lava grid lies on the ground, so the translation's y, a
/// rotation and a scale do not apply to it (the same for sources and zones).
pub fn field_placement(field: &LavaField, transform: Option<&Transform>) -> Placement {
    Placement { centre: field.placement.centre + offset(transform), ..field.placement }
}

/// The x and z of a transform's translation (zero without one).
fn offset(transform: Option<&Transform>) -> Vec2 {
    transform.map_or(Vec2::ZERO, |t| t.translation.xz())
}

/// Built state of a [`LavaField`] (flow and surface layers). Reflected as one opaque value
/// (large grids of model types).
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(opaque)]
#[reflect(Component)]
pub struct LavaState {
    /// Flow layer.
    pub flow: FlowField,
    /// Surface layer.
    pub surface: SurfaceState,
    /// Fold layer (particles in one `Vec`; render them instanced).
    pub folds: FoldSystem,
    /// Crust drag and breakouts.
    pub breakouts: BreakoutState,
    /// Substeps of the last step.
    pub last_substeps: u32,
    /// Whether the last step hit the substep cap (the flow was slowed to stay stable).
    pub mobility_capped: bool,
    /// Whether the folds are at [`FoldParams::max_particles`] after the last step (no fold
    /// is created or extended until particles are buried; logged once per field).
    pub folds_at_cap: bool,
    /// The terrain the field was built on, into which frozen lava is written back (none when
    /// the field was built on flat ground without a `Terrain`).
    #[entities]
    pub imprint: Option<TerrainLink>,
}

/// The terrain entity under a field and what the field wrote into it.
#[derive(Debug, Clone, PartialEq, MapEntities)]
pub struct TerrainLink {
    /// The `Terrain` entity.
    #[entities]
    pub terrain: Entity,
    /// Nodes covered and frozen volume written so far.
    pub imprint: crate::model::imprint::TerrainImprint,
    /// Why write-back stopped (the terrain was despawned or replaced by another grid); the
    /// field keeps its frozen lava in its own ground.
    pub detached: Option<String>,
}

/// Why a field could not be built, or `Ok`.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub enum LavaFieldStatus {
    /// Built and stepping.
    Ok,
    /// Rejected (placement off the terrain, invalid parameters); the message says why.
    Rejected(String),
}

/// A lava source emitting `rate` m³/s at `temperature` K over the cells within `radius` m of
/// `position` moved by its entity's `Transform` translation (x, z; a world position without
/// a `Transform`): `(LavaSource::new(5.0)?, Transform::from_xyz(x, 0.0, z))`. Add, move and
/// remove it live. A source that is on no lava field, or whose values were edited out of
/// range, gets [`LavaSourceStatus::Rejected`].
/// A scene (`bsn!`) patches the default: `LavaSource { rate: 3.0 }` beside a `Transform`.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component, Default)]
pub struct LavaSource {
    /// Position (only x and z are used), added to the entity's `Transform` translation.
    pub position: Vec3,
    /// Volume rate (m³/s), ≥ 0.
    pub rate: f64,
    /// Lava temperature (K), in [300, 2500].
    pub temperature: f64,
    /// Radius of the fed disc (m), ≥ 0 (0 = one cell).
    pub radius: f64,
}

impl Default for LavaSource {
    /// 1 m³/s at the default liquidus (1,473 K) over one cell, at the world origin.
    fn default() -> Self {
        Self { position: Vec3::ZERO, rate: 1.0, temperature: LavaParams::default().liquidus, radius: 0.0 }
    }
}

impl LavaSource {
    /// A validated source of `rate` m³/s over one cell at its entity's `Transform`, at the
    /// default liquidus (1473 K, thesis Table 5.2).
    pub fn new(rate: f64) -> Result<Self, ConfigError> {
        let s = Self { position: Vec3::ZERO, rate, temperature: LavaParams::default().liquidus, radius: 0.0 };
        s.validate()?;
        Ok(s)
    }

    /// The same source at `temperature` K, validated.
    pub fn with_temperature(self, temperature: f64) -> Result<Self, ConfigError> {
        let s = Self { temperature, ..self };
        s.validate()?;
        Ok(s)
    }

    /// The same source over the cells within `radius` m, validated.
    pub fn with_radius(self, radius: f64) -> Result<Self, ConfigError> {
        let s = Self { radius, ..self };
        s.validate()?;
        Ok(s)
    }

    /// The same source at `position` (added to its entity's `Transform` translation), validated.
    pub fn at(self, position: Vec3) -> Result<Self, ConfigError> {
        let s = Self { position, ..self };
        s.validate()?;
        Ok(s)
    }

    /// Where the source is (x, z) on an entity with `transform` (if any).
    pub fn world_xz(&self, transform: Option<&Transform>) -> Vec2 {
        self.position.xz() + offset(transform)
    }

    /// Checks the values (position is checked against the fields at each step).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !self.position.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "source position",
                value: f64::NAN,
                reason: "must be finite".into(),
            });
        }
        in_range("source rate", self.rate, 0.0, 1e6)?;
        in_range("source temperature", self.temperature, 300.0, 2500.0)?;
        in_range("source radius", self.radius, 0.0, 1e4)?;
        Ok(())
    }
}

/// Whether a [`LavaSource`] is feeding a field.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub enum LavaSourceStatus {
    /// Feeding this field entity.
    Active(#[entities] Entity),
    /// Not feeding; why.
    Rejected(String),
}

/// A marked area: when lava (thicker than the field's `min_thickness`) covers any cell within
/// `radius` of `centre` (x, z, moved by the entity's `Transform` translation as for a
/// [`LavaSource`]), a [`LavaReached`] message is written once.
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(Component)]
pub struct LavaZone {
    /// Centre (x, z), added to the entity's `Transform` translation.
    pub centre: Vec2,
    /// Radius (m), > 0.
    pub radius: f32,
    /// Set when the lava arrived.
    pub reached: bool,
}

impl LavaZone {
    /// A validated zone.
    pub fn new(centre: Vec2, radius: f32) -> Result<Self, ConfigError> {
        positive("zone radius", radius as f64)?;
        if !centre.is_finite() {
            return Err(ConfigError::InvalidParameter {
                name: "zone centre",
                value: f64::NAN,
                reason: "must be finite".into(),
            });
        }
        Ok(Self { centre, radius, reached: false })
    }

    /// Where the zone is centred (x, z) on an entity with `transform` (if any).
    pub fn world_centre(&self, transform: Option<&Transform>) -> Vec2 {
        self.centre + offset(transform)
    }
}

/// Lava reached a [`LavaZone`].
#[derive(Message, Debug, Clone, PartialEq)]
pub struct LavaReached {
    /// The zone entity.
    pub entity: Entity,
    /// The field whose lava reached it, or the terrain whose vent lava ([`crate::LavaVent`]) did.
    pub field: Entity,
}

/// The crust tore over inflated lava and a new lobe starts there.
#[derive(Message, Debug, Clone, PartialEq)]
pub struct LavaBreakout {
    /// The field.
    pub field: Entity,
    /// World position of the tear.
    pub position: Vec3,
}

/// What the lava is like at a point, for gameplay.
#[derive(Debug, Clone, Copy, PartialEq, Reflect)]
pub struct LavaProbe {
    /// The field sampled (the terrain, for a volcano's own lava).
    pub field: Entity,
    /// Liquid lava thickness (m).
    pub thickness: f64,
    /// Depth-averaged lava temperature (K).
    pub temperature: f64,
    /// Temperature at the top of the crust (K), see
    /// [`crate::model::thermal::surface_temperature`].
    pub surface_temperature: f64,
    /// Crust thickness (m).
    pub crust: f64,
    /// Surface speed (m/s).
    pub surface_speed: f64,
    /// Lava surface altitude (ground + frozen lava + liquid lava, m).
    pub surface_altitude: f64,
}

impl LavaState {
    /// The three layers, borrowed for one model call.
    pub fn layers_mut(&mut self) -> crate::model::LayersMut<'_> {
        crate::model::LayersMut {
            flow: &mut self.flow,
            surface: &mut self.surface,
            folds: &mut self.folds,
            breakouts: &mut self.breakouts,
        }
    }

    /// Lava at world (x, z), or `None` off this field.
    pub fn probe(&self, field: Entity, params: &LavaParams, xz: Vec2) -> Option<LavaProbe> {
        let (i, j) = self.flow.cell_at(xz)?;
        let p = self.flow.probe(xz)?;
        let k = j * self.flow.nx() + i;
        let crust = self.surface.crust[k];
        Some(LavaProbe {
            field,
            thickness: p.thickness,
            temperature: p.temperature,
            surface_temperature: if p.thickness > 0.0 {
                surface_temperature(params, p.temperature, crust)
            } else {
                params.air_temperature
            },
            crust,
            surface_speed: self.surface.vsurf[0][k].hypot(self.surface.vsurf[1][k]),
            surface_altitude: p.ground + p.thickness,
        })
    }
}

/// Gameplay query: "lava thickness / surface temperature / crust at this point", on lava
/// fields and on a volcano's own lava ([`crate::TerrainLava`]).
#[derive(SystemParam)]
pub struct LavaQuery<'w, 's> {
    fields: Query<'w, 's, (Entity, &'static LavaField, &'static LavaState)>,
    vent_lava: Query<'w, 's, (Entity, &'static crate::vents::TerrainLava)>,
    vent_settings: Option<Res<'w, crate::vents::VentLavaSettings>>,
}

impl LavaQuery<'_, '_> {
    /// The lava at world (x, z): the thickest of the fields covering it and of the vent lava
    /// stored there. Vent lava's `field` is its terrain entity; its crust is the law of its
    /// age (docs/physics/lava.md §7) and its surface speed 3/2 of its depth-averaged speed
    /// (a Jeffreys profile).
    pub fn at(&self, xz: Vec2) -> Option<LavaProbe> {
        let default;
        let params = match self.vent_settings.as_deref() {
            Some(s) => &s.params,
            None => {
                default = crate::vents::VentLavaSettings::default();
                &default.params
            }
        };
        let vent = self.vent_lava.iter().filter_map(|(terrain, lava)| {
            let r = &lava.runout;
            let (a, b) = r.grid().cell_of(xz.as_dvec2())?;
            let (h, t, ground, age) = r.cell_state(a, b)?;
            let wet = h > 0.0;
            let crust = if wet { crate::model::crust::crust_from_contact(params.kappa(), age) } else { 0.0 };
            let speed = r.speed(a, b).unwrap_or(0.0);
            Some(LavaProbe {
                field: terrain,
                thickness: h,
                temperature: if wet { t } else { params.air_temperature },
                surface_temperature: if wet {
                    surface_temperature(params, t, crust)
                } else {
                    params.air_temperature
                },
                crust,
                surface_speed: crate::model::crust::SURFACE_TO_MEAN * speed,
                surface_altitude: ground + h,
            })
        });
        self.fields
            .iter()
            .filter_map(|(e, f, s)| s.probe(e, &f.params, xz))
            .chain(vent)
            .max_by(|a, b| a.thickness.total_cmp(&b.thickness))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_are_the_validated_values() {
        let field = LavaField::new(Placement::default(), LavaParams::default()).unwrap();
        assert_eq!(LavaField::default(), field);
        let source = LavaSource::default();
        assert!(source.validate().is_ok());
        assert_eq!(source, LavaSource::new(1.0).unwrap());
    }
}
