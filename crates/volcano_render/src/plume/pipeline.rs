//! Render-world side of the ash renderer: one instanced draw of a unit quad per frame, with
//! the [`AshInstance`] list (extracted as an `Arc`, no copy) as a per-instance vertex buffer.
//! The shader (`ash.wgsl`) turns each quad toward the camera and draws a smoke puff (s1 and
//! umbrella spheres) or a lit sphere impostor (s2/s3 detail spheres). Fragments write depth and
//! cut out (no blending), so half a million unsorted instances draw correctly in any order.
//!
//! The structure (specialised mesh pipeline, extra instance vertex buffer, custom draw
//! command) follows Bevy 0.19's "custom shader instancing" technique.

use std::sync::Arc;

use bevy::core_pipeline::core_3d::{Transparent3d, TransparentSortingInfo3d};
use bevy::ecs::system::{SystemParamItem, lifetimeless::*};
use bevy::mesh::{MeshVertexBufferLayoutRef, VertexBufferLayout};
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
use volcano_plume::{AshInstance, PlumeInstances};

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

/// The frame's instances in the render world.
#[derive(Resource, Default)]
struct RenderAshInstances(Arc<Vec<AshInstance>>);

/// GPU copy of the instances, on the [`AshCloud`] render entity.
#[derive(Component)]
struct AshInstanceBuffer {
    buffer: Buffer,
    length: u32,
}

/// Adds the pipeline, extraction and draw command.
pub(super) fn build(app: &mut App) {
    app.add_plugins(ExtractComponentPlugin::<AshCloud>::default());
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else { return };
    render_app
        .init_resource::<RenderAshInstances>()
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

fn extract_instances(mut target: ResMut<RenderAshInstances>, source: Extract<Option<Res<PlumeInstances>>>) {
    target.0 = source.as_ref().map(|s| s.0.clone()).unwrap_or_default();
}

fn prepare_buffer(
    mut commands: Commands,
    clouds: Query<Entity, With<AshCloud>>,
    instances: Res<RenderAshInstances>,
    device: Res<RenderDevice>,
) {
    for entity in &clouds {
        if instances.0.is_empty() {
            commands.entity(entity).remove::<AshInstanceBuffer>();
            continue;
        }
        let buffer = device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some("volcano ash instances"),
            contents: bytemuck::cast_slice(instances.0.as_slice()),
            usage: BufferUsages::VERTEX | BufferUsages::COPY_DST,
        });
        commands.entity(entity).insert(AshInstanceBuffer { buffer, length: instances.0.len() as u32 });
    }
}

#[derive(Resource)]
struct AshPipeline {
    shader: Handle<Shader>,
    mesh_pipeline: MeshPipeline,
}

fn init_pipeline(mut commands: Commands, assets: Res<AssetServer>, mesh_pipeline: Res<MeshPipeline>) {
    commands
        .insert_resource(AshPipeline { shader: assets.load(SHADER), mesh_pipeline: mesh_pipeline.clone() });
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
        // Locations 0–2 are the quad's position, normal and uv.
        descriptor.vertex.buffers.push(VertexBufferLayout {
            array_stride: size_of::<AshInstance>() as u64,
            step_mode: VertexStepMode::Instance,
            attributes: vec![
                VertexAttribute { format: VertexFormat::Float32x4, offset: 0, shader_location: 3 },
                VertexAttribute {
                    format: VertexFormat::Float32x4,
                    offset: VertexFormat::Float32x4.size(),
                    shader_location: 4,
                },
            ],
        });
        if let Some(fragment) = descriptor.fragment.as_mut() {
            fragment.shader = self.shader.clone();
        }
        // Both faces: the quad always faces the camera, but cheap insurance against winding.
        descriptor.primitive.cull_mode = None;
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
        for (entity, main_entity) in &clouds {
            let Some(mesh_instance) = mesh_instances.render_mesh_queue_data(*main_entity) else { continue };
            let Some(mesh) = meshes.get(mesh_instance.mesh_asset_id()) else { continue };
            let key = view_key
                | MeshPipelineKey::from_primitive_topology_and_strip_index(
                    mesh.primitive_topology(),
                    mesh.index_format(),
                );
            let Ok(id) = pipelines.specialize(&cache, &pipeline, key, &mesh.layout) else {
                error!("volcano: the ash pipeline could not be specialised");
                continue;
            };
            phase.add_retained(Transparent3d {
                // Drawn first among transparent items: it writes depth like an opaque object.
                sorting_info: TransparentSortingInfo3d::Sorted { mesh_center: Vec3::ZERO, depth_bias: 0.0 },
                entity: (entity, *main_entity),
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

type DrawAsh = (
    SetItemPipeline,
    SetMeshViewBindGroup<0>,
    SetMeshViewBindingArrayBindGroup<1>,
    SetMeshBindGroup<2>,
    DrawAshInstanced,
);

struct DrawAshInstanced;

impl<P: PhaseItem> RenderCommand<P> for DrawAshInstanced {
    type Param = (SRes<RenderAssets<RenderMesh>>, SRes<RenderMeshInstances>, SRes<MeshAllocator>);
    type ViewQuery = ();
    type ItemQuery = Read<AshInstanceBuffer>;

    fn render<'w>(
        item: &P,
        _view: (),
        instances: Option<&'w AshInstanceBuffer>,
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
        pass.set_vertex_buffer(1, instances.buffer.slice(..));
        match &gpu_mesh.buffer_info {
            RenderMeshBufferInfo::Indexed { index_format, count } => {
                let Some(indices) = allocator.mesh_index_slice(&mesh_instance.mesh_asset_id()) else {
                    return RenderCommandResult::Skip;
                };
                pass.set_index_buffer(indices.buffer.slice(..), *index_format);
                pass.draw_indexed(
                    indices.range.start..(indices.range.start + count),
                    vertices.range.start as i32,
                    0..instances.length,
                );
            }
            RenderMeshBufferInfo::NonIndexed => pass.draw(vertices.range, 0..instances.length),
        }
        RenderCommandResult::Success
    }
}
