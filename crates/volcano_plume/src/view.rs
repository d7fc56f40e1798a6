//! What rendering and export see of a column (docs/ARCHITECTURE.md §2.3): every sphere of
//! every scale, enumerated in a fixed order from the ECS state (s1 spheres on slices, umbrella
//! spheres, and their procedural s2/s3 children), what each parent draws, and the light
//! reaching it. Plain data and functions, no GPU layout: the renderer's records, their packing
//! into 32-bit words and the system that uploads them are `volcano_render::plume::layout`.
//!
//! [`gather_parents`] reads the world once (sorted by sphere id, so the order does not depend
//! on archetype layout) and adds the ash clouds the view draws over pyroclastic currents
//! ([`current_clouds`]); [`for_each_sphere`] walks parents and children; [`build_instances`]
//! turns them into [`AshInstance`]s: camera-facing smoke billboards for the s1/umbrella
//! spheres (their texture turned by the spin projected on the screen, §3.7.1) and sphere
//! impostors for the detail spheres, shaded by density (lighter and thinner aloft).
//!
//! The renderer does not draw that list: it takes only the parents ([`plan_parents`], the same
//! plan) and its vertex shader expands the children with the same 32-bit enumeration
//! (re-exported here from the model). [`build_instances`] stays as the CPU reference (tests,
//! benchmark).

mod currents;
mod light;
mod parents;

pub use currents::{
    CLOUD_ID_BIT, CurrentCloudError, CurrentCloudSettings, FlowSample, current_clouds, surge_thickness,
};
pub use light::{AshLightError, AshLightSettings, ParentLight, light_parents, vent_light};
pub use parents::{DrawnParent, plan_parents};

pub use crate::model::spheres::{
    DetailSphere, SphereParams, detail_spheres, direction_index, hash32, lattice_direction, parent_key,
    s2_key, s3_key,
};

use std::sync::Arc;

use bevy::ecs::entity::EntityHashMap;
use bevy::math::{DQuat, DVec3};
use bevy::prelude::*;
use volcano_core::{VentPosition, VolcanoRng};

use crate::components::{Eruption, PlumeSlice, S1, Umbrella};
use crate::pyroclastic::PyroParticle;

/// A first-scale sphere (on a slice, or spreading in the umbrella) as the views see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParentSphere {
    /// Stable id (slice index << 8 | ring index); the detail spheres derive from it.
    pub id: u64,
    /// Index of the eruption in the [`EruptionView`] list.
    pub eruption: usize,
    /// Centre (world, m, y up).
    pub center: Vec3,
    /// Radius (m).
    pub radius: f32,
    /// Orientation (spin about the ring tangent); detail spheres turn rigidly with it.
    pub rotation: Quat,
    /// Density (kg/m³) of its slice; of an umbrella sphere, as it detached times its ash kept.
    pub density: f32,
    /// Whether it has left its slice for the umbrella.
    pub umbrella: bool,
    /// Whether it is a pyroclastic particle (drawn as a puff, no detail spheres: it already
    /// has the s2 size).
    pub flow: bool,
    /// Whether it is the ash cloud over a current, derived for the view ([`current_clouds`]):
    /// a lit puff without detail spheres, not a model sphere.
    pub cloud: bool,
}

/// Per-eruption data the views need.
#[derive(Debug, Clone, PartialEq)]
pub struct EruptionView {
    /// The volcano entity (parents name it by their index in the list, [`ParentSphere::eruption`]).
    pub entity: Entity,
    /// The volcano's seed (detail spheres derive from `(seed, parent id, index)`).
    pub seed: u64,
    /// Sphere counts.
    pub spheres: SphereParams,
    /// Vent density ρ₀ (kg/m³), the dark end of the density shading.
    pub rho0: f32,
    /// World position of the vent (`VentPosition`; the origin if the volcano has none yet).
    pub vent: Vec3,
}

/// Reads every eruption and first-scale sphere, in a deterministic order.
pub fn gather_parents(world: &mut World) -> (Vec<EruptionView>, Vec<ParentSphere>) {
    let mut eruptions: Vec<(Entity, EruptionView, f64)> = world
        .query::<(Entity, &Eruption, &VolcanoRng, Option<&VentPosition>)>()
        .iter(world)
        .map(|(e, er, rng, vent)| {
            let view = EruptionView {
                entity: e,
                seed: rng.seed(),
                spheres: er.spheres.clone(),
                rho0: er.params.rho0 as f32,
                vent: vent.map_or(Vec3::ZERO, |v| v.0),
            };
            (e, view, er.umbrella_fallout_s)
        })
        .collect();
    eruptions.sort_by_key(|(e, ..)| *e);
    let index: EntityHashMap<usize> = eruptions.iter().enumerate().map(|(i, (e, ..))| (*e, i)).collect();
    let slices: EntityHashMap<(usize, f32)> = world
        .query::<(Entity, &PlumeSlice)>()
        .iter(world)
        .filter_map(|(e, s)| index.get(&s.volcano).map(|&i| (e, (i, s.state.density as f32))))
        .collect();
    let mut parents: Vec<ParentSphere> = Vec::new();
    for (s1, t) in world.query::<(&S1, &Transform)>().iter(world) {
        if let Some(&(eruption, density)) = slices.get(&s1.slice) {
            parents.push(ParentSphere {
                id: s1.id,
                eruption,
                center: t.translation,
                radius: t.scale.x,
                rotation: t.rotation,
                density,
                umbrella: false,
                flow: false,
                cloud: false,
            });
        }
    }
    for (u, t) in world.query::<(&Umbrella, &Transform)>().iter(world) {
        if let Some(&eruption) = index.get(&u.volcano) {
            // The sphere has shed `1 − exp(−age/τ)` of its ash (the model's fallout law), which
            // the air's ash draws once coupled: drawn at the density it detached with, that
            // ash would be drawn twice.
            let kept = (-u.age / eruptions[eruption].2).exp();
            parents.push(ParentSphere {
                id: u.id,
                eruption,
                center: t.translation,
                radius: u.radius as f32,
                rotation: t.rotation,
                density: (u.density * kept) as f32,
                umbrella: true,
                flow: false,
                cloud: false,
            });
        }
    }
    let mut flows = Vec::new();
    for (p, t) in world.query::<(&PyroParticle, &Transform)>().iter(world) {
        if let Some(&eruption) = index.get(&p.volcano) {
            let (radius, density) = (p.particle.radius as f32, p.particle.density() as f32);
            parents.push(ParentSphere {
                id: p.id,
                eruption,
                center: t.translation,
                radius,
                rotation: Quat::IDENTITY,
                density,
                umbrella: false,
                flow: true,
                cloud: false,
            });
            flows.push(FlowSample {
                id: p.id,
                eruption,
                center: t.translation,
                radius,
                speed: p.particle.velocity.length() as f32,
                density,
                buoyant: p.buoyant,
                vent: p.vent,
            });
        }
    }
    if !flows.is_empty() {
        let settings = world.get_resource::<CurrentCloudSettings>().cloned().unwrap_or_default();
        // In the query's order: each cloud depends only on its particle and its sector's front
        // (a maximum), and the sort below orders them with the rest.
        if let Err(e) = current_clouds(&flows, &settings, &mut parents) {
            warn_once!("volcano: no clouds over pyroclastic currents: {e}");
        }
    }
    parents.sort_by_key(|p| (p.eruption, p.flow, p.cloud, p.umbrella, p.id));
    (eruptions.into_iter().map(|(_, v, _)| v).collect(), parents)
}

/// One sphere of any scale: `level` 1 for a parent, 2 or 3 for detail spheres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereRecord {
    /// Centre (world, m, y up).
    pub center: DVec3,
    /// Radius (m).
    pub radius: f64,
    /// Density of the material it stands for (kg/m³).
    pub density: f64,
    /// Scale: 1 (s1 or umbrella), 2, 3.
    pub level: u8,
}

/// Calls `f` on every parent followed by its detail spheres (export and tests; the renderer
/// uses [`build_instances`], which walks the same spheres).
pub fn for_each_sphere(
    eruptions: &[EruptionView],
    parents: &[ParentSphere],
    mut f: impl FnMut(SphereRecord),
) {
    for p in parents {
        let Some(e) = eruptions.get(p.eruption) else { continue };
        let center = p.center.as_dvec3();
        let density = p.density as f64;
        f(SphereRecord { center, radius: p.radius as f64, density, level: 1 });
        if p.flow || p.cloud {
            continue;
        }
        let rot = DQuat::from_xyzw(
            p.rotation.x as f64,
            p.rotation.y as f64,
            p.rotation.z as f64,
            p.rotation.w as f64,
        );
        for d in detail_spheres(&e.spheres, e.seed, p.id, center, p.radius as f64, rot) {
            f(SphereRecord { center: d.center, radius: d.radius, density, level: d.level });
        }
    }
}

/// One instance the ash renderer draws, as the CPU reference computes it (the shader's
/// `Expanded` in `volcano_render`'s `ash.wgsl` holds the same eight values).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AshInstance {
    /// Centre (world, m).
    pub center: [f32; 3],
    /// Radius (m).
    pub radius: f32,
    /// Screen-space rotation of the smoke texture (rad): the spin projected on the view axis.
    pub angle: f32,
    /// 0 = dense ash at the vent (dark) … 1 = diluted aloft (light).
    pub shade: f32,
    /// Fraction of the billboard the smoke covers (thinner aloft), in (0, 1].
    pub coverage: f32,
    /// `0 ≤ k < 1`: detail-sphere impostor; `1 ≤ k < 2`: smoke billboard. The fractional part
    /// picks the texture variant.
    pub kind: f32,
}

/// Density shading: 0 at the vent density ρ₀, 1 at [`DILUTE_DENSITY`], on a log scale (the
/// mixture thins by three orders of magnitude on its way up).
pub fn shade_for(density: f32, rho0: f32) -> f32 {
    let hi = rho0.max(DILUTE_DENSITY * 1.01);
    let t = (hi / density.max(1e-6)).ln() / (hi / DILUTE_DENSITY).ln();
    if t.is_finite() { t.clamp(0.0, 1.0) } else { 1.0 }
}

/// Density (kg/m³) rendered as fully diluted ash (below the air density at 15 km, so even the
/// umbrella keeps some tint).
pub const DILUTE_DENSITY: f32 = 0.05;

/// What the renderer draws (a [`Resource`], editable live through reflection).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct PlumeViewSettings {
    /// Whether instances are produced at all (off: an empty list, nothing drawn).
    pub enabled: bool,
    /// Smoke billboards for s1 and umbrella spheres.
    pub billboards: bool,
    /// Detail-sphere impostors (s2/s3).
    pub detail: bool,
    /// Upper bound on instances per frame (detail spheres beyond it are skipped, evenly).
    pub max_instances: u32,
    /// Billboard size relative to the sphere radius (puffs overlap their neighbours).
    pub billboard_scale: f32,
}

impl Default for PlumeViewSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            billboards: true,
            detail: true,
            max_instances: 1_500_000,
            billboard_scale: 1.35,
        }
    }
}

/// Where the viewer is (world), for the projected spin; `None` projects on +z.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct PlumeViewpoint(pub Option<Vec3>);

/// A frame's instances built on the CPU by [`update_instances`] (the reference path).
#[derive(Resource, Debug, Clone, Default)]
pub struct PlumeInstances(pub Arc<Vec<AshInstance>>);

/// Builds the frame's instances: for each parent a smoke billboard, then its first detail
/// spheres (children are placed by hash, so any prefix is an even sample of the parent's
/// surface). Fewer are kept where the ash is diluted (thinner aloft) and when the total would
/// pass `max_instances`. Parent spin is projected on the viewing direction: a sphere turning
/// about an axis `a` by angle `θ` turns its billboard by `θ (a · v̂)`, `v̂` toward the viewer.
///
/// The counts are planned first, so every parent owns a fixed range of `out` and the ranges
/// are filled in parallel (`volcano_core::parallel`) with the same result on any number of
/// threads.
/// `out` is reused: only growth is initialised, every kept slot is overwritten.
pub fn build_instances(
    settings: &PlumeViewSettings,
    viewpoint: Option<Vec3>,
    eruptions: &[EruptionView],
    parents: &[ParentSphere],
    out: &mut Vec<AshInstance>,
) {
    if !settings.enabled {
        out.clear();
        return;
    }
    let plan = plan_instances(settings, eruptions, parents);
    let total = plan.last().map_or(0, |p| p.offset + p.count());
    if out.len() > total {
        out.truncate(total);
    } else {
        out.resize(total, AshInstance::default());
    }
    // Fixed chunking: the result does not depend on the number of threads.
    const CHUNK: usize = 256;
    let mut items = Vec::with_capacity(parents.len().div_ceil(CHUNK));
    let mut rest: &mut [AshInstance] = out.as_mut_slice();
    for (parents, plan) in parents.chunks(CHUNK).zip(plan.chunks(CHUNK)) {
        let len: usize = plan.iter().map(Plan::count).sum();
        let (mine, tail) = std::mem::take(&mut rest).split_at_mut(len);
        rest = tail;
        items.push((parents, plan, mine));
    }
    volcano_core::parallel::par_map(items, |_, (parents, plan, mine)| {
        let mut slots = mine.iter_mut();
        for (p, plan) in parents.iter().zip(plan) {
            fill_parent(settings, viewpoint, eruptions, p, plan, &mut slots);
        }
    });
}

/// How many instances one parent gets and where they start.
#[derive(Debug, Clone, Copy)]
struct Plan {
    offset: usize,
    billboard: bool,
    detail: usize,
    shade: f32,
    coverage: f32,
}

impl Plan {
    fn count(&self) -> usize {
        self.billboard as usize + self.detail
    }
}

fn plan_instances(
    settings: &PlumeViewSettings,
    eruptions: &[EruptionView],
    parents: &[ParentSphere],
) -> Vec<Plan> {
    let max = settings.max_instances as usize;
    let children = |e: &EruptionView| e.spheres.s2_per_s1 as usize * (1 + e.spheres.s3_per_s2 as usize);
    let detail_total: usize = if settings.detail {
        parents
            .iter()
            .filter(|p| !p.flow && !p.cloud)
            .filter_map(|p| eruptions.get(p.eruption))
            .map(children)
            .sum()
    } else {
        0
    };
    let room = max.saturating_sub(if settings.billboards { parents.len() } else { 0 });
    let budget = if detail_total == 0 { 1.0 } else { (room as f64 / detail_total as f64).min(1.0) };
    let mut offset = 0;
    parents
        .iter()
        .map(|p| {
            let valid = p.center.is_finite() && p.radius.is_finite() && p.radius > 0.0;
            let e = eruptions.get(p.eruption).filter(|_| valid);
            let shade = e.map_or(1.0, |e| shade_for(p.density, e.rho0));
            let coverage = 1.0 - 0.45 * shade;
            let mut billboard = e.is_some() && settings.billboards;
            let mut detail = match e {
                Some(e) if settings.detail && !p.flow && !p.cloud => {
                    (children(e) as f64 * budget * coverage as f64) as usize
                }
                _ => 0,
            };
            // Never pass the cap, whatever the rounding.
            let left = max.saturating_sub(offset);
            billboard &= left > 0;
            detail = detail.min(left - billboard as usize);
            let plan = Plan { offset, billboard, detail, shade, coverage };
            offset += plan.count();
            plan
        })
        .collect()
}

fn fill_parent<'a>(
    settings: &PlumeViewSettings,
    viewpoint: Option<Vec3>,
    eruptions: &[EruptionView],
    p: &ParentSphere,
    plan: &Plan,
    slots: &mut impl Iterator<Item = &'a mut AshInstance>,
) {
    let Some(e) = eruptions.get(p.eruption) else { return };
    let (angle, variant) = billboard_look(p, viewpoint);
    let (shade, coverage) = (plan.shade, plan.coverage);
    if plan.billboard
        && let Some(slot) = slots.next()
    {
        *slot = AshInstance {
            center: p.center.to_array(),
            radius: p.radius * settings.billboard_scale,
            angle,
            shade,
            coverage,
            kind: 1.0 + variant,
        };
    }
    if plan.detail == 0 {
        return;
    }
    let rot =
        DQuat::from_xyzw(p.rotation.x as f64, p.rotation.y as f64, p.rotation.z as f64, p.rotation.w as f64);
    let spheres = detail_spheres(&e.spheres, e.seed, p.id, p.center.as_dvec3(), p.radius as f64, rot);
    for (d, slot) in spheres.take(plan.detail).zip(slots) {
        *slot = AshInstance {
            center: d.center.as_vec3().to_array(),
            radius: d.radius as f32,
            angle: 0.0,
            shade: (shade + 0.08 * (d.level as f32 - 1.0)).min(1.0),
            coverage,
            kind: variant,
        };
    }
}

/// A parent's billboard rotation (rad) and texture variant in [0, 1): s1 spheres turn their
/// texture by the spin projected on the viewing direction, umbrella and pyroclastic puffs by a
/// fixed angle from the variant.
fn billboard_look(p: &ParentSphere, viewpoint: Option<Vec3>) -> (f32, f32) {
    let variant = (mix32(p.id) & 0xffff) as f32 / 65_536.0;
    if p.umbrella || p.flow || p.cloud {
        return (variant * std::f32::consts::TAU, variant);
    }
    let (axis, theta) = p.rotation.to_axis_angle();
    let toward = match viewpoint {
        Some(v) => (v - p.center).normalize_or(Vec3::Z),
        None => Vec3::Z,
    };
    (theta * axis.dot(toward), variant)
}

/// A cheap 32-bit hash of a 64-bit key (Murmur3 finaliser on the folded key); written by hand
/// because it is a two-line mixing step, not worth a dependency.
fn mix32(key: u64) -> u32 {
    let mut h = (key ^ (key >> 32)) as u32;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// Gathers the spheres and rebuilds [`PlumeInstances`] on the CPU (reusing the previous
/// allocation when nothing else holds it): the reference path, scheduled by nobody (the
/// renderer expands the parents of [`plan_parents`] on the GPU); the benchmark compares the
/// two.
pub fn update_instances(world: &mut World) {
    let (eruptions, parents) = gather_parents(world);
    let settings = world.get_resource_or_init::<PlumeViewSettings>().clone();
    let viewpoint = world.get_resource_or_init::<PlumeViewpoint>().0;
    let mut shared = std::mem::take(&mut world.get_resource_or_init::<PlumeInstances>().0);
    let mut list = match Arc::get_mut(&mut shared) {
        Some(v) => std::mem::take(v),
        None => Vec::new(),
    };
    build_instances(&settings, viewpoint, &eruptions, &parents, &mut list);
    world.resource_mut::<PlumeInstances>().0 = Arc::new(list);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parent(id: u64, density: f32, umbrella: bool) -> ParentSphere {
        ParentSphere {
            id,
            eruption: 0,
            center: Vec3::new(0.0, 1000.0 + id as f32, 0.0),
            radius: 50.0,
            rotation: Quat::from_axis_angle(Vec3::X, 0.8),
            density,
            umbrella,
            flow: false,
            cloud: false,
        }
    }

    fn view(s2: u32) -> Vec<EruptionView> {
        vec![EruptionView {
            entity: Entity::PLACEHOLDER,
            seed: 3,
            spheres: SphereParams { s2_per_s1: s2, ..Default::default() },
            rho0: 200.0,
            vent: Vec3::ZERO,
        }]
    }

    #[test]
    fn shade_is_dark_at_the_vent_and_light_aloft() {
        assert_eq!(shade_for(200.0, 200.0), 0.0);
        assert_eq!(shade_for(DILUTE_DENSITY, 200.0), 1.0);
        let mid = shade_for(3.0, 200.0);
        assert!(mid > 0.3 && mid < 0.7, "{mid}");
        assert!(shade_for(f32::NAN, 200.0).is_finite());
        assert_eq!(shade_for(0.0, 200.0), 1.0);
    }

    #[test]
    fn instance_counts_follow_settings_and_budget() {
        let parents: Vec<_> = (0..10).map(|i| parent(i, 200.0, false)).collect();
        let e = view(100);
        let mut out = Vec::new();
        let all = PlumeViewSettings { max_instances: u32::MAX, ..Default::default() };
        build_instances(&all, None, &e, &parents, &mut out);
        // Dense ash (shade 0): every detail sphere is kept.
        assert_eq!(out.len(), 10 + 10 * 100);
        assert_eq!(out.iter().filter(|i| i.kind >= 1.0).count(), 10);
        let capped = PlumeViewSettings { max_instances: 500, ..Default::default() };
        build_instances(&capped, None, &e, &parents, &mut out);
        assert!(out.len() <= 500 && out.len() > 350, "budget spreads evenly: {}", out.len());
        let spread: std::collections::HashSet<u32> =
            out.iter().filter(|i| i.kind < 1.0).map(|i| (i.center[1] / 1.0) as u32).collect();
        assert!(spread.len() > 5, "detail kept for many parents, not just the first");
        let none = PlumeViewSettings { detail: false, ..Default::default() };
        build_instances(&none, None, &e, &parents, &mut out);
        assert_eq!(out.len(), 10);
    }

    #[test]
    fn dilute_ash_is_lighter_and_thinner() {
        let e = view(200);
        let mut dense = Vec::new();
        let mut dilute = Vec::new();
        let s = PlumeViewSettings::default();
        build_instances(&s, None, &e, &[parent(1, 150.0, false)], &mut dense);
        build_instances(&s, None, &e, &[parent(1, 0.1, false)], &mut dilute);
        assert!(dilute.len() < dense.len() * 3 / 4, "{} vs {}", dilute.len(), dense.len());
        assert!(dilute[0].shade > dense[0].shade + 0.5);
        assert!(dilute[0].coverage < dense[0].coverage);
    }

    #[test]
    fn billboard_turns_with_the_projected_spin() {
        let e = view(0);
        let s = PlumeViewSettings::default();
        let mut out = Vec::new();
        // Spin axis x, angle 0.8: seen along the axis the billboard turns by the full angle,
        // seen from the side (along z) not at all.
        let p = parent(5, 100.0, false);
        build_instances(&s, Some(p.center + Vec3::X * 1000.0), &e, &[p], &mut out);
        assert!((out[0].angle - 0.8).abs() < 1e-4, "{}", out[0].angle);
        build_instances(&s, Some(p.center + Vec3::Z * 1000.0), &e, &[p], &mut out);
        assert!(out[0].angle.abs() < 1e-4, "{}", out[0].angle);
    }

    #[test]
    fn enumeration_matches_instances_and_is_deterministic() {
        let e = view(20);
        let parents: Vec<_> = (0..4).map(|i| parent(i, 200.0, i % 2 == 0)).collect();
        let mut a = Vec::new();
        for_each_sphere(&e, &parents, |s| a.push(s));
        let mut b = Vec::new();
        for_each_sphere(&e, &parents, |s| b.push(s));
        assert_eq!(a, b);
        assert_eq!(a.len(), 4 * 21);
        let mut inst = Vec::new();
        let s = PlumeViewSettings { billboard_scale: 1.0, max_instances: u32::MAX, ..Default::default() };
        build_instances(&s, None, &e, &parents, &mut inst);
        assert_eq!(inst.len(), a.len());
        for (r, i) in a.iter().zip(&inst) {
            assert!((r.center.as_vec3() - Vec3::from_array(i.center)).length() < 1e-3);
            assert!((r.radius as f32 - i.radius).abs() < 1e-4);
        }
    }

    #[test]
    fn parallel_chunks_match_the_sequential_enumeration() {
        // 700 parents: three chunks filled by different tasks.
        let e = view(7);
        let parents: Vec<_> = (0..700).map(|i| parent(i, 200.0, i % 3 == 0)).collect();
        let mut seq = Vec::new();
        for_each_sphere(&e, &parents, |s| seq.push(s));
        let s = PlumeViewSettings { billboard_scale: 1.0, max_instances: u32::MAX, ..Default::default() };
        let mut inst = vec![AshInstance::default(); 10]; // reused buffer with stale content
        build_instances(&s, None, &e, &parents, &mut inst);
        assert_eq!(inst.len(), seq.len());
        for (r, i) in seq.iter().zip(&inst) {
            assert_eq!(r.center.as_vec3().to_array(), i.center);
            assert_eq!(r.radius as f32, i.radius);
        }
    }
}
