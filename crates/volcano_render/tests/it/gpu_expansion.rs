//! The vertex shader's expansion of parents into billboards and s2/s3 detail spheres
//! (`src/plume/ash.wgsl`, the part between its `BEGIN expansion` / `END expansion` markers) run
//! as a compute shader on the render device (llvmpipe works) and read back, against the CPU
//! reference: [`build_instances`], which walks `detail_spheres` (the enumeration the PLY export
//! uses). Every instance of a small column is compared.
//!
//! Tolerance: centres within `1e-3 ×` the parent's radius (plus f32 rounding of the world
//! position, `1e-6 × |centre|`); the WGSL is f32 with GPU sin/cos (Vulkan allows 2⁻¹¹ absolute
//! error), the reference f64. A different hash or lattice picks another direction: neighbouring
//! lattice points are ≈0.028 parent radii apart, 28× the tolerance, so such a change fails here
//! (the test prints the first instances that differ, and a direct check of `hash32` says
//! whether the hash itself is the cause).

use bevy::app::PluginsState;
use bevy::prelude::*;
use bevy::render::render_resource::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use volcano_plume::view::{
    AshInstance, EruptionView, ParentSphere, PlumeViewSettings, SphereParams, build_instances, hash32,
};
use volcano_render::headless_default_plugins;
use volcano_render::plume::layout::{AshParents, build_parents};

const COMPUTE: &str = r#"
@group(0) @binding(2) var<storage, read_write> expanded: array<Expanded>;
@group(0) @binding(3) var<storage, read_write> hashes: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let total = starts[arrayLength(&parents)];
    if (id.x < total) {
        expanded[id.x] = expand(id.x);
    }
    if (id.x < arrayLength(&hashes)) {
        hashes[id.x] = hash32(id.x * 2654435761u);
    }
}
"#;

const HASHES: u32 = 256;

fn render_device() -> (RenderDevice, RenderQueue) {
    let mut app = App::new();
    app.add_plugins(headless_default_plugins());
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    app.finish();
    app.cleanup();
    (app.world().resource::<RenderDevice>().clone(), app.world().resource::<RenderQueue>().clone())
}

fn shader_source() -> String {
    // Read at run time (the source tree is there when tests run), so an edit of the shader is
    // tested without a rebuild.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/plume/ash.wgsl");
    let wgsl = std::fs::read_to_string(path).expect("ash.wgsl readable");
    let begin = wgsl.find("// BEGIN expansion").expect("BEGIN marker in ash.wgsl");
    let end = wgsl.find("// END expansion").expect("END marker in ash.wgsl");
    format!("{}\n{COMPUTE}", wgsl[begin..end].replace("@group(3)", "@group(0)"))
}

/// The shader's `Expanded` (two `vec4<f32>`: centre and radius; angle, shade, coverage, kind),
/// read back as an [`AshInstance`] (plain data, same eight values in the same order).
fn instance(words: [f32; 8]) -> AshInstance {
    let [x, y, z, radius, angle, shade, coverage, kind] = words;
    AshInstance { center: [x, y, z], radius, angle, shade, coverage, kind }
}

/// Size of one `Expanded` in the readback.
const EXPANDED_BYTES: usize = size_of::<[f32; 8]>();

/// Runs the expansion of `list` on the GPU: every instance, and `hash32` of `HASHES` words.
fn expand_on_gpu(list: &AshParents) -> (Vec<AshInstance>, Vec<u32>) {
    let (device, queue) = render_device();
    let module = device.create_and_validate_shader_module(ShaderModuleDescriptor {
        label: Some("ash expansion test"),
        source: ShaderSource::Wgsl(shader_source().into()),
    });
    let pipeline = device.create_compute_pipeline(&RawComputePipelineDescriptor {
        label: Some("ash expansion test"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let storage = |label, bytes: &[u8], extra| {
        device.create_buffer_with_data(&BufferInitDescriptor {
            label: Some(label),
            contents: bytes,
            usage: BufferUsages::STORAGE | extra,
        })
    };
    let total = list.total();
    let out_bytes = total as u64 * EXPANDED_BYTES as u64;
    let hash_bytes = HASHES as u64 * 4;
    let parents = storage("parents", bytemuck::cast_slice(&list.parents), BufferUsages::empty());
    let starts = storage("starts", bytemuck::cast_slice(&list.starts), BufferUsages::empty());
    let expanded = storage("expanded", &vec![0u8; out_bytes as usize], BufferUsages::COPY_SRC);
    let hashes = storage("hashes", &vec![0u8; hash_bytes as usize], BufferUsages::COPY_SRC);
    let staging = device.create_buffer(&BufferDescriptor {
        label: Some("readback"),
        size: out_bytes + hash_bytes,
        usage: BufferUsages::MAP_READ | BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let layout = BindGroupLayout::from(pipeline.get_bind_group_layout(0));
    let bind_group = device.create_bind_group(
        "ash expansion test",
        &layout,
        &BindGroupEntries::sequential((
            parents.as_entire_binding(),
            starts.as_entire_binding(),
            expanded.as_entire_binding(),
            hashes.as_entire_binding(),
        )),
    );
    let mut encoder = device.create_command_encoder(&CommandEncoderDescriptor::default());
    {
        let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &*bind_group, &[]);
        pass.dispatch_workgroups(total.max(HASHES).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&expanded, 0, &staging, 0, out_bytes);
    encoder.copy_buffer_to_buffer(&hashes, 0, &staging, out_bytes, hash_bytes);
    queue.submit([encoder.finish()]);
    staging.slice(..).map_async(MapMode::Read, |r| r.expect("readback mapped"));
    device.poll(PollType::wait_indefinitely()).expect("device poll");
    let bytes = staging.slice(..).get_mapped_range().to_vec();
    let (inst, hash) = bytes.split_at(out_bytes as usize);
    (
        inst.chunks_exact(EXPANDED_BYTES).map(|c| instance(bytemuck::pod_read_unaligned(c))).collect(),
        hash.chunks_exact(4).map(bytemuck::pod_read_unaligned).collect(),
    )
}

/// A small column: s1 spheres on slices, umbrella spheres and a pyroclastic puff, turned
/// arbitrarily, dense to dilute (so the plan thins), kilometres from the origin.
fn column() -> (Vec<EruptionView>, Vec<ParentSphere>) {
    let spheres = SphereParams { s2_per_s1: 40, s3_per_s2: 3, ..Default::default() };
    let eruptions = vec![EruptionView {
        entity: Entity::PLACEHOLDER,
        seed: 0x1234_5678_9abc_def0,
        spheres,
        rho0: 200.0,
        vent: Vec3::ZERO,
    }];
    let parents = (0..60u64)
        .map(|i| ParentSphere {
            id: (i / 6 + 1000) << 8 | (i % 6),
            eruption: 0,
            center: Vec3::new(3_000.0 + 17.0 * i as f32, 1_500.0 + 160.0 * i as f32, -2_000.0),
            radius: 15.0 + 3.0 * i as f32,
            rotation: Quat::from_axis_angle(Vec3::new(0.2, 1.0, -0.4).normalize(), 0.37 * i as f32),
            density: 200.0 / (1.0 + 0.3 * i as f32).powi(2),
            umbrella: i >= 50,
            flow: i == 13,
            cloud: i == 17,
        })
        .collect();
    (eruptions, parents)
}

#[test]
fn vertex_expansion_matches_the_cpu_enumeration() {
    let (eruptions, parents) = column();
    let viewpoint = Some(Vec3::new(20_000.0, 3_000.0, 15_000.0));
    let settings = PlumeViewSettings { max_instances: u32::MAX, ..Default::default() };
    let mut cpu = Vec::new();
    build_instances(&settings, viewpoint, &eruptions, &parents, &mut cpu);
    let mut list = AshParents::default();
    build_parents(&settings, viewpoint, &eruptions, &parents, &[], &mut list);
    assert_eq!(list.total() as usize, cpu.len(), "the packed counts are the CPU plan's");
    let detail = cpu.iter().filter(|i| i.kind < 1.0).count();
    assert!(detail > 3_000, "a real sample of children: {detail}");

    let (gpu, hashes) = expand_on_gpu(&list);
    let wrong_hashes: Vec<_> = (0..HASHES)
        .map(|x| (x, hashes[x as usize], hash32(x.wrapping_mul(2_654_435_761))))
        .filter(|(_, g, c)| g != c)
        .take(5)
        .collect();
    assert!(
        wrong_hashes.is_empty(),
        "WGSL hash32 differs from the Rust one (x, gpu, cpu): {wrong_hashes:x?}"
    );

    let mut worst = 0.0f32;
    let mut bad = Vec::new();
    for (i, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
        let p = list.starts.partition_point(|&s| s as usize <= i) - 1;
        let r_parent = list.parents[p].radius;
        let d = (Vec3::from_array(g.center) - Vec3::from_array(c.center)).length();
        let tol = 1e-3 * r_parent + 1e-6 * Vec3::from_array(c.center).length();
        worst = worst.max(d / r_parent);
        let look_ok = (g.radius - c.radius).abs() <= 1e-5 * c.radius
            && (g.shade, g.coverage, g.kind, g.angle) == (c.shade, c.coverage, c.kind, c.angle);
        if d > tol || !look_ok {
            bad.push(format!(
                "instance {i} (parent {p}, local {}): gpu {g:?} vs cpu {c:?}, centres {:.4} parent radii apart",
                i as u32 - list.starts[p],
                d / r_parent
            ));
        }
    }
    eprintln!(
        "{} instances ({detail} detail spheres), worst centre error {worst:.2e} parent radii",
        cpu.len()
    );
    assert!(
        bad.is_empty(),
        "{} of {} instances differ, first: {:#?}",
        bad.len(),
        cpu.len(),
        &bad[..bad.len().min(4)]
    );
}
