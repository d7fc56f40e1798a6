//! [`LavaPlugin`]: the lava domain (`LavaStep`, `Substeps(1)` = 0.02 s per step, thesis
//! Table 5.2, with CFL substeps inside the model). Systems gather, call the model, write back.

use bevy::ecs::schedule::ScheduleLabel;
use bevy::prelude::*;
use volcano_core::prelude::*;

use crate::components::*;
use crate::model::breakout::{BreakoutState, update_breakouts};
use crate::model::field::{FlowField, Source};
use crate::model::folds::{FoldSystem, thicken_crust_under_folds, update_folds};
use crate::model::imprint::TerrainImprint;
use crate::model::surface::{SurfaceState, update_surface};

/// Schedule of the lava domain.
#[derive(ScheduleLabel, Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct LavaStep;

/// Pahoehoe lava fields, sources, marked zones and messages.
#[derive(Debug, Default, Clone)]
pub struct LavaPlugin;

impl Plugin for LavaPlugin {
    fn build(&self, app: &mut App) {
        app.add_sim_domain::<LavaStep>(SimSystems::Lava, Cadence::Substeps(1))
            .add_message::<LavaReached>()
            .add_message::<LavaBreakout>()
            .register_type::<LavaField>()
            .register_type::<LavaFieldStatus>()
            .register_type::<LavaSource>()
            .register_type::<LavaSourceStatus>()
            .register_type::<LavaZone>()
            .add_systems(LavaStep, (build_fields, step_fields, check_zones, imprint_terrain).chain());
        #[cfg(debug_assertions)]
        app.add_systems(PostUpdate, assert_finite_fields);
    }
}

/// Grid placement a [`LavaState`] was built for, and whether a terrain existed then; a
/// change (or a terrain appearing under a field built on flat ground) rebuilds the field
/// (its lava is lost).
#[derive(Component, Debug, Clone, PartialEq)]
struct BuiltFor(crate::model::field::Placement, crate::model::field::Edges, bool);

fn build_fields(
    mut commands: Commands,
    terrains: Query<&Terrain>,
    fields: Query<(Entity, &LavaField, Option<&BuiltFor>)>,
) {
    for (entity, field, built) in &fields {
        // Built (or rejected) for this placement already: nothing to do.
        let key = BuiltFor(field.placement, field.edges, !terrains.is_empty());
        if built == Some(&key) {
            continue;
        }
        let result = match terrains.iter().next() {
            Some(t) => FlowField::on_terrain(t, field.placement, field.edges),
            None => field.placement.validate().and_then(|_| {
                let p = field.placement;
                let g = Grid2::new(p.nx, p.ny, p.cell, p.origin(), 0.0)?;
                FlowField::new(g, field.edges, field.params.air_temperature)
            }),
        };
        let mut e = commands.entity(entity);
        match result {
            Ok(flow) => {
                let surface = SurfaceState::new(flow.nx(), flow.ny());
                let imprint = terrains.iter().next().map(|t| TerrainImprint::new(t.heights(), &flow));
                e.insert((
                    LavaState {
                        surface,
                        folds: FoldSystem::new(field.seed),
                        breakouts: BreakoutState::new(flow.nx() * flow.ny()),
                        flow,
                        last_substeps: 0,
                        mobility_capped: false,
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

fn step_fields(
    time: Res<Time>,
    mut commands: Commands,
    mut fields: Query<(Entity, &LavaField, &mut LavaState)>,
    sources: Query<(Entity, &LavaSource, Option<&LavaSourceStatus>)>,
    mut breakouts: MessageWriter<LavaBreakout>,
) {
    let dt = time.delta_secs_f64();
    // Gather: each source feeds the first field whose grid contains it.
    let mut feeds: Vec<(Entity, Source)> = Vec::new();
    for (entity, src, status) in &sources {
        let new_status = match src.validate() {
            Err(e) => LavaSourceStatus::Rejected(e.to_string()),
            Ok(()) => {
                let xz = Vec2::new(src.position.x, src.position.z);
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
        let report =
            crate::model::step_under_crust(&mut state.flow, &field.params, &srcs, &state.surface.crust, dt);
        update_surface(&mut state.surface, &state.flow, &field.params, dt);
        for tear in update_breakouts(&mut state.breakouts, &mut state.flow, &mut state.surface, &field.params)
        {
            let ground = state.flow.ground().data()[tear.cell] + state.flow.thickness().data()[tear.cell];
            breakouts.write(LavaBreakout {
                field: entity,
                position: Vec3::new(tear.position.x, ground as f32, tear.position.y),
            });
        }
        update_folds(&mut state.folds, &state.flow, &state.surface, &field.params, &field.folds, dt);
        thicken_crust_under_folds(&state.folds, &state.flow, &mut state.surface, &field.params, &field.folds);
        state.last_substeps = report.substeps;
        state.mobility_capped = report.mobility_capped;
    }
}

/// Writes each field's frozen lava into the first `Terrain` (the one the fields are built
/// on) once per simulated second of the lava clock, whatever the fixed rate; the terrain is
/// marked changed only when a node moved by at least 1 mm.
fn imprint_terrain(time: Res<Time>, mut terrains: Query<&mut Terrain>, mut fields: Query<&mut LavaState>) {
    if !volcano_core::clock::crossed_period(time.elapsed(), time.delta(), std::time::Duration::from_secs(1)) {
        return;
    }
    let Some(mut terrain) = terrains.iter_mut().next() else { return };
    let mut changed = 0;
    for mut state in &mut fields {
        let state = &mut *state;
        if let Some(imprint) = &mut state.imprint {
            changed += imprint.apply(terrain.bypass_change_detection().heights_mut(), &state.flow, 1e-3);
        }
    }
    if changed > 0 {
        terrain.set_changed();
    }
}

fn check_zones(
    mut zones: Query<(Entity, &mut LavaZone)>,
    fields: Query<(Entity, &LavaField, &LavaState)>,
    mut reached: MessageWriter<LavaReached>,
) {
    for (zone_entity, mut zone) in &mut zones {
        if zone.reached {
            continue;
        }
        for (field_entity, field, state) in &fields {
            if covered(&state.flow, zone.centre, zone.radius, field.params.min_thickness) {
                zone.reached = true;
                reached.write(LavaReached { entity: zone_entity, field: field_entity });
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

/// Debug builds: every lava state stays finite with non-negative thickness.
#[cfg(debug_assertions)]
fn assert_finite_fields(fields: Query<(Entity, &LavaState)>) {
    for (entity, state) in &fields {
        assert!(state.flow.is_valid(), "lava field {entity} has a non-finite or negative value");
        assert!(
            state.surface.crust.iter().all(|c| c.is_finite() && *c >= 0.0),
            "lava field {entity} has a bad crust value"
        );
        assert!(state.folds.particles.iter().all(|p| p.pos.is_finite()), "lava field {entity}: fold NaN");
    }
}
