//! The GPU layout of the ash renderer: per frame only the parents (s1, umbrella and pyroclastic
//! spheres, ~6,000) are uploaded, as 64-byte [`AshParent`] records with the prefix sum of their
//! instance counts; the renderer draws `total` instances and its vertex shader maps an
//! instance index to (parent, child) by binary search over the prefix sums and computes the
//! child with the same 32-bit enumeration as
//! [`detail_spheres`](volcano_plume::view::detail_spheres).
//!
//! What each parent draws (counts, thinning, look) is plain data of the plume crate
//! ([`plan_parents`], the same plan as the CPU reference
//! [`build_instances`](volcano_plume::view::build_instances)); this module only lays it out
//! for the shader: the record, the flag bits, the light packed into one word.

use std::sync::Arc;

use bevy::prelude::*;
use volcano_core::SimTick;
use volcano_plume::view::{
    AshInstance, AshLightSettings, CurrentCloudSettings, EruptionView, ParentLight, ParentSphere,
    PlumeViewSettings, PlumeViewpoint, SphereParams, direction_index, gather_parents, lattice_direction,
    plan_parents, s2_key, s3_key, vent_light,
};

use super::light_task::AshLightTask;

/// One parent as the renderer's vertex shader reads it (64 bytes, a `std430` storage-buffer
/// element; the WGSL struct `AshParent` in `ash.wgsl` mirrors it).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AshParent {
    /// Centre (world, m).
    pub center: [f32; 3],
    /// Radius (m): children sit on this sphere, with radius `CHILD_RATIO ×` it.
    pub radius: f32,
    /// Orientation (unit quaternion x, y, z, w); children turn rigidly with it.
    pub rotation: [f32; 4],
    /// Screen-space rotation of the billboard's smoke texture (rad).
    pub angle: f32,
    /// Density shade of the parent (children add 0.08 per level, capped at 1).
    pub shade: f32,
    /// Coverage of the billboard (and of the impostors), in (0, 1].
    pub coverage: f32,
    /// Texture variant in [0, 1) (impostor `kind`; the billboard's is `1 + variant`).
    pub variant: f32,
    /// 32-bit key of the children (`parent_key` of seed and parent id).
    pub key: u32,
    /// Bit 0: the first instance is the billboard; bits 8–15: s3 children per s2 child.
    pub flags: u32,
    /// Billboard radius (m): `radius × billboard_scale`.
    pub billboard_radius: f32,
    /// Light reaching the parent ([`pack_light`]: sun and sky transmittance, 8 bits each);
    /// keeps the record 16-byte aligned.
    pub light: u32,
}

impl AshParent {
    /// [`AshParent::flags`] bit: the parent's first instance is its billboard.
    pub const BILLBOARD: u32 = 1;
    /// [`AshParent::flags`] bit: a pyroclastic-current particle (drawn dark and ground-hugging).
    pub const FLOW: u32 = 2;
    /// [`AshParent::flags`] shift of the s3-per-s2 count (8 bits, at most 100 by validation).
    pub const S3_SHIFT: u32 = 8;
}

/// The light of a parent as the shader reads it (`unpack4x8unorm`: x = sun, y = sky,
/// z = vent).
pub fn pack_light(light: ParentLight) -> u32 {
    let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u32;
    q(light.sun) | (q(light.sky) << 8) | (q(light.vent) << 16)
}

/// The frame's parents and the prefix sum of their instance counts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AshParents {
    /// Parents with at least one instance, in the enumeration order.
    pub parents: Vec<AshParent>,
    /// `parents.len() + 1` entries: parent `i` owns instances `starts[i] .. starts[i + 1]`
    /// (strictly increasing); the last entry is the number of instances to draw.
    pub starts: Vec<u32>,
}

impl AshParents {
    /// Instances to draw.
    pub fn total(&self) -> u32 {
        self.starts.last().copied().unwrap_or(0)
    }
}

/// The parents the renderer expands, shared with the render world without a copy.
#[derive(Resource, Debug, Clone, Default)]
pub struct PlumeParents(pub Arc<AshParents>);

/// Packs the frame's parents for GPU expansion: one [`AshParent`] per parent that draws
/// anything ([`plan_parents`]) and the prefix sum of the counts. `light` is per parent (from
/// [`light_parents`](volcano_plume::view::light_parents)); missing entries are fully lit. `out` is reused.
pub fn build_parents(
    settings: &PlumeViewSettings,
    viewpoint: Option<Vec3>,
    eruptions: &[EruptionView],
    parents: &[ParentSphere],
    light: &[ParentLight],
    out: &mut AshParents,
) {
    out.parents.clear();
    out.starts.clear();
    out.starts.push(0);
    plan_parents(settings, viewpoint, eruptions, parents, |d| {
        let p = &parents[d.index];
        // The shader's rotation formula wants a unit quaternion.
        let q = p.rotation;
        let rotation =
            if q.is_finite() && q.length_squared() > 1e-12 { q.normalize() } else { Quat::IDENTITY };
        out.parents.push(AshParent {
            center: p.center.to_array(),
            radius: p.radius,
            rotation: rotation.to_array(),
            angle: d.angle,
            shade: d.shade,
            coverage: d.coverage,
            variant: d.variant,
            key: d.key,
            flags: (d.billboard as u32 * AshParent::BILLBOARD)
                | (p.flow as u32 * AshParent::FLOW)
                | (d.s3_per_s2.min(255) << AshParent::S3_SHIFT),
            billboard_radius: p.radius * settings.billboard_scale,
            light: pack_light(light.get(d.index).copied().unwrap_or(ParentLight::CLEAR)),
        });
        out.starts.push(d.end);
    });
}

/// Gathers the spheres and repacks [`PlumeParents`] (reusing the previous allocation when the
/// render world has let go of it). Scheduled in `PostUpdate` by
/// [`PlumeRenderPlugin`](super::PlumeRenderPlugin).
pub fn update_parents(world: &mut World) {
    let (eruptions, parents) = gather_parents(world);
    let settings = world.resource::<PlumeViewSettings>().clone();
    let viewpoint = world.resource::<PlumeViewpoint>().0;
    let light_settings = world.get_resource_or_init::<AshLightSettings>().clone();
    let light = match light_settings.validate() {
        Ok(()) => {
            let tick = world.get_resource::<SimTick>().map(|t| t.0);
            let mut light = world.resource_mut::<AshLightTask>().light(&parents, &light_settings, tick);
            let vents: Vec<Vec3> = eruptions.iter().map(|e| e.vent).collect();
            vent_light(&parents, &vents, light_settings.vent_reach_m, &mut light);
            light
        }
        Err(e) => {
            warn_once!("volcano: ash lighting off: {e}");
            Vec::new()
        }
    };
    let mut shared = std::mem::take(&mut world.resource_mut::<PlumeParents>().0);
    let mut list = match Arc::get_mut(&mut shared) {
        Some(v) => std::mem::take(v),
        None => AshParents::default(),
    };
    build_parents(&settings, viewpoint, &eruptions, &parents, &light, &mut list);
    world.resource_mut::<PlumeParents>().0 = Arc::new(list);
}

/// Resources and the packing system (called by [`PlumeRenderPlugin`](super::PlumeRenderPlugin)).
pub(super) fn build(app: &mut App) {
    app.init_resource::<PlumeViewSettings>()
        .init_resource::<PlumeViewpoint>()
        .init_resource::<PlumeParents>()
        .init_resource::<AshLightTask>()
        .init_resource::<AshLightSettings>()
        .init_resource::<CurrentCloudSettings>()
        .register_type::<AshLightSettings>()
        .register_type::<CurrentCloudSettings>()
        .register_type::<PlumeViewSettings>()
        .register_type::<PlumeViewpoint>()
        .add_systems(PostUpdate, update_parents);
}

/// The CPU reference of the shader's expansion: instance `index` of a packed list, as an
/// [`AshInstance`] (binary search over `starts`, then the billboard or the child's level,
/// centre and radius in f64 like [`detail_spheres`](volcano_plume::view::detail_spheres)).
/// `None` past the end. For tests and tools; the renderer does this on the GPU.
pub fn expand_instance(list: &AshParents, index: u32) -> Option<AshInstance> {
    if index >= list.total() {
        return None;
    }
    // Last parent whose start is ≤ index (starts are strictly increasing).
    let p = list.starts.partition_point(|&s| s <= index) - 1;
    let a = list.parents.get(p)?;
    let local = index - list.starts[p];
    let billboard = a.flags & AshParent::BILLBOARD != 0;
    if billboard && local == 0 {
        return Some(AshInstance {
            center: a.center,
            radius: a.billboard_radius,
            angle: a.angle,
            shade: a.shade,
            coverage: a.coverage,
            kind: 1.0 + a.variant,
        });
    }
    let child = local - billboard as u32;
    let group = 1 + ((a.flags >> AshParent::S3_SHIFT) & 0xff);
    let (k, j) = (child / group, child % group);
    let rot = Quat::from_array(a.rotation).as_dquat();
    let radius = a.radius as f64;
    let key2 = s2_key(a.key, k);
    let mut center =
        Vec3::from_array(a.center).as_dvec3() + rot * (lattice_direction(direction_index(key2)) * radius);
    let mut r = radius * SphereParams::CHILD_RATIO;
    if j > 0 {
        center += rot * (lattice_direction(direction_index(s3_key(key2, j - 1))) * r);
        r *= SphereParams::CHILD_RATIO;
    }
    let level = if j > 0 { 3.0 } else { 2.0 };
    Some(AshInstance {
        center: center.as_vec3().to_array(),
        radius: r as f32,
        angle: 0.0,
        shade: (a.shade + 0.08 * (level - 1.0)).min(1.0),
        coverage: a.coverage,
        kind: a.variant,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_plume::view::build_instances;

    fn parents() -> Vec<ParentSphere> {
        (0..40u64)
            .map(|i| ParentSphere {
                id: (i / 6) << 8 | (i % 6),
                eruption: 0,
                center: Vec3::new(30.0 * i as f32, 2_000.0 + 50.0 * i as f32, -10.0),
                radius: 20.0 + i as f32,
                rotation: Quat::from_axis_angle(Vec3::new(1.0, 0.3, -0.2).normalize(), 0.1 * i as f32),
                // Dense to dilute: the plan thins the dilute ones.
                density: 200.0 / (1.0 + i as f32).powi(2),
                umbrella: i % 5 == 4,
                flow: i == 7,
                cloud: i == 11,
            })
            .collect()
    }

    fn view(s2: u32, s3: u32) -> Vec<EruptionView> {
        let spheres = SphereParams { s2_per_s1: s2, s3_per_s2: s3, ..Default::default() };
        vec![EruptionView {
            entity: Entity::PLACEHOLDER,
            seed: 0x5eed_0000_0000_0042,
            spheres,
            rho0: 200.0,
            vent: Vec3::ZERO,
        }]
    }

    fn assert_close(a: &AshInstance, b: &AshInstance, scale: f32, what: &str) {
        let d = (Vec3::from_array(a.center) - Vec3::from_array(b.center)).length();
        assert!(d <= 1e-6 * scale.max(1.0) + 1e-3, "{what}: centres {:?} vs {:?}", a.center, b.center);
        assert!((a.radius - b.radius).abs() <= 1e-5 * a.radius, "{what}: radius {a:?} vs {b:?}");
        assert_eq!((a.shade, a.coverage, a.kind, a.angle), (b.shade, b.coverage, b.kind, b.angle), "{what}");
    }

    #[test]
    fn packed_parents_expand_to_the_cpu_instances() {
        let parents = parents();
        let viewpoint = Some(Vec3::new(5_000.0, 3_000.0, 8_000.0));
        for (s2, s3, max) in [(30, 0, u32::MAX), (12, 3, u32::MAX), (50, 2, 2_000), (0, 0, u32::MAX)] {
            let e = view(s2, s3);
            let settings = PlumeViewSettings { max_instances: max, ..Default::default() };
            let mut cpu = Vec::new();
            build_instances(&settings, viewpoint, &e, &parents, &mut cpu);
            let mut gpu = AshParents::default();
            build_parents(&settings, viewpoint, &e, &parents, &[], &mut gpu);
            // Same thinning: the same number of instances, parent by parent.
            assert_eq!(gpu.total() as usize, cpu.len(), "s2 {s2}, s3 {s3}, max {max}");
            assert!(gpu.starts.windows(2).all(|w| w[0] < w[1]), "every packed parent draws");
            for (i, c) in cpu.iter().enumerate() {
                let g = expand_instance(&gpu, i as u32).expect("inside the total");
                assert_close(&g, c, 5_000.0, &format!("instance {i} (s2 {s2}, s3 {s3}, max {max})"));
            }
            assert_eq!(expand_instance(&gpu, gpu.total()), None);
        }
    }

    #[test]
    fn disabled_view_packs_nothing() {
        let settings = PlumeViewSettings { enabled: false, ..Default::default() };
        let mut gpu = AshParents::default();
        build_parents(&settings, None, &view(10, 0), &parents(), &[], &mut gpu);
        assert_eq!((gpu.parents.len(), gpu.starts.as_slice(), gpu.total()), (0, &[0][..], 0));
    }

    #[test]
    fn layout_is_64_bytes() {
        // The WGSL struct in ash.wgsl has the same size (std430, 16-aligned).
        assert_eq!(size_of::<AshParent>(), 64);
    }

    #[test]
    fn light_packing_is_what_the_shader_unpacks() {
        assert_eq!(pack_light(ParentLight { sun: 1.0, sky: 0.0, vent: 0.0 }), 0xff);
        assert_eq!(pack_light(ParentLight { sun: 0.0, sky: 1.0, vent: 0.0 }), 0xff00);
        assert_eq!(pack_light(ParentLight { sun: 0.0, sky: 0.0, vent: 1.0 }), 0xff_0000);
        assert_eq!(pack_light(ParentLight { sun: f32::NAN, sky: 2.0, vent: 0.0 }) >> 8, 0xff);
    }
}
