//! [`CouplingPlugin`]: the plume ↔ atmosphere transfers around each weather step (thesis
//! §4.3.3). Plume → air runs in `SimSystems::BeforeWeather` on the ticks where the weather is
//! about to step, after the atmosphere has written back the step started one weather step
//! earlier (`WeatherSystems::Apply`), so it writes into the state the next step starts from;
//! air → plume and the ash deposit run in `SimSystems::AfterWeather` on the ticks where the
//! weather stepped and read that written-back result (the lag: docs/ARCHITECTURE.md §3.3).
//! Systems gather slices, spheres and layers, call the coupling's two steps
//! ([`crate::model::step`]), write back.

use bevy::ecs::entity::MapEntities;
use bevy::math::{DVec2, DVec3};
use bevy::prelude::*;
use volcano_atmosphere::model::fields::{GridSpec, LayerFields};
use volcano_atmosphere::plugin::AtmosphereGround;
use volcano_atmosphere::{
    AirLayer, Atmosphere, WeatherStep, WeatherStepped, WeatherSystems, atmosphere_fields,
};
use volcano_core::prelude::*;
use volcano_plume::{
    AshReleased, DepositMap, Eruption, LayeredAmbient, PlumeAmbient, PlumeAshBudget, PlumeSlice, Umbrella,
};

pub use crate::model::books::CouplingBudget;
use crate::model::column::ColumnSlice;
use crate::model::heat::GroundSource;
use crate::model::inject::cell_at;
use crate::model::step::{AirReadSide, AirSide, AmbientRequest, AshParcel, CoupledColumn, GroundHeat};

/// Public sets of the coupling, so games can order their own systems against the transfers.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CouplingSystems {
    /// Plume → air (in `SimSystems::BeforeWeather`, after `WeatherSystems::Apply`).
    PlumeToAir,
    /// Air → plume and the ash deposit (in `SimSystems::AfterWeather`).
    AirToPlume,
}

/// Which transfers a volcano takes part in (optional; all on when absent).
#[derive(Component, Debug, Clone, Copy, PartialEq, Eq, Reflect)]
#[reflect(Component)]
pub struct CouplingSettings {
    /// The column reads the layers' air and wind.
    pub air_to_plume: bool,
    /// The column imposes its temperature and moisture on the layers.
    pub plume_to_air: bool,
    /// The ash the column sheds goes into the layers.
    pub ash: bool,
}

impl Default for CouplingSettings {
    fn default() -> Self {
        Self { air_to_plume: true, plume_to_air: true, ash: true }
    }
}

/// Ash released by expiring umbrella spheres since the last weather step, in message order.
/// Holds at most [`AshInbox::CAP`] releases: while the weather alone is paused nothing drains
/// it, and a release beyond the cap is booked as lost by its volcano
/// ([`PlumeAshBudget::lost_kg`]) with a warning.
#[derive(Resource, Debug, Clone, Default, Reflect, MapEntities)]
#[reflect(opaque)]
#[reflect(Resource, Default)]
pub struct AshInbox(#[entities] pub Vec<AshReleased>);

impl AshInbox {
    /// Most releases held between two weather steps (a few hours of a paused weather domain
    /// under a spreading umbrella; 1.5 MB).
    pub const CAP: usize = 65_536;
}

/// Weather steps the air → plume transfer has seen, so it acts once per weather step. A
/// resource rather than a system's `Local`, so a saved and reloaded world continues the same.
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource, Default)]
pub struct WeatherStepsSeen(pub u64);

/// The coupling: add after the plume and atmosphere plugins (as `VolcanoSimPlugins` does).
#[derive(Debug, Default, Clone)]
pub struct CouplingPlugin;

impl Plugin for CouplingPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<AshInbox>()
            // Owned by volcano_core; registering twice is harmless.
            .add_message::<SimFault>()
            .init_resource::<WeatherStepsSeen>()
            .register_type::<WeatherStepsSeen>()
            .register_type::<CouplingSettings>()
            .register_type::<CouplingBudget>()
            .register_type::<AshInbox>()
            .register_required_components::<Atmosphere, CouplingBudget>()
            .configure_sets(
                FixedUpdate,
                CouplingSystems::PlumeToAir.in_set(SimSystems::BeforeWeather).after(WeatherSystems::Apply),
            )
            .configure_sets(FixedUpdate, CouplingSystems::AirToPlume.in_set(SimSystems::AfterWeather))
            .add_systems(
                FixedUpdate,
                (collect_released, plume_to_air.run_if(weather_steps_this_tick))
                    .chain()
                    .in_set(CouplingSystems::PlumeToAir),
            )
            .add_systems(FixedUpdate, air_to_plume.in_set(CouplingSystems::AirToPlume));
    }
}

fn weather_steps_this_tick(
    clock: Option<Res<Time<DomainClock<WeatherStep>>>>,
    fixed: Res<Time<Fixed>>,
) -> bool {
    clock.is_some_and(|c| c.context().steps_at_next_tick(fixed.timestep()) > 0)
}

/// Every tick: keeps what expiring umbrella spheres released until the next weather step, up
/// to [`AshInbox::CAP`]; the rest is booked as lost by its volcano. A release whose position or
/// mass is not finite (or whose mass is negative; a game may send its own) is the guard's:
/// dropped, what it held booked as lost, one [`SimFault`] per volcano and tick.
fn collect_released(
    mut inbox: ResMut<AshInbox>,
    mut released: MessageReader<AshReleased>,
    mut plume_books: Query<&mut PlumeAshBudget>,
    mut faults: MessageWriter<SimFault>,
) {
    let mut broken: Vec<SimFault> = Vec::new();
    for m in released.read() {
        let lost = if !(m.position.is_finite() && m.mass.is_finite() && m.mass >= 0.0) {
            let kg = volcano_core::fault::bookable(m.mass);
            match broken.iter_mut().find(|f| f.entity == m.volcano) {
                Some(f) => {
                    f.repaired += 1;
                    f.lost_ash_kg += kg;
                }
                None => broken
                    .push(SimFault { lost_ash_kg: kg, ..SimFault::new(m.volcano, SimDomain::Coupling, 1) }),
            }
            kg
        } else if inbox.0.len() < AshInbox::CAP {
            inbox.0.push(*m);
            continue;
        } else {
            warn_once!(
                "ash released while the weather does not step: more than {} releases wait for it; \
                 the excess is booked as lost by its volcano (AshInbox::CAP, PlumeAshBudget::lost_kg)",
                AshInbox::CAP
            );
            m.mass
        };
        if let Ok(mut books) = plume_books.get_mut(m.volcano) {
            books.lost_kg += lost;
        }
    }
    for fault in broken {
        fault.warn();
        faults.write(fault);
    }
}

/// An atmosphere's layers moved out of their components (sorted by index) and back.
struct Gathered<'a> {
    handles: Vec<Mut<'a, AirLayer>>,
    layers: Vec<LayerFields>,
}

impl<'a> Gathered<'a> {
    fn new(atmosphere: Entity, query: &'a mut Query<&mut AirLayer>, n: usize) -> Option<Self> {
        let mut handles: Vec<Mut<AirLayer>> =
            query.iter_mut().filter(|l| l.atmosphere == atmosphere).collect();
        handles.sort_by_key(|l| l.index);
        if handles.len() < 2 || handles.iter().any(|l| l.fields.t.nx() != n) {
            return None;
        }
        // Moved out of their shared cells in place: the plume → air transfer runs before a
        // weather step starts, when no step holds them (no copy).
        let layers = handles.iter_mut().map(|l| std::mem::take(&mut *l.fields)).collect();
        Some(Self { handles, layers })
    }
    fn restore(mut self) {
        for (h, f) in self.handles.iter_mut().zip(self.layers.drain(..)) {
            *h.fields = f;
        }
    }
}

/// An atmosphere's layers, read in place (sorted by index): the air → plume transfer runs
/// while the weather step it just started holds them, and only reads them.
fn layers_read<'a>(
    atmosphere: Entity,
    query: &'a Query<&AirLayer>,
    n: usize,
) -> Option<Vec<&'a LayerFields>> {
    let mine = atmosphere_fields(query, atmosphere);
    (mine.len() >= 2 && mine.iter().all(|l| l.t.nx() == n)).then_some(mine)
}

/// Atmospheres by entity order, with their grids.
fn grids<'a>(atmospheres: impl Iterator<Item = (Entity, &'a Atmosphere)>) -> Vec<(Entity, GridSpec)> {
    let mut v: Vec<(Entity, GridSpec)> =
        atmospheres.filter_map(|(e, a)| GridSpec::new(a.n, a.dx).ok().map(|g| (e, g))).collect();
    v.sort_by_key(|(e, _)| *e);
    v
}

/// The first atmosphere (in entity order) whose grid contains world `(x, z)`.
fn atmosphere_over(grids: &[(Entity, GridSpec)], x: f32, z: f32) -> Option<(Entity, GridSpec)> {
    grids.iter().copied().find(|(_, g)| cell_at(*g, x as f64, z as f64).is_some())
}

/// The column slices of `volcano`, sorted by emission index, as the layers see them.
fn column_of(volcano: Entity, slices: &[(Entity, &PlumeSlice)]) -> Vec<ColumnSlice> {
    let mut mine: Vec<&PlumeSlice> =
        slices.iter().map(|(_, s)| *s).filter(|s| s.volcano == volcano).collect();
    mine.sort_by_key(|s| s.index);
    mine.iter()
        .filter(|s| matches!(s.state.phase, volcano_plume::Phase::Jet | volcano_plume::Phase::Buoyant))
        .map(|s| {
            let p = s.state.position;
            ColumnSlice {
                centre: DVec2::new(s.vent.x as f64 + p.x, s.vent.z as f64 - p.y),
                altitude: s.vent.y as f64 + p.z,
                radius: s.state.r,
                temperature: s.state.temperature,
                water_fraction: s.state.water_mass / s.state.mass.max(1e-9),
            }
        })
        .collect()
}

/// The valid heat sources of every entity (entity order, then list order) with where they are;
/// an invalid one is skipped with a warning.
fn ground_sources(sources: &Query<(Entity, &AirHeatSources)>) -> Vec<GroundSource> {
    let mut all: Vec<(Entity, &AirHeatSources)> = sources.iter().collect();
    all.sort_by_key(|(e, _)| *e);
    let mut out = Vec::new();
    for (e, list) in all {
        for s in &list.0 {
            if let Err(err) = s.validate() {
                warn_once!("entity {e}: an air heat source is skipped: {err}");
                continue;
            }
            out.push(GroundSource {
                at: DVec2::new(s.at.x as f64, s.at.z as f64),
                altitude: s.at.y as f64,
                heat_w: s.heat_w,
                vapour_kg_s: s.vapour_kg_s,
                radius: s.radius_m,
            });
        }
    }
    out
}

/// Plume → air, just before a weather step: gathers each atmosphere's layers, the columns of
/// the volcanoes over it, the ash their slices, umbrella spheres and expired spheres shed and
/// the ground's heat sources (`AirHeatSources`: fountains, sea entries) over it, and runs
/// [`crate::model::step::plume_to_air`].
#[allow(clippy::type_complexity, clippy::too_many_arguments)]
fn plume_to_air(
    clock: Option<Res<Time<DomainClock<WeatherStep>>>>,
    fixed: Res<Time<Fixed>>,
    heat_sources: Query<(Entity, &AirHeatSources)>,
    mut inbox: ResMut<AshInbox>,
    mut atmospheres: Query<(Entity, &Atmosphere, &mut AtmosphereGround, &mut CouplingBudget)>,
    mut layer_query: Query<&mut AirLayer>,
    volcanoes: Query<(Entity, &VentPosition, Option<&CouplingSettings>), With<Eruption>>,
    mut plume_books: Query<&mut PlumeAshBudget>,
    mut slices: Query<(Entity, &mut PlumeSlice)>,
    mut spheres: Query<(&mut Umbrella, &Transform)>,
) {
    let grids = grids(atmospheres.iter().map(|(e, a, ..)| (e, a)));
    let settings_of = |v: Entity| volcanoes.get(v).ok().map(|(_, _, s)| s.copied().unwrap_or_default());
    // The heat of the weather steps about to run (their simulated length).
    let seconds = clock.map_or(0.0, |c| {
        let base = fixed.timestep();
        c.context().step_duration(base).as_secs_f64() * c.context().steps_at_next_tick(base) as f64
    });
    let sources = ground_sources(&heat_sources);
    for (atmo, grid) in grids.iter().copied() {
        let Ok((_, _, mut ground, mut budget)) = atmospheres.get_mut(atmo) else { continue };
        let Some(mut g) = Gathered::new(atmo, &mut layer_query, grid.n) else { continue };
        // The volcanoes over this atmosphere (entity order) and their columns.
        let mut coupled: Vec<Entity> = volcanoes
            .iter()
            .filter(|(_, vent, _)| {
                atmosphere_over(&grids, vent.0.x, vent.0.z).is_some_and(|(a, _)| a == atmo)
            })
            .map(|(e, ..)| e)
            .collect();
        coupled.sort();
        let columns: Vec<Vec<ColumnSlice>> = {
            let all: Vec<(Entity, &PlumeSlice)> = slices.iter().collect();
            coupled
                .iter()
                .filter(|v| settings_of(**v).is_some_and(|s| s.plume_to_air))
                .map(|v| column_of(*v, &all))
                .collect()
        };
        // Ash: slices (emission order), umbrella spheres (id order), expired spheres.
        let wants_ash = |v: Entity| settings_of(v).is_some_and(|s| s.ash) && coupled.contains(&v);
        let mut parcels: Vec<((u64, u64), Vec3, f64)> = Vec::new();
        for (_, mut s) in slices.iter_mut() {
            if s.ash_pending > 0.0 && wants_ash(s.volcano) {
                let p = s.state.position;
                let at = s.vent + Vec3::new(p.x as f32, p.z as f32, -p.y as f32);
                parcels.push(((s.volcano.to_bits(), s.index), at, s.ash_pending));
                s.ash_pending = 0.0;
            }
        }
        for (mut u, transform) in spheres.iter_mut() {
            if u.ash_pending > 0.0 && wants_ash(u.volcano) {
                parcels.push(((u.volcano.to_bits(), u.id | 1 << 63), transform.translation, u.ash_pending));
                u.ash_pending = 0.0;
            }
        }
        parcels.sort_by_key(|p| p.0);
        let (mine, others): (Vec<AshReleased>, Vec<AshReleased>) =
            inbox.0.drain(..).partition(|m| wants_ash(m.volcano));
        inbox.0 = others;
        parcels.extend(mine.into_iter().map(|m| ((m.volcano.to_bits(), u64::MAX), m.position, m.mass)));
        let parcels: Vec<AshParcel> = parcels
            .into_iter()
            .map(|(_, at, kg)| AshParcel { at: DVec3::new(at.x as f64, at.y as f64, at.z as f64), kg })
            .collect();
        let columns: Vec<CoupledColumn> =
            columns.iter().map(|c| CoupledColumn { slices: c, plume_to_air: true }).collect();
        let over: Vec<GroundSource> = sources
            .iter()
            .copied()
            .filter(|s| atmosphere_over(&grids, s.at.x as f32, s.at.y as f32).is_some_and(|(a, _)| a == atmo))
            .collect();
        let heat = GroundHeat { sources: &over, seconds };
        let mut air =
            AirSide { grid, layers: &mut g.layers, ground_ash: ground.0.ash.data_mut(), books: &mut budget };
        let report = crate::model::step::plume_to_air(&mut air, &columns, &parcels, heat);
        if report.stability_floored > 0 {
            warn_once!(
                "atmosphere {atmo}: a heat source rose through neutral or unstable air; its plume height \
                 used the floor N = {} s⁻¹ (volcano_coupling::model::heat::MIN_BUOYANCY_FREQUENCY)",
                crate::model::heat::MIN_BUOYANCY_FREQUENCY
            );
        }
        g.restore();
    }
    // Released ash no atmosphere took (its volcano is under none, or does not hand over ash):
    // booked as lost by its volcano instead of piling up here.
    for m in inbox.0.drain(..) {
        if let Ok(mut books) = plume_books.get_mut(m.volcano) {
            books.lost_kg += m.mass;
        }
    }
}

/// Air → plume and the ash books, just after a weather step (or on the first tick a coupled
/// volcano has no ambient yet): gathers each atmosphere's layers and the columns asking for
/// their ambient, runs [`crate::model::step::air_to_plume`] (the fallen ash goes onto the
/// deposit of the first terrain under each cell), and inserts each column's ambient.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn air_to_plume(
    mut commands: Commands,
    clock: Option<Res<Time<DomainClock<WeatherStep>>>>,
    mut seen_steps: ResMut<WeatherStepsSeen>,
    mut stepped: MessageReader<WeatherStepped>,
    mut atmospheres: Query<(Entity, &Atmosphere, &mut AtmosphereGround, &mut CouplingBudget)>,
    layer_query: Query<&AirLayer>,
    volcanoes: Query<(Entity, &VentPosition, &Eruption, Option<&CouplingSettings>, Has<PlumeAmbient>)>,
    slices: Query<(Entity, &PlumeSlice)>,
    mut grounds: Query<(&Terrain, &mut DepositMap)>,
) {
    let steps = clock.map_or(0, |c| c.context().steps_run());
    let stepped_now = steps != seen_steps.0;
    seen_steps.0 = steps;
    for m in stepped.read() {
        if let Ok((.., mut budget)) = atmospheres.get_mut(m.atmosphere) {
            budget.ash_outflow_kg += m.report.ash.outflow * 1e-3;
        }
    }
    let grids = grids(atmospheres.iter().map(|(e, a, ..)| (e, a)));
    // Volcanoes: their atmosphere (if any) and whether they need an ambient now.
    let mut by_atmo: Vec<(Entity, Entity)> = Vec::new();
    for (v, vent, _, settings, has) in volcanoes.iter() {
        let settings = settings.copied().unwrap_or_default();
        match atmosphere_over(&grids, vent.0.x, vent.0.z) {
            Some((a, _)) if settings.air_to_plume => {
                if stepped_now || !has {
                    by_atmo.push((a, v));
                }
            }
            _ => {
                if has {
                    commands.entity(v).remove::<PlumeAmbient>();
                }
            }
        }
    }
    if !stepped_now && by_atmo.is_empty() {
        return;
    }
    by_atmo.sort();
    let all: Vec<(Entity, &PlumeSlice)> = slices.iter().collect();
    let bulk = volcanoes.iter().next().map_or(1_000.0, |(_, _, e, ..)| e.pyroclastic.deposit_density);
    for (atmo, grid) in grids.iter().copied() {
        let Ok((_, _, mut ground, mut budget)) = atmospheres.get_mut(atmo) else { continue };
        // Ash fallen this step: spread over the cell's footprint on the deposit of the terrain
        // under the cell's centre (the first that holds it).
        let half = (0.5 * grid.dx) as f32;
        let mut deposit = |x: f64, z: f64, kg: f64| {
            let (x, z) = (x as f32, z as f32);
            grounds
                .iter_mut()
                .find(|(t, _)| t.contains(x, z))
                .is_some_and(|(t, mut deposit)| deposit.add_over(t, Vec2::new(x, z), half, kg, bulk))
        };
        let mine: Vec<Entity> = by_atmo.iter().filter(|(a, _)| *a == atmo).map(|(_, v)| *v).collect();
        let gathered = if mine.is_empty() { None } else { layers_read(atmo, &layer_query, grid.n) };
        let Some(layers) = gathered else {
            // No column to serve here (or no usable layers): only the fallen ash.
            if stepped_now {
                let mut air = AirReadSide {
                    grid,
                    layers: &[],
                    ground_ash: ground.0.ash.data_mut(),
                    books: &mut budget,
                };
                crate::model::step::air_to_plume(&mut air, true, &[], &mut deposit);
            }
            continue;
        };
        let requests: Vec<(Entity, &Eruption, Vec<ColumnSlice>, DVec2)> = mine
            .iter()
            .filter_map(|&v| volcanoes.get(v).ok())
            .map(|(v, vent, eruption, ..)| {
                (v, eruption, column_of(v, &all), DVec2::new(vent.0.x as f64, vent.0.z as f64))
            })
            .collect();
        let asks: Vec<AmbientRequest> = requests
            .iter()
            .map(|(_, eruption, column, vent)| AmbientRequest {
                slices: column,
                vent: *vent,
                r0: eruption.params.r0,
            })
            .collect();
        let mut air =
            AirReadSide { grid, layers: &layers, ground_ash: ground.0.ash.data_mut(), books: &mut budget };
        let report = crate::model::step::air_to_plume(&mut air, stepped_now, &asks, &mut deposit);
        for ((v, eruption, ..), levels) in requests.iter().zip(report.ambients) {
            let v = *v;
            match LayeredAmbient::new(eruption.params.atmosphere, levels) {
                Ok(a) => {
                    commands.entity(v).insert(PlumeAmbient(a));
                }
                Err(e) => {
                    warn_once!(
                        "volcano {v}: no ambient from its atmosphere ({e}); the plume keeps its profile"
                    );
                    commands.entity(v).remove::<PlumeAmbient>();
                }
            }
        }
    }
}

/// The ash books of one atmosphere and the volcanoes over it (kg).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AshLedger {
    /// Solid mass emitted at the vents.
    pub emitted: f64,
    /// Still in live slices (carried and shed-but-pending).
    pub in_slices: f64,
    /// Still in umbrella spheres (carried and pending).
    pub in_spheres: f64,
    /// Released by expired spheres, waiting for the next weather step.
    pub in_inbox: f64,
    /// In the layers' ash fields.
    pub in_air: f64,
    /// Deposited on the ground (including what is on the ground grid, not yet collected).
    pub deposited: f64,
    /// Left through the rim or handed over outside the grid.
    pub outflow: f64,
    /// Handed to pyroclastic flows with collapsing slices.
    pub to_flows: f64,
    /// Removed without a place (see [`PlumeAshBudget::lost_kg`]).
    pub lost: f64,
}

impl AshLedger {
    /// `emitted − (everything it went to)`: zero to rounding when the books close.
    pub fn imbalance(&self) -> f64 {
        self.emitted
            - (self.in_slices
                + self.in_spheres
                + self.in_inbox
                + self.in_air
                + self.deposited
                + self.outflow
                + self.to_flows
                + self.lost)
    }
}

/// Adds up the ash books of atmosphere `atmosphere` and every eruption in the world (tests,
/// summaries; one atmosphere per world is assumed for the volcano side).
pub fn ash_ledger(world: &mut World, atmosphere: Entity) -> AshLedger {
    let mut l = AshLedger::default();
    for b in world.query::<&PlumeAshBudget>().iter(world) {
        l.emitted += b.emitted_kg;
        l.to_flows += b.to_flows_kg;
        l.lost += b.lost_kg;
    }
    for s in world.query::<&PlumeSlice>().iter(world) {
        l.in_slices += s.state.solid_mass.max(0.0) + s.ash_pending;
    }
    for u in world.query::<&Umbrella>().iter(world) {
        l.in_spheres += u.ash + u.ash_pending;
    }
    l.in_inbox = world.resource::<AshInbox>().0.iter().map(|m| m.mass).sum();
    let dx = world.get::<Atmosphere>(atmosphere).map_or(1.0, |a| a.dx);
    let mut layers: Vec<(usize, f64)> = world
        .query::<&AirLayer>()
        .iter(world)
        .filter(|l| l.atmosphere == atmosphere)
        .map(|l| (l.index, volcano_atmosphere::model::ash::airborne(std::slice::from_ref(&l.fields), dx)))
        .collect();
    layers.sort_by_key(|x| x.0);
    l.in_air = layers.iter().map(|x| x.1).sum::<f64>() * 1e-3;
    let on_ground: f64 = world
        .get::<AtmosphereGround>(atmosphere)
        .map_or(0.0, |g| g.0.ash.data().iter().sum::<f64>() * dx * dx * 1e-3);
    if let Some(b) = world.get::<CouplingBudget>(atmosphere) {
        l.deposited = b.ash_deposited_kg + on_ground;
        l.outflow = b.ash_outflow_kg;
    }
    l
}
