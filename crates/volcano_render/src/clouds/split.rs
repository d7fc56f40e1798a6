//! Every cloud box drawn twice, around the ash: the box as spawned (by the cloud rebuild, the
//! ash fall, or a game) marches each view ray from the ash onward and is drawn before the ash;
//! a child box with a twin material ([`CloudMaterial::IN_FRONT_OF_ASH`]) marches from the eye
//! up to the ash and is drawn after it. Both read [`AshDepthImage`]. The twin follows its
//! original: any edit of the original material is copied to it in the same frame.

use bevy::light::{NotShadowCaster, NotShadowReceiver};
use bevy::prelude::*;

use super::CloudMaterial;
use crate::plume::AshDepthImage;

/// On a cloud box: its twin drawn in front of the ash.
#[derive(Component, Debug, Clone, Copy, Reflect)]
#[reflect(Component, Debug)]
pub struct CloudFrontDraw(pub Entity);

/// On the twin box (a child of the original, same mesh, identity transform).
#[derive(Component, Debug, Clone, Copy, Reflect)]
#[reflect(Component, Debug)]
pub struct CloudFrontOf(pub Entity);

/// `original` with the viewer's ash depth, and its twin for the part in front of the ash.
pub fn split_materials(
    original: &CloudMaterial,
    ash_depth: &Handle<Image>,
) -> (CloudMaterial, CloudMaterial) {
    let mut behind = original.clone();
    behind.ash_depth = Some(ash_depth.clone());
    behind.uniform.segment = CloudMaterial::BEHIND_ASH;
    let mut front = behind.clone();
    front.uniform.segment = CloudMaterial::IN_FRONT_OF_ASH;
    (behind, front)
}

/// Gives every cloud box the ash depth and a twin in front of the ash, and keeps the twins'
/// materials equal to their originals' (but for the segment); tells the ash-depth pass whether
/// anything reads it. Nothing without an [`AshDepthImage`] (no ash renderer).
#[allow(clippy::type_complexity)]
pub(crate) fn split_cloud_draws(
    mut commands: Commands,
    ash_depth: Option<ResMut<AshDepthImage>>,
    originals: Query<
        (Entity, &MeshMaterial3d<CloudMaterial>, &Mesh3d, Option<&CloudFrontDraw>),
        Without<CloudFrontOf>,
    >,
    twins: Query<&MeshMaterial3d<CloudMaterial>, With<CloudFrontOf>>,
    mut materials: ResMut<Assets<CloudMaterial>>,
    mut image_events: MessageReader<AssetEvent<Image>>,
) {
    let Some(mut ash_depth) = ash_depth else { return };
    let in_use = !originals.is_empty();
    if ash_depth.in_use != in_use {
        ash_depth.in_use = in_use;
    }
    // A resized image is a new texture, and a material's bind group keeps the one it was
    // built with: touch every cloud material so its bind group is built again (otherwise,
    // after a window resize, the clouds read a stale image and fall back to the single-pass
    // order).
    let resized = image_events.read().fold(false, |any, e| any | e.is_modified(&ash_depth.image));
    if resized {
        let ids: Vec<_> = originals.iter().map(|o| o.1.id()).chain(twins.iter().map(|t| t.id())).collect();
        for id in ids {
            // `into_inner` marks the asset modified (a bare `get_mut` does not).
            if let Some(m) = materials.get_mut(id) {
                m.into_inner();
            }
        }
    }
    for (entity, material, mesh, front) in &originals {
        let Some(original) = materials.get(&material.0) else { continue };
        let (behind, wanted) = split_materials(original, &ash_depth.image);
        if *original != behind
            && let Some(mut m) = materials.get_mut(&material.0)
        {
            *m = behind;
        }
        match front.and_then(|f| twins.get(f.0).ok()) {
            Some(twin) => {
                if materials.get(&twin.0) != Some(&wanted)
                    && let Some(mut m) = materials.get_mut(&twin.0)
                {
                    *m = wanted;
                }
            }
            None => {
                let twin = commands
                    .spawn((
                        Name::new("Clouds in front of the ash"),
                        Mesh3d(mesh.0.clone()),
                        MeshMaterial3d(materials.add(wanted)),
                        Transform::default(),
                        Visibility::Inherited,
                        NotShadowCaster,
                        NotShadowReceiver,
                        CloudFrontOf(entity),
                        ChildOf(entity),
                    ))
                    .id();
                commands.entity(entity).insert(CloudFrontDraw(twin));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clouds::{CloudRenderSettings, CloudUniform};

    /// After the ash-depth image is resized (a window resize), every cloud material is marked
    /// changed, so that the renderer builds its bind group again with the new texture (else
    /// the materials keep the first texture); without the touch, no `Modified` event follows
    /// the resize and this fails.
    #[test]
    fn resizing_the_ash_depth_image_rebuilds_the_cloud_materials() {
        use bevy::asset::AssetPlugin;
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<Image>()
            .init_asset::<Mesh>()
            .init_asset::<CloudMaterial>()
            .add_systems(PostUpdate, split_cloud_draws);
        let world = app.world_mut();
        let image = world.resource_mut::<Assets<Image>>().add(crate::plume::ash_depth_image(UVec2::ONE));
        world.insert_resource(AshDepthImage { image: image.clone(), in_use: false });
        let uniform = CloudUniform::new(Vec3::ZERO, Vec3::ONE, &CloudRenderSettings::default());
        let material =
            world.resource_mut::<Assets<CloudMaterial>>().add(CloudMaterial::new(uniform, Handle::default()));
        let mesh = world.resource_mut::<Assets<Mesh>>().add(Cuboid::default());
        world.spawn((Mesh3d(mesh), MeshMaterial3d(material.clone())));
        // The split settles (the twin spawned, the ash depth set); then only new events count.
        for _ in 0..3 {
            app.update();
        }
        let mut cursor = app.world().resource::<Messages<AssetEvent<CloudMaterial>>>().get_cursor_current();
        let mut modified = |app: &mut App| {
            let events = app.world().resource::<Messages<AssetEvent<CloudMaterial>>>();
            cursor.read(events).filter(|e| e.is_modified(&material)).count()
        };
        app.update();
        app.update();
        assert_eq!(modified(&mut app), 0, "the original is touched while nothing changes");
        let extent =
            bevy::render::render_resource::Extent3d { width: 640, height: 360, depth_or_array_layers: 1 };
        if let Some(mut image) = app.world_mut().resource_mut::<Assets<Image>>().get_mut(&image) {
            image.resize(extent);
        }
        let mut seen = 0;
        for _ in 0..3 {
            app.update();
            seen += modified(&mut app);
        }
        assert!(seen > 0, "no cloud material rebuilt after the ash-depth image was resized");
        assert!(app.world().resource::<AshDepthImage>().in_use);
    }

    #[test]
    fn the_twin_differs_only_in_its_segment_and_sorts_after_the_original() {
        use bevy::pbr::Material;
        let uniform = CloudUniform::new(Vec3::ZERO, Vec3::ONE, &CloudRenderSettings::default());
        let original = CloudMaterial::new(uniform, Handle::default());
        let depth = Handle::<Image>::default();
        let (behind, front) = split_materials(&original, &depth);
        assert_eq!(behind.ash_depth, Some(depth));
        assert_eq!(behind.uniform.segment, CloudMaterial::BEHIND_ASH);
        assert_eq!(front.uniform.segment, CloudMaterial::IN_FRONT_OF_ASH);
        let mut same = front.clone();
        same.uniform.segment = CloudMaterial::BEHIND_ASH;
        assert_eq!(same, behind);
        assert!(behind.depth_bias() < -1e8 && front.depth_bias() > 1e8);
    }
}
