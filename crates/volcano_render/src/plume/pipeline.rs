//! Render-world side of the ash renderer: one instanced draw of a unit quad per frame. Only the
//! parents are uploaded: the [`AshParents`] list (extracted as an `Arc`, no copy) becomes two
//! storage buffers (the [`AshParent`] records and the prefix sum of their instance counts,
//! bind group 3), and the draw asks for `total` instances; the vertex shader (`ash.wgsl`)
//! finds instance `i`'s parent by binary search, computes the billboard or the s2/s3 child with
//! the CPU enumeration's 32-bit hash, and turns the quad toward the camera. The fragment stage
//! draws a smoke puff (s1, umbrella and pyroclastic spheres) or a lit sphere impostor (detail
//! spheres) with soft edges, blended with premultiplied alpha and without depth writes (the
//! terrain still hides them). Blending needs back-to-front order: the parents are sorted far
//! to near from the camera here, before upload (the children of one parent stay unsorted; they
//! lie within its radius), and an instanced draw blends its instances in instance order.
//!
//! The structure (specialised mesh pipeline, custom draw command) follows Bevy 0.19's "custom
//! shader instancing" technique, with storage buffers in place of the instance vertex buffer.

use std::sync::Arc;

use super::layout::{AshParent, AshParents, PlumeParents};
use bevy::core_pipeline::core_3d::{Transparent3d, TransparentSortingInfo3d};
use bevy::ecs::system::{SystemParamItem, lifetimeless::*};
use bevy::mesh::MeshVertexBufferLayoutRef;
use bevy::pbr::{
    MeshPipeline, MeshPipelineKey, MeshPipelineSystems, RenderMeshInstances, SetMeshBindGroup,
    SetMeshViewBindGroup, SetMeshViewBindingArrayBindGroup, ViewKeyCache,
};
use bevy::prelude::*;
use bevy::render::{
    Extract, ExtractSchedule, Render, RenderApp, RenderStartup, RenderSystems,
    extract_component::{ExtractComponent, ExtractComponentPlugin},
    mesh::{RenderMesh, RenderMeshBufferInfo, allocator::MeshAllocator},
    render_asset::RenderAssets,
    render_phase::{
        AddRenderCommand, DrawFunctions, PhaseItem, PhaseItemExtraIndex, RenderCommand, RenderCommandResult,
        SetItemPipeline, TrackedRenderPass, ViewSortedRenderPhases,
    },
    render_resource::*,
    renderer::RenderDevice,
    sync_component::SyncComponent,
    sync_world::MainEntity,
    view::ExtractedView,
};

/// Asset path of the embedded shader.
const SHADER: &str = "embedded://volcano_render/plume/ash.wgsl";

/// Marks the entity that carries the ash draw (a unit quad mesh, no frustum culling).
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component)]
pub struct AshCloud;

impl SyncComponent for AshCloud {
    type Target = Self;
}

impl ExtractComponent for AshCloud {
    type QueryData = ();
    type QueryFilter = With<AshCloud>;
    type Out = Self;

    fn extract_component(_: ()) -> Option<Self> {
        Some(AshCloud)
    }
}

/// The frame's parents in the render world.
#[derive(Resource, Default)]
struct RenderAshParents(Arc<AshParents>);

/// GPU copy of the parents (bind group 3) and the number of instances they expand to, on the
/// [`AshCloud`] render entity.
#[derive(Component)]
pub(super) struct AshParentBuffers {
    bind_group: BindGroup,
    total: u32,
}

/// Adds the pipeline, extraction and draw command.
pub(super) fn build(app: &mut App) {
    app.add_plugins(ExtractComponentPlugin::<AshCloud>::default());
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else { return };
    render_app
        .init_resource::<RenderAshParents>()
        .add_render_command::<Transparent3d, DrawAsh>()
        .init_resource::<SpecializedMeshPipelines<AshPipeline>>()
        .add_systems(RenderStartup, init_pipeline.after(MeshPipelineSystems))
        .add_systems(ExtractSchedule, extract_instances)
        .add_systems(
            Render,
            (
                queue_ash.in_set(RenderSystems::QueueMeshes),
                prepare_buffer.in_set(RenderSystems::PrepareResources),
            ),
        );
}

fn extract_instances(mut target: ResMut<RenderAshParents>, source: Extract<Option<Res<PlumeParents>>>) {
    target.0 = source.as_ref().map(|s| s.0.clone()).unwrap_or_default();
}

/// The parents reordered far to near from `eye` (ties keep their order), with their prefix sums
/// rebuilt: the same instances, in the order premultiplied blending needs.
fn sort_far_to_near(list: &AshParents, eye: Vec3, out: &mut AshParents) {
    let mut order: Vec<(f32, usize)> = list
        .parents
        .iter()
        .enumerate()
        .map(|(i, p)| (Vec3::from_array(p.center).distance_squared(eye), i))
        .collect();
    // NaN distances (never packed, but cheap to guard) sort first, drawn under everything.
    order.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    out.parents.clear();
    out.starts.clear();
    out.starts.push(0);
    for (_, i) in order {
        out.parents.push(list.parents[i]);
        let count = list.starts[i + 1] - list.starts[i];
        out.starts.push(out.starts.last().copied().unwrap_or(0) + count);
    }
}

fn prepare_buffer(
    mut commands: Commands,
    clouds: Query<Entity, With<AshCloud>>,
    views: Query<&ExtractedView>,
    list: Res<RenderAshParents>,
    (device, pipeline, cache): (Res<RenderDevice>, Res<AshPipeline>, Res<PipelineCache>),
    mut sorted: Local<AshParents>,
) {
    // One order for every view: the first camera's (the scenes have one).
    let eye = views.iter().next().map(|v| v.world_from_view.translation()).unwrap_or(Vec3::ZERO);
    for entity in &clouds {
        let total = list.0.total();
        if total == 0 || list.0.parents.is_empty() {
            commands.entity(entity).remove::<AshParentBuffers>();
            continue;
        }
        sort_far_to_near(&list.0, eye, &mut sorted);
        let parents = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("volcano ash parents"),
            contents: bytemuck::cast_slice(sorted.parents.as_slice()),
            usage: BufferUsages::STORAGE,
        });
        let starts = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("volcano ash instance starts"),
            contents: bytemuck::cast_slice(sorted.starts.as_slice()),
            usage: BufferUsages::STORAGE,
        });
        let bind_group = device.create_bind_group(
            "volcano ash parents",
            &cache.get_bind_group_layout(&pipeline.parents_layout),
            &BindGroupEntries::sequential((parents.as_entire_binding(), starts.as_entire_binding())),
        );
        commands.entity(entity).insert(AshParentBuffers { bind_group, total });
    }
}

#[derive(Resource, Clone)]
pub(super) struct AshPipeline {
    shader: Handle<Shader>,
    pub(super) mesh_pipeline: MeshPipeline,
    /// Bind group 3: the parents and the prefix sum of their instance counts.
    parents_layout: BindGroupLayoutDescriptor,
}

pub(super) fn init_pipeline(
    mut commands: Commands,
    assets: Res<AssetServer>,
    mesh_pipeline: Res<MeshPipeline>,
) {
    use bevy::render::render_resource::binding_types::storage_buffer_read_only_sized;
    let parents_layout = BindGroupLayoutDescriptor::new(
        "volcano ash parents",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::VERTEX,
            (
                storage_buffer_read_only_sized(false, BufferSize::new(size_of::<AshParent>() as u64)),
                storage_buffer_read_only_sized(false, BufferSize::new(size_of::<u32>() as u64)),
            ),
        ),
    );
    commands.insert_resource(AshPipeline {
        shader: assets.load(SHADER),
        mesh_pipeline: mesh_pipeline.clone(),
        parents_layout,
    });
}

impl SpecializedMeshPipeline for AshPipeline {
    type Key = MeshPipelineKey;

    fn specialize(
        &self,
        key: Self::Key,
        layout: &MeshVertexBufferLayoutRef,
    ) -> Result<RenderPipelineDescriptor, SpecializedMeshPipelineError> {
        let mut descriptor = self.mesh_pipeline.specialize(key, layout)?;
        descriptor.vertex.shader = self.shader.clone();
        // Vertex buffer 0 is the quad (locations 0–2: position, normal, uv); the instances
        // come from the parents in bind group 3, after the view (0, 1) and mesh (2) groups.
        descriptor.set_layout(3, self.parents_layout.clone());
        if let Some(fragment) = descriptor.fragment.as_mut() {
            fragment.shader = self.shader.clone();
            // `ash.wgsl` has a second fragment entry point, the ash-depth pass's (`depth`).
            fragment.entry_point = Some("fragment".into());
        }
        // Both faces: the quad always faces the camera, but cheap insurance against winding.
        descriptor.primitive.cull_mode = None;
        // Soft edges: premultiplied alpha over what is behind, depth tested, not written.
        if let Some(fragment) = descriptor.fragment.as_mut() {
            for target in fragment.targets.iter_mut().flatten() {
                target.blend = Some(BlendState::PREMULTIPLIED_ALPHA_BLENDING);
            }
        }
        if let Some(depth) = descriptor.depth_stencil.as_mut() {
            depth.depth_write_enabled = Some(false);
        }
        Ok(descriptor)
    }
}

#[allow(clippy::too_many_arguments)]
fn queue_ash(
    draw_functions: Res<DrawFunctions<Transparent3d>>,
    pipeline: Res<AshPipeline>,
    mut pipelines: ResMut<SpecializedMeshPipelines<AshPipeline>>,
    cache: Res<PipelineCache>,
    meshes: Res<RenderAssets<RenderMesh>>,
    mesh_instances: Res<RenderMeshInstances>,
    clouds: Query<(Entity, &MainEntity), With<AshCloud>>,
    mut phases: ResMut<ViewSortedRenderPhases<Transparent3d>>,
    views: Query<&ExtractedView>,
    view_keys: Res<ViewKeyCache>,
) {
    let draw = draw_functions.read().id::<DrawAsh>();
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
            phase.add_retained(Transparent3d {
                // Drawn first among transparent items (sorted within itself, see `prepare_buffer`).
                sorting_info: TransparentSortingInfo3d::Sorted { mesh_center: Vec3::ZERO, depth_bias: 0.0 },
                entity: (entity, main_entity),
                pipeline: id,
                draw_function: draw,
                distance: f32::NEG_INFINITY,
                batch_range: 0..1,
                extra_index: PhaseItemExtraIndex::None,
                indexed: true,
            });
        }
    }
}

/// The ash draw of each [`AshCloud`] entity whose quad mesh is ready, with `pipeline`
/// specialised for a view of `view_key`: (render entity, main entity, pipeline). Shared by the
/// colour pass and the ash-depth pass (`depth`).
pub(super) fn specialized_ash_draws<S: SpecializedMeshPipeline<Key = MeshPipelineKey>>(
    view_key: MeshPipelineKey,
    clouds: &Query<(Entity, &MainEntity), With<AshCloud>>,
    (meshes, mesh_instances): (&RenderAssets<RenderMesh>, &RenderMeshInstances),
    (pipelines, cache, pipeline): (&mut SpecializedMeshPipelines<S>, &PipelineCache, &S),
) -> Vec<(Entity, MainEntity, CachedRenderPipelineId)> {
    let mut ready = Vec::new();
    for (entity, main_entity) in clouds {
        let Some(mesh_instance) = mesh_instances.render_mesh_queue_data(*main_entity) else { continue };
        let Some(mesh) = meshes.get(mesh_instance.mesh_asset_id()) else { continue };
        let key = view_key
            | MeshPipelineKey::from_primitive_topology_and_strip_index(
                mesh.primitive_topology(),
                mesh.index_format(),
            );
        match pipelines.specialize(cache, pipeline, key, &mesh.layout) {
            Ok(id) => ready.push((entity, *main_entity, id)),
            Err(e) => error!("volcano: an ash pipeline could not be specialised: {e}"),
        }
    }
    ready
}

type DrawAsh = (
    SetItemPipeline,
    SetMeshViewBindGroup<0>,
    SetMeshViewBindingArrayBindGroup<1>,
    SetMeshBindGroup<2>,
    DrawAshInstanced,
);

pub(super) struct DrawAshInstanced;

impl<P: PhaseItem> RenderCommand<P> for DrawAshInstanced {
    type Param = (SRes<RenderAssets<RenderMesh>>, SRes<RenderMeshInstances>, SRes<MeshAllocator>);
    type ViewQuery = ();
    type ItemQuery = Read<AshParentBuffers>;

    fn render<'w>(
        item: &P,
        _view: (),
        instances: Option<&'w AshParentBuffers>,
        (meshes, mesh_instances, allocator): SystemParamItem<'w, '_, Self::Param>,
        pass: &mut TrackedRenderPass<'w>,
    ) -> RenderCommandResult {
        let allocator = allocator.into_inner();
        let Some(mesh_instance) = mesh_instances.render_mesh_queue_data(item.main_entity()) else {
            return RenderCommandResult::Skip;
        };
        let Some(gpu_mesh) = meshes.into_inner().get(mesh_instance.mesh_asset_id()) else {
            return RenderCommandResult::Skip;
        };
        let Some(instances) = instances else { return RenderCommandResult::Skip };
        let Some(vertices) = allocator.mesh_vertex_slice(&mesh_instance.mesh_asset_id()) else {
            return RenderCommandResult::Skip;
        };
        pass.set_vertex_buffer(0, vertices.buffer.slice(..));
        pass.set_bind_group(3, &instances.bind_group, &[]);
        match &gpu_mesh.buffer_info {
            RenderMeshBufferInfo::Indexed { index_format, count } => {
                let Some(indices) = allocator.mesh_index_slice(&mesh_instance.mesh_asset_id()) else {
                    return RenderCommandResult::Skip;
                };
                pass.set_index_buffer(indices.buffer.slice(..), *index_format);
                pass.draw_indexed(
                    indices.range.start..(indices.range.start + count),
                    vertices.range.start as i32,
                    0..instances.total,
                );
            }
            RenderMeshBufferInfo::NonIndexed => pass.draw(vertices.range, 0..instances.total),
        }
        RenderCommandResult::Success
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parents_are_sorted_far_to_near_with_their_instances() {
        let parent = |z: f32| AshParent { center: [0.0, 0.0, z], ..Default::default() };
        let list = AshParents {
            parents: vec![parent(10.0), parent(300.0), parent(-50.0)],
            starts: vec![0, 1, 21, 24],
        };
        let mut out = AshParents::default();
        sort_far_to_near(&list, Vec3::ZERO, &mut out);
        let z: Vec<f32> = out.parents.iter().map(|p| p.center[2]).collect();
        assert_eq!(z, vec![300.0, -50.0, 10.0]);
        // Each parent keeps its instance count: 20, 3, 1.
        assert_eq!(out.starts, vec![0, 20, 23, 24]);
    }
}
