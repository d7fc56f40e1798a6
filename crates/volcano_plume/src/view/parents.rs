//! What the GPU-expanded path draws, as plain data: per frame only the parents (s1, umbrella and
//! pyroclastic spheres, ~6,000) go to the renderer, each with its instance count and look, and
//! its vertex shader computes the children with the same 32-bit enumeration as
//! [`detail_spheres`](crate::model::spheres::detail_spheres). [`plan_parents`] says what each
//! parent draws; the renderer lays that out for its shader (`volcano_render::plume::layout`,
//! 64-byte records and the prefix sum of the counts). The plume benchmark measures this part.
//!
//! The counts (thinning by dilution and by `max_instances`) and the billboard look (shade,
//! coverage, projected spin, texture variant) come from the same plan as the CPU
//! [`build_instances`](super::build_instances), so both paths draw the same instances; the
//! CPU path stays as the reference (tests, the benchmark's comparison).

use bevy::prelude::*;

use super::{EruptionView, ParentSphere, PlumeViewSettings, billboard_look, plan_instances};
use crate::model::spheres::parent_key;

/// One parent that draws at least one instance this frame, and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrawnParent {
    /// Index of the parent in the list it was planned from (the order of
    /// [`light_parents`](super::light_parents) too).
    pub index: usize,
    /// Its instances are `start .. end` of the frame's list (`start < end`); the parents come in
    /// the enumeration order, so each one's `start` is the previous one's `end`.
    pub start: u32,
    /// One past its last instance: the running sum of the counts.
    pub end: u32,
    /// Whether its first instance is its billboard (the rest are detail spheres, a prefix of
    /// its enumeration).
    pub billboard: bool,
    /// Screen-space rotation of the billboard's smoke texture (rad): the spin projected on the
    /// viewing direction (s1 spheres), a fixed angle (umbrella and pyroclastic puffs).
    pub angle: f32,
    /// Density shade, 0 (dense, at the vent) … 1 (diluted); children add 0.08 per level.
    pub shade: f32,
    /// Fraction of the billboard (and of the impostors) the smoke covers, in (0, 1].
    pub coverage: f32,
    /// Texture variant in [0, 1).
    pub variant: f32,
    /// 32-bit key of its children ([`parent_key`] of the eruption's seed and the parent id).
    pub key: u32,
    /// s3 children per s2 child (the eruption's `SphereParams::s3_per_s2`).
    pub s3_per_s2: u32,
}

/// Calls `f` on every parent that draws anything this frame, in order: the same plan (counts,
/// thinning, shading) as [`build_instances`](super::build_instances). Parents without
/// instances (nothing kept, invalid geometry, unknown eruption, or the view disabled) are
/// skipped.
pub fn plan_parents(
    settings: &PlumeViewSettings,
    viewpoint: Option<Vec3>,
    eruptions: &[EruptionView],
    parents: &[ParentSphere],
    mut f: impl FnMut(DrawnParent),
) {
    if !settings.enabled {
        return;
    }
    let plan = plan_instances(settings, eruptions, parents);
    for (index, (p, plan)) in parents.iter().zip(&plan).enumerate() {
        let count = plan.count();
        let Some(e) = eruptions.get(p.eruption).filter(|_| count > 0) else { continue };
        let (angle, variant) = billboard_look(p, viewpoint);
        // The plan never passes `max_instances` (a u32), so the running sum fits.
        f(DrawnParent {
            index,
            start: plan.offset as u32,
            end: (plan.offset + count) as u32,
            billboard: plan.billboard,
            angle,
            shade: plan.shade,
            coverage: plan.coverage,
            variant,
            key: parent_key(e.seed, p.id),
            s3_per_s2: e.spheres.s3_per_s2,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::super::build_instances;
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

    #[test]
    fn drawn_parents_are_the_cpu_instances_parent_by_parent() {
        let parents = parents();
        let viewpoint = Some(Vec3::new(5_000.0, 3_000.0, 8_000.0));
        for (s2, s3, max) in [(30, 0, u32::MAX), (12, 3, u32::MAX), (50, 2, 2_000), (0, 0, u32::MAX)] {
            let e = view(s2, s3);
            let settings = PlumeViewSettings { max_instances: max, ..Default::default() };
            let mut cpu = Vec::new();
            build_instances(&settings, viewpoint, &e, &parents, &mut cpu);
            let mut drawn = Vec::new();
            plan_parents(&settings, viewpoint, &e, &parents, |d| drawn.push(d));
            let mut next = 0;
            for d in &drawn {
                assert_eq!(d.start, next, "contiguous ranges");
                assert!(d.start < d.end, "every drawn parent draws");
                next = d.end;
                let first = &cpu[d.start as usize];
                let p = &parents[d.index];
                assert_eq!(d.key, parent_key(e[0].seed, p.id));
                if d.billboard {
                    assert_eq!((first.kind, first.angle, first.shade), (1.0 + d.variant, d.angle, d.shade));
                } else {
                    assert_eq!((first.kind, first.coverage), (d.variant, d.coverage));
                }
            }
            assert_eq!(next as usize, cpu.len(), "s2 {s2}, s3 {s3}, max {max}");
        }
    }

    #[test]
    fn disabled_view_draws_nothing() {
        let settings = PlumeViewSettings { enabled: false, ..Default::default() };
        let mut n = 0;
        plan_parents(&settings, None, &view(10, 0), &parents(), |_| n += 1);
        assert_eq!(n, 0);
    }
}
