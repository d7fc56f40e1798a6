//! Fold particles as cylinders: a pool of entities sharing one mesh and one material (Bevy
//! batches them into instanced draws), one per particle of every [`LavaState`], the rest
//! hidden.

use bevy::light::NotShadowCaster;
use bevy::prelude::*;
use volcano_core::Boundary;
use volcano_lava::view::FoldParticle;
use volcano_lava::{FlowField, LavaField, LavaState};

use super::surface::LIFT;
use super::{LavaRenderMode, LavaRenderSettings};

/// Marks a pooled fold-particle cylinder.
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct FoldInstance;

/// Shared mesh and material of the fold cylinders.
#[derive(Resource)]
pub(super) struct FoldAssets {
    mesh: Handle<Mesh>,
    material: Handle<StandardMaterial>,
}

impl FromWorld for FoldAssets {
    fn from_world(world: &mut World) -> Self {
        // Unit cylinder along y (radius 0.5, height 1), scaled per particle to (ℓ, L, ℓ).
        let mesh = Cylinder::new(0.5, 1.0).mesh().resolution(8).build();
        let mesh = world.resource_mut::<Assets<Mesh>>().add(mesh);
        let material =
            world.resource_mut::<Assets<StandardMaterial>>().add(fold_material(LavaRenderMode::Lit));
        Self { mesh, material }
    }
}

/// Glassy dark crust in the lit view, plain white in the debug views (as the thesis draws them).
fn fold_material(mode: LavaRenderMode) -> StandardMaterial {
    match mode {
        LavaRenderMode::Lit => StandardMaterial {
            base_color: Color::srgb(0.10, 0.09, 0.085),
            perceptual_roughness: 0.3,
            reflectance: 0.5,
            ..default()
        },
        _ => StandardMaterial { base_color: Color::WHITE, unlit: true, ..default() },
    }
}

/// Transform of the cylinder of particle `p` (length `length`) on `flow`: centred on its
/// position at the lava surface raised by its vertical offset (−ℓ/2 when created, 0 once risen)
/// and rolling height (eq 5.5), axis along its tangent, rolled by its roll angle.
pub fn fold_transform(flow: &FlowField, p: &FoldParticle, length: f32) -> Transform {
    let xz = Vec2::new(p.pos.x as f32, p.pos.y as f32);
    let surface = flow.ground().sample(xz, Boundary::Clamp) + flow.thickness().sample(xz, Boundary::Clamp);
    let y = surface as f32 + LIFT + (p.offset + p.roll_height) as f32;
    let axis = Vec3::new(p.tangent.x as f32, 0.0, p.tangent.y as f32).normalize_or(Vec3::X);
    let rotation = Quat::from_rotation_arc(Vec3::Y, axis) * Quat::from_rotation_y(p.roll_angle as f32);
    let d = (p.thickness as f32).max(0.01);
    Transform { translation: Vec3::new(xz.x, y, xz.y), rotation, scale: Vec3::new(d, length, d) }
}

/// Moves the pool onto the particles (at the surface rebuild cadence), grows it when needed and
/// hides what is left over.
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
pub(super) fn update_fold_instances(
    mut commands: Commands,
    mode: Res<LavaRenderMode>,
    settings: Res<LavaRenderSettings>,
    fields: Query<(&LavaField, Ref<LavaState>)>,
    mut pool: Query<(&mut Transform, &mut Visibility), With<FoldInstance>>,
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
    for (mut transform, mut visibility) in &mut pool {
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
        .map(|t| {
            // Thousands of small cylinders: casting shadows would draw each once per cascade.
            (
                FoldInstance,
                Mesh3d(assets.mesh.clone()),
                MeshMaterial3d(assets.material.clone()),
                *t,
                NotShadowCaster,
            )
        })
        .collect();
    if !extra.is_empty() {
        commands.spawn_batch(extra);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::DVec2;
    use volcano_core::Grid2;
    use volcano_lava::Edges;

    #[test]
    fn cylinder_lies_along_the_tangent_at_its_offset() {
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
        assert!((t.translation.y - (10.0 + h + LIFT - 0.15)).abs() < 1e-4, "{t:?}");
        // The cylinder's axis (local y) points along the tangent (world +z).
        let axis = t.rotation * Vec3::Y;
        assert!((axis - Vec3::Z).length() < 1e-5, "{axis}");
        assert_eq!(t.scale, Vec3::new(0.3, 0.5, 0.3));
    }
}
