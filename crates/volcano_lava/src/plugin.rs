//! [`LavaPlugin`]: the lava domain (`LavaStep`, `Substeps(1)` = 0.02 s per step, thesis
//! Table 5.2, with CFL substeps inside the model). Systems gather, call the model, write back.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_core::terrain::{NodeRegion, TerrainChanged};

use crate::components::*;
use crate::model::breakout::BreakoutState;
use crate::model::field::{FlowField, Placement, Source};
use crate::model::folds::FoldSystem;
use crate::model::imprint::TerrainImprint;
use crate::model::surface::SurfaceState;
use crate::model::{DomainReport, step_layers};

/// Schedule of the lava domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default, TypePath)]
pub struct LavaStep;

/// Pahoehoe lava fields, sources, marked zones and messages.
#[derive(Debug, Default, Clone)]
pub struct LavaPlugin;

impl Plugin for LavaPlugin {
    fn build(&self, app: &mut App) {
        app.add_sim_domain::<LavaStep>(SimSystems::Lava, Cadence::Substeps(1))
            .add_message::<LavaReached>()
            .add_message::<LavaBreakout>()
            .add_message::<crate::vents::LavaVentOpened>()
            .add_message::<crate::vents::LavaFlowFront>()
            .add_message::<crate::vents::LavaFlowStopped>()
            .init_resource::<crate::vents::VentLavaSettings>()
            .register_type::<crate::vents::LavaVent>()
            .register_type::<crate::vents::LavaVentStatus>()
            .register_type::<crate::vents::TerrainLava>()
            .register_type::<crate::vents::VentLavaSettings>()
            .register_type::<crate::vents::FrontTrack>()
            .register_type::<crate::fountains::LavaFountain>()
            .register_type::<crate::fountains::LavaFountainState>()
            .register_type::<AirHeatSources>()
            // Owned by volcano_core, like `TerrainChanged`.
            .add_message::<SimFault>()
            // Owned by volcano_core; registering twice is harmless.
            .add_message::<TerrainChanged>()
            .register_type::<LavaField>()
            .register_type::<LavaFieldStatus>()
            .register_type::<LavaSource>()
            .register_type::<LavaSourceStatus>()
            .register_type::<LavaZone>()
            .register_type::<LavaState>()
            .register_type::<BuiltFor>()
            .add_systems(
                LavaStep,
                (
                    build_fields,
                    step_fields,
                    crate::vents::step_vent_lava,
                    crate::fountains::step_fountains,
                    check_zones,
                    imprint_terrain,
                )
                    .chain(),
            )
            // Patches spawned with the scene are built while it loads, not on its first tick
            // (a 256² patch takes ≈ 6 ms to resample its terrain and allocate its layers,
            // release); patches spawned later are built on their first lava step.
            .add_systems(PostStartup, build_fields);
    }
}

/// Grid placement a [`LavaState`] was built for and the terrain under it; a change (or a
/// terrain appearing under a field built on flat ground) rebuilds the field (its lava is lost).
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[reflect(opaque)]
#[reflect(Component)]
struct BuiltFor(crate::model::field::Placement, crate::model::field::Edges, #[entities] Option<Entity>);

/// The terrain a field at `placement` belongs on: the one it was built on while that still
/// contains it, else the finest terrain (smallest cell, then lowest entity index) whose grid
/// contains the whole patch. `Ok(None)` when the world has no terrain (flat ground); an error
/// when no terrain contains the patch.
fn terrain_under(
    terrains: &Query<(Entity, &Terrain)>,
    placement: &Placement,
    built_on: Option<Entity>,
) -> Result<Option<Entity>, ConfigError> {
    if terrains.is_empty() {
        return Ok(None);
    }
    let origin = placement.origin();
    let far =
        origin + Vec2::new((placement.nx - 1) as f32, (placement.ny - 1) as f32) * placement.cell as f32;
    let holds = |t: &Terrain| t.contains(origin.x, origin.y) && t.contains(far.x, far.y);
    if let Some(e) = built_on
        && terrains.get(e).is_ok_and(|(_, t)| holds(t))
    {
        return Ok(Some(e));
    }
    let finest = terrains.iter().filter(|(_, t)| holds(t)).min_by(|(a, s), (b, t)| {
        s.heights().cell().total_cmp(&t.heights().cell()).then(a.index_u32().cmp(&b.index_u32()))
    });
    finest.map(|(e, _)| Some(e)).ok_or_else(|| ConfigError::InvalidParameter {
        name: "lava field placement",
        value: placement.centre.x as f64,
        reason: format!("no terrain contains the whole grid [{origin}, {far}]"),
    })
}

/// A field: its entity, the field, its `Transform` if any, what it was built for, its state.
type FieldItem = (
    Entity,
    &'static LavaField,
    Option<&'static Transform>,
    Option<&'static BuiltFor>,
    Option<&'static mut LavaState>,
);

fn build_fields(mut commands: Commands, terrains: Query<(Entity, &Terrain)>, mut fields: Query<FieldItem>) {
    for (entity, field, transform, built, state) in &mut fields {
        let p = field_placement(field, transform);
        // Its terrain despawned under a built patch that has not moved: the patch keeps its lava
        // and its ground (the terrain's shape), and stops writing back.
        if let (Some(BuiltFor(at, edges, Some(terrain))), Some(mut state)) = (built, state)
            && *at == p
            && *edges == field.edges
            && terrains.get(*terrain).is_err()
        {
            if let Some(link) = state.imprint.as_mut().filter(|l| l.detached.is_none()) {
                warn!(
                    "lava field {entity}: its terrain {terrain} was despawned; the lava flows on in the field's own ground and no longer writes back"
                );
                link.detached = Some("the terrain was despawned".into());
            }
            continue;
        }
        let under = p.validate().and_then(|_| terrain_under(&terrains, &p, built.and_then(|b| b.2)));
        let key = BuiltFor(p, field.edges, under.as_ref().ok().copied().flatten());
        // Built (or rejected) for this placement and terrain already: nothing to do.
        if built == Some(&key) {
            continue;
        }
        let result = under.and_then(|under| match under.and_then(|e| terrains.get(e).ok()) {
            Some((e, t)) => FlowField::on_terrain(t, p, field.edges).map(|flow| {
                let imprint =
                    TerrainLink { terrain: e, imprint: TerrainImprint::new(t, &flow), detached: None };
                (flow, Some(imprint))
            }),
            None => {
                let g = Grid2::new(p.nx, p.ny, p.cell, p.origin(), 0.0)?;
                Ok((FlowField::new(g, field.edges, field.params.air_temperature)?, None))
            }
        });
        warn_ignored_parts(entity, transform);
        let mut e = commands.entity(entity);
        match result {
            Ok((flow, imprint)) => {
                let surface = SurfaceState::new(flow.nx(), flow.ny());
                e.insert((
                    LavaState {
                        surface,
                        folds: FoldSystem::new(field.seed),
                        breakouts: BreakoutState::new(flow.nx() * flow.ny()),
                        flow,
                        last_substeps: 0,
                        mobility_capped: false,
                        folds_at_cap: false,
                        imprint,
                    },
                    LavaFieldStatus::Ok,
                    key,
                ));
            }
            Err(err) => {
                e.remove::<LavaState>().insert((LavaFieldStatus::Rejected(err.to_string()), key));
            }
        }
    }
}

/// Warns that a lava field's `Transform` has a rotation or scale, which a grid lying on the
/// ground cannot take (its translation's y is ignored without a word: the ground sets it).
fn warn_ignored_parts(entity: Entity, transform: Option<&Transform>) {
    let ignored: Vec<_> = transform
        .map(volcano_core::terrain::ignored_transform_parts)
        .unwrap_or_default()
        .into_iter()
        .filter(|p| *p != "y translation")
        .collect();
    if !ignored.is_empty() {
        warn!(
            "lava field {entity}: a grid on the ground cannot take its Transform's {} (only the x \
             and z translation place it)",
            ignored.join(", ")
        );
    }
}

/// A source: its entity, the source, its `Transform` if any, its last status.
type SourceItem =
    (Entity, &'static LavaSource, Option<&'static Transform>, Option<&'static LavaSourceStatus>);

fn step_fields(
    time: Res<Time>,
    mut commands: Commands,
    mut fields: Query<(Entity, &LavaField, &mut LavaState)>,
    sources: Query<SourceItem>,
    mut breakouts: MessageWriter<LavaBreakout>,
    mut faults: MessageWriter<SimFault>,
) {
    let dt = time.delta_secs_f64();
    // Gather: each source feeds the first field whose grid contains it.
    let mut feeds: Vec<(Entity, Source)> = Vec::new();
    for (entity, src, transform, status) in &sources {
        let new_status = match src.validate() {
            Err(e) => LavaSourceStatus::Rejected(e.to_string()),
            Ok(()) => {
                let xz = src.world_xz(transform);
                let found = fields.iter().find(|(_, _, s)| s.flow.cell_at(xz).is_some());
                match found {
                    None => LavaSourceStatus::Rejected(format!("({}, {}) is on no lava field", xz.x, xz.y)),
                    Some((fe, _, state)) => {
                        match state.flow.point_source(xz, src.radius, src.rate, src.temperature) {
                            Ok(s) => {
                                feeds.push((fe, s));
                                LavaSourceStatus::Active(fe)
                            }
                            Err(e) => LavaSourceStatus::Rejected(e.to_string()),
                        }
                    }
                }
            }
        };
        if status != Some(&new_status) {
            commands.entity(entity).insert(new_status);
        }
    }
    // Call the model.
    for (entity, field, mut state) in &mut fields {
        if field.params.validate().is_err() || field.folds.validate().is_err() {
            continue; // an invalid live edit freezes the field until fixed
        }
        let srcs: Vec<Source> = feeds.iter().filter(|(f, _)| *f == entity).map(|(_, s)| s.clone()).collect();
        let state = &mut *state;
        let DomainReport { flow: report, breakouts: tears, repaired, folds_at_cap } =
            step_layers(state.layers_mut(), &field.params, &field.folds, &srcs, dt);
        if repaired.any() {
            let fault = SimFault {
                lost_lava_m3: repaired.lost_m3,
                ..SimFault::new(entity, SimDomain::Lava, repaired.cells + repaired.particles)
            };
            fault.warn();
            faults.write(fault);
        }
        for tear in tears {
            let ground = state.flow.ground().data()[tear.cell] + state.flow.thickness().data()[tear.cell];
            breakouts.write(LavaBreakout {
                field: entity,
                position: Vec3::new(tear.position.x, ground as f32, tear.position.y),
            });
        }
        state.last_substeps = report.substeps;
        state.mobility_capped = report.mobility_capped;
        if folds_at_cap && !state.folds_at_cap {
            warn!(
                "lava field {entity}: {} fold particles, FoldParams::max_particles; no new folds until \
                 some are buried (LavaState::folds_at_cap)",
                state.folds.particles.len()
            );
        }
        state.folds_at_cap = folds_at_cap;
    }
}

/// When frozen lava is written into the terrain: once per simulated second of the lava clock,
/// at half past each second ([`IMPRINT_OFFSET`]).
pub const IMPRINT_PERIOD: std::time::Duration = std::time::Duration::from_secs(1);
/// Half a second: the write-back never falls on the base tick of the once-per-second weather
/// step (started and applied on whole seconds), so the two costs do not add up on one tick
/// (the frame-budget target: weather ticks ≤ 1.5 × the others).
pub const IMPRINT_OFFSET: std::time::Duration = std::time::Duration::from_millis(500);

/// Writes each field's new frozen lava into the terrain it was built on once per
/// [`IMPRINT_PERIOD`] of the lava clock at [`IMPRINT_OFFSET`], whatever the fixed rate (fields
/// in entity order), and one [`TerrainChanged`] per terrain whose heights moved. The terrain's
/// change detection is bypassed: readers of `Changed<Terrain>` would otherwise redo the whole
/// terrain each second for a few nodes.
fn imprint_terrain(
    time: Res<Time>,
    mut terrains: Query<&mut Terrain>,
    mut fields: Query<(Entity, &mut LavaState)>,
    mut changed: MessageWriter<TerrainChanged>,
) {
    if volcano_core::clock::crossings(time.elapsed(), time.delta(), IMPRINT_PERIOD, IMPRINT_OFFSET) == 0 {
        return;
    }
    let mut order: Vec<Entity> = fields.iter().map(|(e, _)| e).collect();
    order.sort_unstable();
    let mut moved: Vec<(Entity, NodeRegion)> = Vec::new();
    for field in order {
        let Ok((_, mut state)) = fields.get_mut(field) else { continue };
        let state = &mut *state;
        let Some(link) = state.imprint.as_mut().filter(|l| l.detached.is_none()) else { continue };
        let result = match terrains.get_mut(link.terrain) {
            Ok(mut t) => link.imprint.apply(t.bypass_change_detection(), &state.flow),
            Err(_) => Err(ConfigError::InvalidParameter {
                name: "terrain under a lava field",
                value: 0.0,
                reason: "despawned".into(),
            }),
        };
        match result {
            Ok(region) if region.is_empty() => {}
            Ok(region) => match moved.iter_mut().find(|(t, _)| *t == link.terrain) {
                Some((_, r)) => *r = r.union(region),
                None => moved.push((link.terrain, region)),
            },
            // The field keeps flowing on its own ground; its frozen lava stays in it.
            Err(e) => {
                warn!(
                    "lava field {field}: no longer writes its frozen lava into terrain {}: {e}",
                    link.terrain
                );
                link.detached = Some(e.to_string());
            }
        }
    }
    for (terrain, region) in moved {
        changed.write(TerrainChanged { terrain, region });
    }
}

fn check_zones(
    mut zones: Query<(Entity, &mut LavaZone, Option<&Transform>)>,
    fields: Query<(Entity, &LavaField, &LavaState)>,
    vent_lava: Query<(Entity, &crate::vents::TerrainLava)>,
    vent_settings: Res<crate::vents::VentLavaSettings>,
    mut reached: MessageWriter<LavaReached>,
) {
    for (zone_entity, mut zone, transform) in &mut zones {
        if zone.reached {
            continue;
        }
        let centre = zone.world_centre(transform);
        for (field_entity, field, state) in &fields {
            if covered(&state.flow, centre, zone.radius, field.params.min_thickness) {
                zone.reached = true;
                reached.write(LavaReached { entity: zone_entity, field: field_entity });
                break;
            }
        }
        if zone.reached {
            continue;
        }
        let min_h = vent_settings.params.min_thickness;
        for (terrain, lava) in &vent_lava {
            if lava.runout.covered(centre.as_dvec2(), zone.radius as f64, min_h) {
                zone.reached = true;
                reached.write(LavaReached { entity: zone_entity, field: terrain });
                break;
            }
        }
    }
}

/// Whether any cell within `radius` of `centre` holds lava thicker than `min_h`.
fn covered(flow: &FlowField, centre: Vec2, radius: f32, min_h: f64) -> bool {
    let (nx, ny) = (flow.nx(), flow.ny());
    let h = flow.thickness();
    let (gx, gy) = h.to_grid(centre);
    let r = radius as f64 / flow.cell();
    let (i0, i1) = ((gx - r).floor().max(0.0), (gx + r).ceil().min(nx as f64 - 1.0));
    let (j0, j1) = ((gy - r).floor().max(0.0), (gy + r).ceil().min(ny as f64 - 1.0));
    if i0 > i1 || j0 > j1 {
        return false;
    }
    for j in j0 as usize..=j1 as usize {
        for i in i0 as usize..=i1 as usize {
            if h.position(i, j).distance(centre) <= radius && h.get(i, j) > min_h {
                return true;
            }
        }
    }
    false
}
