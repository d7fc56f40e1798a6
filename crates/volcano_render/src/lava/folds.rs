//! Fold particles as ropes: a pool of capsule segments sharing one mesh and one material (Bevy
//! batches them into instanced draws), one per particle of every [`LavaState`], the rest
//! hidden. Each segment is [`ROPE_WIDTH`] × ℓ thick and [`ROPE_LENGTH`] × L long, so the
//! segments of a chain overlap into one rope, and stands a little proud of the surface
//! ([`ROPE_RISE`] × ℓ) so the rope reads as a ridge that catches the light and casts a shadow.

use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use volcano_core::Boundary;
use volcano_lava::view::FoldParticle;
use volcano_lava::{FlowField, LavaField, LavaState};

use super::surface::LIFT;
use super::{LavaRenderMode, LavaRenderSettings};

/// Rope diameter over the fold particle's diameter ℓ.
pub const ROPE_WIDTH: f32 = 1.3;
/// Rope segment length over the particle length L (> 1: neighbours overlap).
pub const ROPE_LENGTH: f32 = 1.3;
/// Height of the rope's axis above the particle's, over ℓ.
pub const ROPE_RISE: f32 = 0.1;

/// Marks a pooled fold-particle rope segment.
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct FoldInstance;

/// Shared mesh and material of the fold ropes.
#[derive(Resource)]
pub(super) struct FoldAssets {
    mesh: Handle<Mesh>,
    material: Handle<StandardMaterial>,
}

impl FromWorld for FoldAssets {
    fn from_world(world: &mut World) -> Self {
        // Capsule along y, 1 wide and 2 long overall (radius 0.5, caps included), scaled per
        // particle by (width, length / 2, width).
        let mesh = Capsule3d::new(0.5, 1.0).mesh().longitudes(12).latitudes(6).build();
        let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
        let material =
            world.resource_mut::<Assets<StandardMaterial>>().add(fold_material(LavaRenderMode::Lit));
        Self { mesh, material }
    }
}

/// Glassy dark crust in the lit view (a little lighter and shinier than the crust between
/// the ropes, as stretched pahoehoe skin is), plain white in the debug views (as the thesis
/// draws them).
fn fold_material(mode: LavaRenderMode) -> StandardMaterial {
    match mode {
        LavaRenderMode::Lit => StandardMaterial {
            base_color: Color::srgb(0.20, 0.18, 0.17),
            perceptual_roughness: 0.35,
            reflectance: 0.5,
            ..default()
        },
        _ => StandardMaterial { base_color: Color::WHITE, unlit: true, ..default() },
    }
}

/// Transform of the rope segment of particle `p` (length `length`) on `flow`: centred on its
/// position at the lava surface raised by its vertical offset (−ℓ/2 when created, 0 once
/// risen), its rolling height (eq 5.5) and `ROPE_RISE` × ℓ, axis along its tangent, rolled
/// by its roll angle, `ROPE_WIDTH` × ℓ thick and `ROPE_LENGTH` × `length` long.
pub fn fold_transform(flow: &FlowField, p: &FoldParticle, length: f32) -> Transform {
    let xz = Vec2::new(p.pos.x as f32, p.pos.y as f32);
    let surface = flow.ground().sample(xz, Boundary::Clamp) + flow.thickness().sample(xz, Boundary::Clamp);
    let d = (p.thickness as f32).max(0.01);
    let y = surface as f32 + LIFT + (p.offset + p.roll_height) as f32 + ROPE_RISE * d;
    let axis = Vec3::new(p.tangent.x as f32, 0.0, p.tangent.y as f32).normalize_or(Vec3::X);
    let rotation = Quat::from_rotation_arc(Vec3::Y, axis) * Quat::from_rotation_y(p.roll_angle as f32);
    let (w, l) = (ROPE_WIDTH * d, ROPE_LENGTH * length);
    Transform { translation: Vec3::new(xz.x, y, xz.y), rotation, scale: Vec3::new(w, 0.5 * l, w) }
}

/// Moves the pool onto the particles (at the surface rebuild cadence), grows it when needed and
/// hides what is left over.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub(super) fn update_fold_instances(
    mut commands: Commands,
    mode: Res<LavaRenderMode>,
    settings: Res<LavaRenderSettings>,
    fields: Query<(&LavaField, Ref<LavaState>)>,
    mut pool: Query<(Entity, &mut Transform, &mut Visibility, Has<NotShadowCaster>), With<FoldInstance>>,
    assets: Option<Res<FoldAssets>>,
    mut materials: Option<ResMut<Assets<StandardMaterial>>>,
    mut cadence: Local<(u32, bool)>,
) {
    let (frames, dirty) = &mut *cadence;
    let Some(assets) = assets else { return };
    if mode.is_changed()
        && let Some(mut m) = materials.as_mut().and_then(|m| m.get_mut(&assets.material))
    {
        *m = fold_material(*mode);
    }
    *frames = frames.saturating_add(1);
    *dirty |= settings.is_changed() || fields.iter().any(|(_, s)| s.is_changed());
    if !*dirty || *frames < settings.rebuild_every_frames.max(1) {
        return;
    }
    *frames = 0;
    *dirty = false;
    let mut transforms = Vec::new();
    if settings.show_folds {
        for (field, state) in &fields {
            let length = field.folds.particle_length as f32;
            transforms.extend(state.folds.particles.iter().map(|p| fold_transform(&state.flow, p, length)));
        }
    }
    let mut next = transforms.iter();
    let shadows = settings.fold_shadows;
    for (entity, mut transform, mut visibility, no_shadow) in &mut pool {
        if no_shadow == shadows {
            if shadows {
                commands.entity(entity).remove::<NotShadowCaster>();
            } else {
                commands.entity(entity).insert(NotShadowCaster);
            }
        }
        match next.next() {
            Some(t) => {
                *transform = *t;
                if *visibility != Visibility::Inherited {
                    *visibility = Visibility::Inherited;
                }
            }
            None if *visibility != Visibility::Hidden => *visibility = Visibility::Hidden,
            None => {}
        }
    }
    let extra: Vec<_> = next
        .map(|t| (FoldInstance, Mesh3d(assets.mesh.clone()), MeshMaterial3d(assets.material.clone()), *t))
        .collect();
    if !extra.is_empty() {
        if shadows {
            commands.spawn_batch(extra);
        } else {
            // Thousands of small ropes: shadows draw each once more per cascade.
            commands.spawn_batch(extra.into_iter().map(|e| (e, NotShadowCaster)));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::DVec2;
    use volcano_core::Grid2;
    use volcano_lava::Edges;

    #[test]
    fn rope_lies_along_the_tangent_at_its_offset() {
        let g = Grid2::new(8, 8, 0.5, Vec2::ZERO, 10.0).unwrap();
        let mut flow = FlowField::new(g, Edges::default(), 300.0).unwrap();
        flow.place_volume(Vec2::new(2.0, 2.0), 3.0, 8.0 * 8.0 * 0.25 * 0.5, 1400.0).unwrap();
        let h = flow.thickness().get(4, 4) as f32;
        let p = FoldParticle {
            pos: DVec2::new(2.0, 2.0),
            spring_vel: DVec2::ZERO,
            vel: DVec2::ZERO,
            tangent: DVec2::new(0.0, 1.0),
            thickness: 0.3,
            age: 0.0,
            offset: -0.15,
            roll_height: 0.0,
            roll_angle: 0.0,
            fold: 0,
            blocked_by: None,
        };
        let t = fold_transform(&flow, &p, 0.5);
        assert_eq!((t.translation.x, t.translation.z), (2.0, 2.0));
        let rise = ROPE_RISE * 0.3;
        assert!((t.translation.y - (10.0 + h + LIFT - 0.15 + rise)).abs() < 1e-4, "{t:?}");
        // The rope's axis (local y) points along the tangent (world +z).
        let axis = t.rotation * Vec3::Y;
        assert!((axis - Vec3::Z).length() < 1e-5, "{axis}");
        let (w, l) = (ROPE_WIDTH * 0.3, ROPE_LENGTH * 0.5);
        assert!((t.scale - Vec3::new(w, 0.5 * l, w)).length() < 1e-6, "{:?}", t.scale);
    }
}
