//! The ash-depth pass: where the ash begins along each view ray, so that the clouds and the ash
//! fall in front of the column are drawn over it and those behind it under it.
//!
//! The ash is one transparent draw that writes no depth (`pipeline`), and the cloud pass
//! (`crate::clouds`) is a ray march over a box around the whole atmosphere: sorted as whole
//! draws, one of them always lies over the other. Here the same instances are drawn once more,
//! between Bevy's opaque and transparent passes, for the [`VolcanoViewer`] camera only, into
//! [`AshDepthImage`] (`Rg16Float`, the camera's size): each pixel keeps, by min blending, the
//! distance from the eye (km) of the nearest ash fragment at least `DEPTH_ALPHA` (0.03,
//! `ash.wgsl`) opaque, and `g = 0` where there is one (cleared to `(65504, 1)`: no ash). Each
//! cloud box is drawn twice (`crate::clouds::split`): before the ash, marching from the ash
//! onward, and after it, marching from the eye up to the ash. What this cannot order: a cloud
//! behind a faint veil of ash but in front of dense ash is drawn under both (one depth per
//! pixel, where the ash begins).
//!
//! A texture that was never written (no viewer camera) reads `(0, 0)` (ash at the eye: the
//! whole ray is marched before the ash, the single-pass order), and the fallback image that an
//! unset material binds reads `(1, 1)` (no ash). Another camera reads the viewer's image: its
//! two parts still cover each ray once, so its clouds are whole, ordered by the viewer's ash.
//! A resized image (a window resize) is a new texture: the split touches every cloud material
//! so its bind group picks it up. Cost: one more instanced draw of every ash instance (vertex
//! expansion and the coverage of the colour pass, no lighting) into a 4-byte-per-pixel target.

use bevy::camera::{MainPassResolutionOverride, Viewport};
use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::schedule::{Core3d, Core3dSystems};
use bevy::ecs::entity::EntityHash;
use bevy::math::FloatOrd;
use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{
    MeshPipelineKey, MeshPipelineViewLayoutKey, RenderMeshInstances, SetMeshViewBindGroup,
    SetMeshViewBindingArrayBindGroup, SetMeshViewEmptyBindGroup, ViewKeyCache,
};
use bevy::platform::collections::HashSet;
use bevy::prelude::*;
use bevy::render::{
    Extract, ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems,
    camera::ExtractedCamera,
    extract_resource::{ExtractResource, ExtractResourcePlugin},
    mesh::RenderMesh,
    render_asset::RenderAssets,
    render_phase::{
        AddRenderCommand, CachedRenderPipelinePhaseItem, DrawFunctionId, DrawFunctions, PhaseItem,
        PhaseItemExtraIndex, SetItemPipeline, SortedPhaseItem, ViewSortedRenderPhases,
    },
    render_resource::*,
    renderer::{RenderContext, ViewQuery},
    sync_world::MainEntity,
    texture::GpuImage,
    view::{ExtractedView, RetainedViewEntity},
};
use indexmap::IndexMap;
use std::ops::Range;

use super::pipeline::{AshCloud, AshPipeline, DrawAshInstanced, init_pipeline, specialized_ash_draws};
use crate::camera::VolcanoViewer;

/// Format of [`AshDepthImage`]: r the distance (km), g 0 where there is ash. Half floats are
/// blendable on every adapter; 2⁻¹¹ relative precision is ±10 m at 20 km.
pub const ASH_DEPTH_FORMAT: TextureFormat = TextureFormat::Rg16Float;

/// The value a pixel without ash keeps (the target's clear colour).
const NO_ASH: LinearRgba = LinearRgba { red: 65504.0, green: 1.0, blue: 0.0, alpha: 0.0 };

/// The image the ash-depth pass writes for the first [`VolcanoViewer`] camera, sized to its
/// render target, and that every cloud material reads.
#[derive(Resource, Debug, Clone, ExtractResource, Reflect)]
#[reflect(Resource, Debug)]
pub struct AshDepthImage {
    /// The image.
    pub image: Handle<Image>,
    /// Whether anything reads it (set by the cloud split each frame): without a reader the
    /// ash is not drawn into it, only the clear is paid.
    pub in_use: bool,
}

/// Adds the image, its sizing, and the pass.
pub(super) fn build(app: &mut App) {
    app.register_type::<AshDepthImage>()
        .add_systems(PreStartup, create_image)
        .add_systems(PostUpdate, size_to_viewer);
    if app.get_sub_app(RenderApp).is_none() {
        return;
    }
    app.add_plugins(ExtractResourcePlugin::<AshDepthImage>::default());
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else { return };
    render_app
        .init_resource::<DrawFunctions<AshDepth3d>>()
        .init_resource::<ViewSortedRenderPhases<AshDepth3d>>()
        .init_resource::<SpecializedMeshPipelines<AshDepthPipeline>>()
        .add_render_command::<AshDepth3d, DrawAshDepth>()
        .add_systems(RenderStartup, init_depth_pipeline.after(init_pipeline))
        .add_systems(ExtractSchedule, extract_phases)
        .add_systems(Render, queue_depth.in_set(RenderSystems::QueueMeshes))
        .add_systems(
            Core3d,
            ash_depth_pass
                .after(main_opaque_pass_3d)
                .before(main_transparent_pass_3d)
                .in_set(Core3dSystems::MainPass),
        );
}

/// Inserts [`AshDepthImage`] (1×1 until a viewer sizes it), when the app has images at all.
fn create_image(mut commands: Commands, images: Option<ResMut<Assets<Image>>>) {
    if let Some(mut images) = images {
        commands
            .insert_resource(AshDepthImage { image: images.add(ash_depth_image(UVec2::ONE)), in_use: false });
    }
}

/// An `ASH_DEPTH_FORMAT` image of `size` pixels that the pass can draw into and the cloud
/// material can read (no data: the GPU texture starts zeroed).
pub fn ash_depth_image(size: UVec2) -> Image {
    let mut image = Image::new_uninit(
        Extent3d { width: size.x.max(1), height: size.y.max(1), depth_or_array_layers: 1 },
        TextureDimension::D2,
        ASH_DEPTH_FORMAT,
        bevy::asset::RenderAssetUsages::RENDER_WORLD,
    );
    image.texture_descriptor.usage = TextureUsages::TEXTURE_BINDING | TextureUsages::RENDER_ATTACHMENT;
    image
}

/// Keeps the image the size of the viewer's render target.
fn size_to_viewer(
    viewers: Query<&Camera, With<VolcanoViewer>>,
    target: Option<Res<AshDepthImage>>,
    images: Option<ResMut<Assets<Image>>>,
) {
    let (Some(target), Some(mut images)) = (target, images) else { return };
    let Some(size) = viewers.iter().filter(|c| c.is_active).find_map(Camera::physical_target_size) else {
        return;
    };
    let extent = Extent3d { width: size.x.max(1), height: size.y.max(1), depth_or_array_layers: 1 };
    let current = images.get(&target.image).map(|i| i.texture_descriptor.size);
    if current != Some(extent)
        && let Some(mut image) = images.get_mut(&target.image)
    {
        image.resize(extent);
    }
}

/// The pass's phase item: the ash draw, for one view.
struct AshDepth3d {
    distance: FloatOrd,
    entity: (Entity, MainEntity),
    pipeline: CachedRenderPipelineId,
    draw_function: DrawFunctionId,
    batch_range: Range<u32>,
    extra_index: PhaseItemExtraIndex,
}

impl PhaseItem for AshDepth3d {
    fn entity(&self) -> Entity {
        self.entity.0
    }
    fn main_entity(&self) -> MainEntity {
        self.entity.1
    }
    fn draw_function(&self) -> DrawFunctionId {
        self.draw_function
    }
    fn batch_range(&self) -> &Range<u32> {
        &self.batch_range
    }
    fn batch_range_mut(&mut self) -> &mut Range<u32> {
        &mut self.batch_range
    }
    fn extra_index(&self) -> PhaseItemExtraIndex {
        self.extra_index.clone()
    }
    fn batch_range_and_extra_index_mut(&mut self) -> (&mut Range<u32>, &mut PhaseItemExtraIndex) {
        (&mut self.batch_range, &mut self.extra_index)
    }
}

impl SortedPhaseItem for AshDepth3d {
    type SortKey = FloatOrd;

    fn sort_key(&self) -> Self::SortKey {
        self.distance
    }
    fn sort(_: &mut IndexMap<(Entity, MainEntity), Self, EntityHash>) {
        // One item per view: nothing to order (min blending does not depend on order anyway).
    }
    fn recalculate_sort_keys(_: &mut IndexMap<(Entity, MainEntity), Self, EntityHash>, _: &ExtractedView) {}
    fn indexed(&self) -> bool {
        true
    }
}

impl CachedRenderPipelinePhaseItem for AshDepth3d {
    fn cached_pipeline(&self) -> CachedRenderPipelineId {
        self.pipeline
    }
}

/// The colour pass's pipeline with the `fragment_depth` entry point, one `ASH_DEPTH_FORMAT`
/// target blended with min, no depth attachment, one sample, and no mesh bind group (the ash
/// vertex stage reads only the view and the parents).
#[derive(Resource)]
struct AshDepthPipeline(AshPipeline);

/// Built from the colour pass's pipeline once that exists.
fn init_depth_pipeline(mut commands: Commands, ash: Res<AshPipeline>) {
    commands.insert_resource(AshDepthPipeline(ash.clone()));
}

impl SpecializedMeshPipeline for AshDepthPipeline {
    type Key = MeshPipelineKey;

    fn specialize(
        &self,
        key: Self::Key,
        layout: &MeshVertexBufferLayoutRef,
    ) -> Result<RenderPipelineDescriptor, SpecializedMeshPipelineError> {
        let mut descriptor = self.0.specialize(key, layout)?;
        descriptor.label = Some("volcano ash depth".into());
        let empty = self.0.mesh_pipeline.get_view_layout(MeshPipelineViewLayoutKey::from(key)).empty_layout;
        descriptor.set_layout(2, empty);
        let min = BlendComponent {
            src_factor: BlendFactor::One,
            dst_factor: BlendFactor::One,
            operation: BlendOperation::Min,
        };
        if let Some(fragment) = descriptor.fragment.as_mut() {
            fragment.entry_point = Some("fragment_depth".into());
            fragment.targets = vec![Some(ColorTargetState {
                format: ASH_DEPTH_FORMAT,
                blend: Some(BlendState { color: min, alpha: min }),
                write_mask: ColorWrites::ALL,
            })];
        }
        descriptor.depth_stencil = None;
        descriptor.multisample = MultisampleState::default();
        Ok(descriptor)
    }
}

type DrawAshDepth = (
    SetItemPipeline,
    SetMeshViewBindGroup<0>,
    SetMeshViewBindingArrayBindGroup<1>,
    SetMeshViewEmptyBindGroup<2>,
    DrawAshInstanced,
);

/// A phase for the first active [`VolcanoViewer`] 3D camera (the one [`AshDepthImage`] is
/// sized to).
type ViewerCameras<'w, 's> = Query<'w, 's, (Entity, &'static Camera), (With<Camera3d>, With<VolcanoViewer>)>;

fn extract_phases(
    mut phases: ResMut<ViewSortedRenderPhases<AshDepth3d>>,
    cameras: Extract<ViewerCameras>,
    mut live: Local<HashSet<RetainedViewEntity>>,
) {
    live.clear();
    if let Some((entity, _)) = cameras.iter().find(|(_, c)| c.is_active) {
        let view = RetainedViewEntity::new(entity.into(), None, 0);
        phases.prepare_for_new_frame(view);
        live.insert(view);
    }
    phases.retain(|view, _| live.contains(view));
}

#[allow(clippy::too_many_arguments)]
fn queue_depth(
    draw_functions: Res<DrawFunctions<AshDepth3d>>,
    pipeline: Res<AshDepthPipeline>,
    mut pipelines: ResMut<SpecializedMeshPipelines<AshDepthPipeline>>,
    cache: Res<PipelineCache>,
    meshes: Res<RenderAssets<RenderMesh>>,
    mesh_instances: Res<RenderMeshInstances>,
    clouds: Query<(Entity, &MainEntity), With<AshCloud>>,
    mut phases: ResMut<ViewSortedRenderPhases<AshDepth3d>>,
    views: Query<&ExtractedView>,
    view_keys: Res<ViewKeyCache>,
    target: Option<Res<AshDepthImage>>,
) {
    if !target.is_some_and(|t| t.in_use) {
        return;
    }
    let draw = draw_functions.read().id::<DrawAshDepth>();
    for view in &views {
        let Some(phase) = phases.get_mut(&view.retained_view_entity) else { continue };
        let Some(&view_key) = view_keys.get(&view.retained_view_entity) else { continue };
        let ready = specialized_ash_draws(
            view_key,
            &clouds,
            (&meshes, &mesh_instances),
            (&mut pipelines, &cache, &pipeline),
        );
        for (entity, main_entity, id) in ready {
            phase.add_transient(AshDepth3d {
                distance: FloatOrd(0.0),
                entity: (entity, main_entity),
                pipeline: id,
                draw_function: draw,
                batch_range: 0..1,
                extra_index: PhaseItemExtraIndex::None,
            });
        }
    }
}

/// Clears [`AshDepthImage`] and draws the ash into it (views with a phase only).
fn ash_depth_pass(
    world: &World,
    view: ViewQuery<(&ExtractedCamera, &ExtractedView, Option<&MainPassResolutionOverride>)>,
    phases: Res<ViewSortedRenderPhases<AshDepth3d>>,
    target: Option<Res<AshDepthImage>>,
    images: Res<RenderAssets<GpuImage>>,
    mut ctx: RenderContext,
) {
    let view_entity = view.entity();
    let (camera, extracted, resolution_override) = view.into_inner();
    let Some(phase) = phases.get(&extracted.retained_view_entity) else { return };
    let Some(image) = target.as_ref().and_then(|t| images.get(&t.image)) else { return };
    let attachment = RenderPassColorAttachment {
        view: &image.texture_view,
        depth_slice: None,
        resolve_target: None,
        ops: Operations { load: LoadOp::Clear(NO_ASH.into()), store: StoreOp::Store },
    };
    let mut pass = ctx.begin_tracked_render_pass(RenderPassDescriptor {
        label: Some("volcano ash depth"),
        color_attachments: &[Some(attachment)],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    if let Some(viewport) =
        Viewport::from_viewport_and_override(camera.viewport.as_ref(), resolution_override)
    {
        pass.set_camera_viewport(&viewport);
    }
    if let Err(err) = phase.render(&mut pass, world, view_entity) {
        error!("volcano: the ash-depth pass failed: {err:?}");
    }
}
