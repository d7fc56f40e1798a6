//! A terrain goes where its entity's `Transform` puts it: the grids move by the translation's
//! x and z. Its heights are altitudes above sea level (the air, the sea and the column read
//! them as such), so the translation's y, a rotation or a scale cannot apply: each is warned
//! about and ignored, and the renderer draws the terrain where the simulation has it.

use bevy::prelude::*;

use super::Terrain;

/// Moves each new terrain, and each whose `Transform` changed, to the translation's x and z
/// ([`Terrain::set_placement`]). Runs before the vents snap, in `Update` and at the start of
/// each base tick; only the `Update` instance (`WARN`) logs, so a change is reported once.
pub(crate) fn place_terrains<const WARN: bool>(mut terrains: Query<(Entity, &mut Terrain, Ref<Transform>)>) {
    for (entity, mut terrain, transform) in &mut terrains {
        if !(transform.is_changed() || terrain.is_added()) {
            continue;
        }
        let offset = transform.translation.xz();
        if terrain.placement() != offset
            && let Err(e) = terrain.set_placement(offset)
            && WARN
        {
            warn!("terrain {entity}: its Transform cannot place it: {e}");
        }
        let ignored = ignored_parts(&transform);
        if WARN && !ignored.is_empty() {
            warn!(
                "terrain {entity}: a heightfield's heights are altitudes, so its Transform's {} \
                 is ignored (only the x and z translation place it)",
                ignored.join(", ")
            );
        }
    }
}

/// The parts of `transform` a heightfield-bound entity (a terrain, a lava field) cannot take:
/// its translation's y, a rotation, a scale.
pub fn ignored_parts(transform: &Transform) -> Vec<&'static str> {
    let mut parts = Vec::new();
    if transform.translation.y != 0.0 {
        parts.push("y translation");
    }
    if !transform.rotation.is_near_identity() {
        parts.push("rotation");
    }
    if transform.scale != Vec3::ONE {
        parts.push("scale");
    }
    parts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::StratovolcanoParams;

    fn app_with(terrain: Terrain, transform: Transform) -> (App, Entity) {
        let mut app = App::new();
        app.add_systems(Update, place_terrains::<true>);
        let e = app.world_mut().spawn((terrain, transform)).id();
        app.update();
        (app, e)
    }

    #[test]
    fn the_translation_moves_the_terrain_and_its_heights_with_it() {
        let built =
            StratovolcanoParams { resolution: 64, cell: 250.0, ..Default::default() }.generate().unwrap();
        let peak = built.height_at(0.0, 0.0);
        let (mut app, e) = app_with(built.clone(), Transform::from_xyz(3_000.0, 0.0, -20_000.0));
        let t = app.world().get::<Terrain>(e).unwrap();
        assert_eq!(t.placement(), Vec2::new(3_000.0, -20_000.0));
        assert_eq!(t.heights().origin(), built.heights().origin() + Vec2::new(3_000.0, -20_000.0));
        assert_eq!(t.height_at(3_000.0, -20_000.0), peak, "the summit moved with the entity");
        assert!(t.contains(3_000.0, -20_000.0) && !t.contains(0.0, 0.0));
        // Moved back: exactly where it was built (no accumulated rounding).
        app.world_mut().get_mut::<Transform>(e).unwrap().translation = Vec3::ZERO;
        app.update();
        let t = app.world().get::<Terrain>(e).unwrap();
        assert_eq!(t.heights().origin(), built.heights().origin());
        assert_eq!(t.height_at(0.0, 0.0), peak);
    }

    #[test]
    fn an_added_layer_moves_with_the_terrain() {
        let mut built = Terrain::flat(9, 10.0, 100.0).unwrap();
        let region = crate::NodeRegion { i0: 4, j0: 4, ni: 1, nj: 1 };
        built.add_thickness(region, &[2.0]).unwrap();
        let (app, e) = app_with(built, Transform::from_xyz(-500.0, 0.0, 700.0));
        let t = app.world().get::<Terrain>(e).unwrap();
        assert_eq!(t.added().unwrap().origin(), t.heights().origin());
        assert_eq!(t.base_heights().origin(), t.heights().origin());
        assert_eq!(t.height_at(-500.0, 700.0), 102.0, "the added node is the centre one, moved");
    }

    #[test]
    fn what_cannot_apply_is_named_and_a_bad_offset_is_an_error() {
        let none = ignored_parts(&Transform::from_xyz(5.0, 0.0, 5.0));
        assert!(none.is_empty());
        let all = ignored_parts(
            &Transform::from_xyz(0.0, 10.0, 0.0)
                .with_rotation(Quat::from_rotation_y(0.5))
                .with_scale(Vec3::splat(2.0)),
        );
        assert_eq!(all, ["y translation", "rotation", "scale"]);
        let mut t = Terrain::flat(4, 1.0, 0.0).unwrap();
        let before = t.clone();
        assert!(t.set_placement(Vec2::new(f32::NAN, 0.0)).is_err());
        assert!(t.set_placement(Vec2::new(0.0, f32::INFINITY)).is_err());
        assert_eq!(t, before, "an error changes nothing");
    }
}
