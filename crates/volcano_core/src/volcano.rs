//! The [`Volcano`] entity: a vent on the terrain with a radius and a seed. Its world position is
//! the entity's `Transform` (x, z); the y coordinate is snapped to the terrain under it and the
//! resulting vent point is published as [`VentPosition`], and the terrain it stands on as the
//! relationship [`OnTerrain`] (the terrain lists its volcanoes in [`TerrainVolcanoes`]): what a
//! volcano leaves on the ground (deposits) goes to that terrain.

use bevy::ecs::component::Component;
use bevy::ecs::entity::Entity;
use bevy::ecs::error::BevyError;
use bevy::ecs::template::{FromTemplate, SpecializeFromTemplate, Template, TemplateContext};
use bevy::math::Vec3;
use bevy::prelude::{Commands, DetectChanges, Query, Ref, ReflectComponent, ReflectDefault};
use bevy::reflect::Reflect;
use bevy::transform::components::Transform;
use serde::{Deserialize, Serialize};

use crate::error::{ConfigError, in_range};
use crate::rng::VolcanoRng;
use crate::terrain::Terrain;

/// A volcano. Spawn it with a `Transform` whose x/z place the vent; the vent snaps to the
/// terrain. Build it with [`Volcano::new`] or from a RON [`VolcanoSpec`], which validate; a
/// scene (`bsn!`) writes it through its [`VolcanoTemplate`].
#[derive(Component, Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[require(Transform)]
#[reflect(Component)]
pub struct Volcano {
    vent_radius: f32,
    seed: u64,
}

impl Default for Volcano {
    /// Vent radius 100 m (thesis Table 3.1, r₀), seed 0.
    fn default() -> Self {
        Self { vent_radius: 100.0, seed: 0 }
    }
}

impl Volcano {
    /// Largest vent radius accepted (m).
    pub const MAX_VENT_RADIUS: f32 = 2_000.0;

    /// A volcano with vent radius `vent_radius` (m, in (0, 2000]) and RNG seed `seed`.
    pub fn new(vent_radius: f32, seed: u64) -> Result<Self, ConfigError> {
        let mut v = Self { vent_radius: 1.0, seed };
        v.set_vent_radius(vent_radius)?;
        Ok(v)
    }
    /// Vent radius (m).
    pub fn vent_radius(&self) -> f32 {
        self.vent_radius
    }
    /// Changes the vent radius; rejects NaN, ≤ 0 or above [`Volcano::MAX_VENT_RADIUS`].
    pub fn set_vent_radius(&mut self, r: f32) -> Result<(), ConfigError> {
        if !(r.is_finite() && r > 0.0 && r <= Self::MAX_VENT_RADIUS) {
            return Err(ConfigError::InvalidParameter {
                name: "vent_radius",
                value: r as f64,
                reason: format!("must be a finite number in (0, {}] metres", Self::MAX_VENT_RADIUS),
            });
        }
        self.vent_radius = r;
        Ok(())
    }
    /// Seed of the volcano's random streams.
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// Checks a value that may have been edited through reflection.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.clone().set_vent_radius(self.vent_radius)
    }
}

/// How a scene writes a [`Volcano`] (`Volcano`'s `FromTemplate::Template`). A volcano keeps
/// its fields private so that its vent radius is always valid; `bsn!` patches this template's
/// fields instead and builds the volcano with [`Volcano::new`] when the scene spawns. An
/// invalid radius fails the spawn with an error naming `vent_radius`, never a panic.
///
/// ```text
/// bsn! { Volcano { vent_radius: 80.0, seed: 7 } Transform::from_xyz(0.0, 0.0, -2_000.0) }
/// bsn! { Volcano::new(80.0, 7) }   // the same, through `VolcanoTemplate::new`
/// bsn! { Volcano }                 // Volcano::default()
/// ```
///
/// Not `Clone`: a `Default + Clone` type is its own template in Bevy, so a template that builds
/// something else copies itself with [`Template::clone_template`].
#[derive(Debug, PartialEq, Reflect)]
#[reflect(Default, Debug, PartialEq)]
pub struct VolcanoTemplate {
    /// Vent radius (m), in (0, [`Volcano::MAX_VENT_RADIUS`]]; checked when the scene spawns.
    pub vent_radius: f32,
    /// Seed of the volcano's random streams.
    pub seed: u64,
}

impl Default for VolcanoTemplate {
    /// [`Volcano::default`]'s values: vent radius 100 m, seed 0.
    fn default() -> Self {
        let v = Volcano::default();
        Self { vent_radius: v.vent_radius, seed: v.seed }
    }
}

impl VolcanoTemplate {
    /// The template of `Volcano::new(vent_radius, seed)`; the radius is checked when the
    /// scene spawns.
    pub fn new(vent_radius: f32, seed: u64) -> Self {
        Self { vent_radius, seed }
    }
}

impl Template for VolcanoTemplate {
    type Output = Volcano;

    fn build_template(&self, _context: &mut TemplateContext) -> Result<Volcano, BevyError> {
        Volcano::new(self.vent_radius, self.seed)
            .map_err(|e| BevyError::from(format!("volcano not built: {e}")))
    }

    fn clone_template(&self) -> Self {
        Self { vent_radius: self.vent_radius, seed: self.seed }
    }
}

// `Volcano` is `Default + Clone`, which would make it its own template (Bevy's blanket
// `FromTemplate` for `Default + Clone + Unpin` types). This impl, whose bound never holds, takes
// `Unpin` away from it so that its template is the validating `VolcanoTemplate` instead: the
// same opt-out Bevy's `FromTemplate` derive and asset `Handle`s use.
impl Unpin for Volcano where for<'a> [()]: SpecializeFromTemplate {}

impl FromTemplate for Volcano {
    type Template = VolcanoTemplate;
}

/// A volcano as written in RON presets and scene files.
///
/// ```ron
/// (vent: (0.0, 0.0), vent_radius: 100.0, seed: 7)
/// ```
#[derive(Debug, Clone, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolcanoSpec {
    /// Vent position in the horizontal plane, world (x, z) in metres.
    pub vent: (f32, f32),
    /// Vent radius (m).
    pub vent_radius: f32,
    /// RNG seed.
    #[serde(default)]
    pub seed: u64,
}

impl Default for VolcanoSpec {
    fn default() -> Self {
        Self { vent: (0.0, 0.0), vent_radius: 100.0, seed: 0 }
    }
}

impl VolcanoSpec {
    /// Parses and validates a RON text.
    pub fn from_ron(text: &str) -> Result<Self, ConfigError> {
        let spec: Self = ron::from_str(text)?;
        spec.validate()?;
        Ok(spec)
    }
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("vent.x", self.vent.0 as f64, -1e7, 1e7)?;
        in_range("vent.z", self.vent.1 as f64, -1e7, 1e7)?;
        Volcano::new(self.vent_radius, self.seed)?;
        Ok(())
    }
    /// The component and the transform placing its vent (y is snapped later).
    pub fn build(&self) -> Result<(Volcano, Transform), ConfigError> {
        self.validate()?;
        Ok((Volcano::new(self.vent_radius, self.seed)?, Transform::from_xyz(self.vent.0, 0.0, self.vent.1)))
    }
}

/// World position of a volcano's vent on the terrain (written by the core plugin).
#[derive(Component, Debug, Clone, Copy, PartialEq, Default, Reflect)]
#[reflect(Component)]
pub struct VentPosition(pub Vec3);

/// The terrain a volcano stands on (the first, in query order, whose footprint holds its vent;
/// kept by the core plugin). Its deposits go to that terrain.
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq, Reflect)]
#[reflect(Component, Debug, PartialEq)]
#[relationship(relationship_target = TerrainVolcanoes)]
pub struct OnTerrain(#[entities] pub Entity);

/// The volcanoes standing on this terrain (the other side of [`OnTerrain`]).
#[derive(Component, Debug, Default, PartialEq, Eq, Reflect)]
#[reflect(Component, Debug, Default)]
#[relationship_target(relationship = OnTerrain)]
pub struct TerrainVolcanoes(Vec<Entity>);

impl TerrainVolcanoes {
    /// The volcanoes, in the order they joined.
    pub fn volcanoes(&self) -> &[Entity] {
        &self.0
    }
}

type VolcanoQueryData<'a> = (
    Entity,
    Ref<'a, Volcano>,
    &'a mut Transform,
    Option<&'a VentPosition>,
    Option<&'a VolcanoRng>,
    Option<&'a OnTerrain>,
);

/// Snaps vents to the terrain under them, links each volcano to that terrain ([`OnTerrain`]),
/// creates the volcano's RNG and keeps it in step with the seed.
pub(crate) fn snap_vents(
    mut commands: Commands,
    terrains: Query<(Entity, Ref<Terrain>)>,
    mut volcanoes: Query<VolcanoQueryData>,
) {
    let terrain_changed = terrains.iter().any(|(_, t)| t.is_changed());
    for (entity, volcano, mut transform, vent, rng, on) in &mut volcanoes {
        if rng.is_none_or(|r| r.seed() != volcano.seed()) {
            commands.entity(entity).insert(VolcanoRng::new(volcano.seed()));
        }
        if !(terrain_changed || volcano.is_changed() || transform.is_changed() || vent.is_none()) {
            continue;
        }
        // An edit that left the volcano invalid (through reflection, an inspector) keeps its
        // last vent until it is fixed; the eruption goes on from there.
        let p = transform.translation;
        if let Err(e) = volcano.validate() {
            bevy::log::warn!("volcano {entity}: {e}; its vent stays where it was until the value is fixed");
            continue;
        }
        if !p.is_finite() {
            bevy::log::warn!(
                "volcano {entity}: its translation {p} is not finite; its vent stays where it was"
            );
            continue;
        }
        let under = terrains.iter().find(|(_, t)| t.contains(p.x, p.z));
        match (under.map(|(e, _)| e), on.map(|o| o.0)) {
            (Some(t), Some(o)) if t == o => {}
            (Some(t), _) => {
                commands.entity(entity).insert(OnTerrain(t));
            }
            (None, Some(_)) => {
                commands.entity(entity).remove::<OnTerrain>();
            }
            (None, None) => {}
        }
        let ground = under.map(|(_, t)| t.height_at(p.x, p.z));
        let y = ground.unwrap_or(p.y);
        if transform.translation.y != y {
            transform.translation.y = y;
        }
        let vent_pos = Vec3::new(p.x, y, p.z);
        if vent.is_none_or(|v| v.0 != vent_pos) {
            commands.entity(entity).insert(VentPosition(vent_pos));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_radius_is_a_clear_error() {
        for r in [f32::NAN, -3.0, 0.0, f32::INFINITY, 5_000.0] {
            let e = Volcano::new(r, 1).unwrap_err();
            assert!(e.to_string().contains("vent_radius"), "{e}");
        }
        assert_eq!(Volcano::new(42.0, 3).unwrap().vent_radius(), 42.0);
    }

    #[test]
    fn the_template_builds_a_valid_volcano_or_names_the_error() {
        use bevy::ecs::world::World;
        let mut world = World::new();
        let mut entity = world.spawn_empty();
        let mut refs = bevy::ecs::template::SceneEntityReferences::default();
        let mut context = TemplateContext::new(&mut entity, &mut refs);
        let v = VolcanoTemplate::new(80.0, 9).clone_template().build_template(&mut context).unwrap();
        assert_eq!(v, Volcano::new(80.0, 9).unwrap());
        let v = VolcanoTemplate::default().build_template(&mut context).unwrap();
        assert_eq!(v, Volcano::default());
        for r in [f32::NAN, -3.0, 5_000.0] {
            let e = VolcanoTemplate::new(r, 1).build_template(&mut context).unwrap_err();
            assert!(e.to_string().contains("vent_radius"), "{e}");
        }
    }

    #[test]
    fn ron_spec_round_trip_and_errors() {
        let s = VolcanoSpec::from_ron("(vent: (10.0, -5.0), vent_radius: 80.0, seed: 9)").unwrap();
        assert_eq!(s.vent, (10.0, -5.0));
        let (v, t) = s.build().unwrap();
        assert_eq!((v.vent_radius(), v.seed(), t.translation.x, t.translation.z), (80.0, 9, 10.0, -5.0));
        // Malformed RON: syntax error with a position.
        let e = VolcanoSpec::from_ron("(vent: (1.0, 2.0), vent_radius: )").unwrap_err();
        assert!(matches!(e, ConfigError::Ron(_)) && e.to_string().contains("malformed RON"), "{e}");
        // Unknown field.
        let e = VolcanoSpec::from_ron("(vent: (0.0, 0.0), vent_radius: 5.0, radius: 3.0)").unwrap_err();
        assert!(e.to_string().contains("radius"), "{e}");
        // Well-formed but invalid value.
        let e = VolcanoSpec::from_ron("(vent: (0.0, 0.0), vent_radius: -5.0)").unwrap_err();
        assert!(e.to_string().contains("vent_radius"), "{e}");
        let e = VolcanoSpec::from_ron("(vent: (0.0, 0.0), vent_radius: NaN)").unwrap_err();
        assert!(e.to_string().contains("vent_radius"), "{e}");
    }
}
