//! The GPU-expanded path: per frame only the parents (s1, umbrella and pyroclastic spheres,
//! ~6,000) are packed, with the prefix sum of their instance counts; the renderer draws
//! `total` instances and its vertex shader maps an instance index to (parent, child) by binary
//! search over the prefix sums and computes the child with the same 32-bit enumeration as
//! [`detail_spheres`](crate::model::spheres::detail_spheres).
//!
//! The counts (thinning by dilution and by `max_instances`) and the billboard look (shade,
//! coverage, projected spin, texture variant) come from the same plan as the CPU
//! [`build_instances`](super::build_instances), so both paths draw the same instances; the
//! CPU path stays as the reference (PLY export, tests, the benchmark's comparison).

use std::sync::Arc;

use bevy::prelude::*;

use super::{
    AshLightSettings, EruptionView, ParentLight, ParentSphere, PlumeViewSettings, PlumeViewpoint,
    billboard_look, light_parents, plan_instances,
};
use crate::model::spheres::parent_key;

/// One parent as the renderer's vertex shader reads it (64 bytes, a `std430` storage-buffer
/// element; the WGSL struct `AshParent` in `volcano_render`'s `ash.wgsl` mirrors it).
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
    /// 32-bit key of the children ([`parent_key`] of seed and parent id).
    pub key: u32,
    /// Bit 0: the first instance is the billboard; bits 8–15: s3 children per s2 child.
    pub flags: u32,
    /// Billboard radius (m): `radius × billboard_scale`.
    pub billboard_radius: f32,
    /// Light reaching the parent ([`ParentLight::pack`]: sun and sky transmittance, 8 bits
    /// each); keeps the record 16-byte aligned.
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

/// Packs the frame's parents for GPU expansion: the same plan (counts, thinning, shading) as
/// [`build_instances`](super::build_instances), one [`AshParent`] per parent that draws
/// anything, and the prefix sum of the counts. Parents without instances (nothing kept,
/// invalid geometry, unknown eruption) are left out. `light` is per parent (from
/// [`light_parents`](super::light_parents)); missing entries are fully lit. `out` is reused.
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
    if !settings.enabled {
        return;
    }
    let plan = plan_instances(settings, eruptions, parents);
    for (i, (p, plan)) in parents.iter().zip(&plan).enumerate() {
        let count = plan.count();
        let Some(e) = eruptions.get(p.eruption).filter(|_| count > 0) else { continue };
        let (angle, variant) = billboard_look(p, viewpoint);
        let n3 = e.spheres.s3_per_s2.min(255);
        // The shader's rotation formula wants a unit quaternion.
        let q = p.rotation;
        let rotation =
            if q.is_finite() && q.length_squared() > 1e-12 { q.normalize() } else { Quat::IDENTITY };
        out.parents.push(AshParent {
            center: p.center.to_array(),
            radius: p.radius,
            rotation: rotation.to_array(),
            angle,
            shade: plan.shade,
            coverage: plan.coverage,
            variant,
            key: parent_key(e.seed, p.id),
            flags: (plan.billboard as u32 * AshParent::BILLBOARD)
                | (p.flow as u32 * AshParent::FLOW)
                | (n3 << AshParent::S3_SHIFT),
            billboard_radius: p.radius * settings.billboard_scale,
            light: light.get(i).copied().unwrap_or(ParentLight::CLEAR).pack(),
        });
        // The plan never passes `max_instances` (a u32), so the running sum fits.
        out.starts.push((plan.offset + count) as u32);
    }
}

/// Gathers the spheres and repacks [`PlumeParents`] (reusing the previous allocation when the
/// render world has let go of it). Scheduled by [`PlumeViewPlugin`](super::PlumeViewPlugin).
pub fn update_parents(world: &mut World) {
    let (eruptions, parents) = super::gather_parents(world);
    let settings = world.resource::<PlumeViewSettings>().clone();
    let viewpoint = world.resource::<PlumeViewpoint>().0;
    let light_settings = world.get_resource_or_init::<AshLightSettings>().clone();
    let light = match light_settings.validate() {
        Ok(()) => light_parents(&parents, &light_settings),
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

/// The CPU reference of the shader's expansion: instance `index` of a packed list, as an
/// [`AshInstance`](super::AshInstance) (binary search over `starts`, then the billboard or
/// the child's level, centre and radius in f64 like
/// [`detail_spheres`](crate::model::spheres::detail_spheres)). `None` past the end. For
/// tests and tools; the renderer does this on the GPU.
pub fn expand_instance(list: &AshParents, index: u32) -> Option<super::AshInstance> {
    use crate::model::spheres::{SphereParams, direction_index, lattice_direction, s2_key, s3_key};
    if index >= list.total() {
        return None;
    }
    // Last parent whose start is ≤ index (starts are strictly increasing).
    let p = list.starts.partition_point(|&s| s <= index) - 1;
    let a = list.parents.get(p)?;
    let local = index - list.starts[p];
    let billboard = a.flags & AshParent::BILLBOARD != 0;
    if billboard && local == 0 {
        return Some(super::AshInstance {
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
    Some(super::AshInstance {
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
    use super::super::{AshInstance, build_instances};
    use super::*;
    use crate::model::spheres::SphereParams;

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
            })
            .collect()
    }

    fn view(s2: u32, s3: u32) -> Vec<EruptionView> {
        let spheres = SphereParams { s2_per_s1: s2, s3_per_s2: s3, ..Default::default() };
        vec![EruptionView { seed: 0x5eed_0000_0000_0042, spheres, rho0: 200.0 }]
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
        // The WGSL struct in volcano_render's ash.wgsl has the same size (std430, 16-aligned).
        assert_eq!(size_of::<AshParent>(), 64);
    }
}
