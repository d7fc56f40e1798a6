//! A volcano's own lava (docs/physics/lava.md §7): put a [`LavaVent`] on a `Volcano` and its
//! lava runs over the terrain the volcano stands on, as far as it goes. The plugin keeps one
//! [`TerrainLava`] (a [`Runout`]) per terrain with lava vents, steps it in `LavaStep`, writes
//! what froze into the terrain ([`TerrainChanged`]) and tells the game where the flow is
//! ([`LavaFlowFront`], [`LavaFlowStopped`], [`LavaVentOpened`]).

use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_core::terrain::TerrainChanged;
use volcano_core::volcano::{OnTerrain, VentPosition};

use crate::model::params::{LavaParams, ViscosityModel};
use crate::model::runout::{Runout, RunoutSettings, Vent};

/// Lava from a volcano's vent: put it on a `Volcano` entity. The vent is the volcano's
/// (`VentPosition`) moved by `offset` (a flank vent), a point or, with a non-zero `fissure`,
/// a line; while `active` it emits `rate` m³/s of lava at `temperature` over the cells within
/// `radius` of it. Checked every step: an invalid value stops
/// the vent and says why in [`LavaVentStatus::error`].
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[require(LavaVentStatus)]
#[reflect(Component, Default)]
pub struct LavaVent {
    /// Effusion rate (m³/s of lava, in [0, 10⁶]).
    pub rate: f64,
    /// Temperature of the lava (K, in [300, 2500]).
    pub temperature: f64,
    /// Radius of the fed disc (m, in [0, 5000]).
    pub radius: f64,
    /// World (x, z) offset of the vent from the volcano's vent (m).
    pub offset: Vec2,
    /// Half a fissure: from its centre (the vent) to one end (world x, z; m, at most 5 km);
    /// zero for a point vent.
    pub fissure: Vec2,
    /// Whether it emits.
    pub active: bool,
}

impl Default for LavaVent {
    /// 5 m³/s of basalt at 1450 K from a 15 m disc at the volcano's vent.
    fn default() -> Self {
        Self {
            rate: 5.0,
            temperature: 1450.0,
            radius: 15.0,
            offset: Vec2::ZERO,
            fissure: Vec2::ZERO,
            active: true,
        }
    }
}

impl LavaVent {
    /// An effusive vent at the volcano's vent emitting `rate` m³/s; errors on a bad rate.
    pub fn effusive(rate: f64) -> Result<Self, ConfigError> {
        let v = Self { rate, ..Self::default() };
        v.validate()?;
        Ok(v)
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.vent(Vec2::ZERO).validate()?;
        if !(self.offset.is_finite() && self.fissure.is_finite()) {
            return Err(ConfigError::InvalidParameter {
                name: "lava vent offset or fissure",
                value: f64::NAN,
                reason: "must be finite".into(),
            });
        }
        Ok(())
    }

    /// The model's vent for a volcano whose vent is at world (x, z) `at`.
    fn vent(&self, at: Vec2) -> Vent {
        let c = (at + self.offset).as_dvec2();
        Vent { fissure: self.fissure.as_dvec2(), ..Vent::point(c, self.radius, self.rate, self.temperature) }
    }
}

/// What a [`LavaVent`]'s flow is doing (written by the plugin once per simulated second).
#[derive(Component, Debug, Clone, PartialEq, Default, Reflect)]
#[reflect(Component, Default)]
pub struct LavaVentStatus {
    /// Lava emitted so far (m³).
    pub emitted_m3: f64,
    /// Farthest lava from the vent (m).
    pub runout_m: f64,
    /// The flow's front (world x, z), the farthest liquid lava.
    pub front: Option<Vec2>,
    /// How fast the front moved away over the last second (m per simulated second).
    pub front_speed_m_s: f32,
    /// The front has not advanced for [`FRONT_STOP_S`].
    pub stopped: bool,
    /// Why the vent emits nothing (invalid values, no terrain under it).
    pub error: Option<String>,
}

const SECOND: std::time::Duration = std::time::Duration::from_secs(1);

/// Seconds without the front advancing a cell after which a flow counts as stopped.
pub const FRONT_STOP_S: f64 = 600.0;

/// The lava of every vent on one terrain (on the terrain entity; created by the plugin).
/// Reflected as one opaque value.
#[derive(Component, Debug, Clone, Reflect)]
#[reflect(opaque)]
#[reflect(Component)]
pub struct TerrainLava {
    /// The lava over the terrain.
    pub runout: Runout,
    /// What the last step did (its limiters: `mobility_capped`, `vents_rejected`).
    pub last_step: crate::model::runout::RunoutReport,
    /// The terrain placement it was built for (a moved terrain rebuilds it, losing its lava).
    built_at: Vec2,
    /// Simulated seconds the lava clock has fallen behind the scaled game clock because steps
    /// would have exceeded [`VentLavaSettings::substep_budget`] (a limiter; 0 while it never
    /// acted).
    pub behind_s: f64,
    /// Substeps per simulated second of the last step: what the next step's length is budgeted
    /// from.
    substeps_per_s: f64,
}

impl TerrainLava {
    /// The length (simulated s) of a step that wants `wanted` s with `cells` stored cells and
    /// `budget` cell-substeps to spend: shortened so the substeps the last step needed per
    /// simulated second fit the budget (never below a thousandth of `wanted`).
    fn budgeted(&self, wanted: f64, cells: usize, budget: u64) -> f64 {
        let need = self.substeps_per_s * cells as f64;
        if need > 0.0 { wanted.min(budget as f64 / need).max(1e-3 * wanted) } else { wanted }
    }
}

/// How vent lava behaves (a resource; checked every step, an invalid value pauses it).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct VentLavaSettings {
    /// Resolution and tile sleeping.
    pub runout: RunoutSettings,
    /// The lava: a channel-fed crystallising basalt by default.
    pub params: LavaParams,
    /// Simulated seconds of vent lava per second of the lava clock (in [1, 10⁴]): an
    /// effusive week shown in minutes. The flow's substeps follow (the cost grows with it).
    pub time_scale: f64,
    /// Most stored cells × flow substeps one step may take (in [10⁴, 10¹⁰]; ≈ 30 ns each on
    /// one core, release, so the default 10⁵ is ≈ 3 ms). Lava ponded deep and hot needs many
    /// substeps (explicit flow, stable step ∝ η/h³): a step that would take more is shortened
    /// and the lava clock falls behind the scaled game clock ([`TerrainLava::behind_s`],
    /// warned once) instead of taking the frame.
    pub substep_budget: u64,
}

impl VentLavaSettings {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.runout.validate()?;
        self.params.validate()?;
        volcano_core::error::in_range("vent lava time_scale", self.time_scale, 1.0, 1e4)?;
        volcano_core::error::in_range("vent lava substep_budget", self.substep_budget as f64, 1e4, 1e10)?;
        Ok(())
    }
}

impl Default for VentLavaSettings {
    fn default() -> Self {
        Self {
            runout: RunoutSettings::default(),
            params: LavaParams { viscosity: ViscosityModel::CHANNEL_BASALT, ..LavaParams::default() },
            time_scale: 1.0,
            substep_budget: 100_000,
        }
    }
}

/// A lava vent started emitting.
#[derive(Message, Debug, Clone, Copy, PartialEq, Reflect)]
pub struct LavaVentOpened {
    /// The volcano.
    pub volcano: Entity,
    /// World (x, z) of the vent.
    pub position: Vec2,
}

/// Where a vent's flow front is (once per simulated second while it moves).
#[derive(Message, Debug, Clone, Copy, PartialEq, Reflect)]
pub struct LavaFlowFront {
    /// The volcano.
    pub volcano: Entity,
    /// World (x, z) of the front.
    pub position: Vec2,
    /// Its distance from the vent (m).
    pub distance_m: f32,
    /// Its speed away from the vent over the last second (m/s).
    pub speed_m_s: f32,
}

/// A vent's flow front stopped (it did not advance for [`FRONT_STOP_S`]).
#[derive(Message, Debug, Clone, Copy, PartialEq, Reflect)]
pub struct LavaFlowStopped {
    /// The volcano.
    pub volcano: Entity,
    /// How far the flow ran (m).
    pub runout_m: f32,
}

/// Per-vent bookkeeping of the front between seconds.
#[derive(Component, Debug, Clone, Copy, PartialEq, Default, Reflect)]
#[reflect(Component, Default)]
pub(crate) struct FrontTrack {
    last_runout: f64,
    last_front: f64,
    /// The runout's clock at `last_front` (simulated s).
    last_time: f64,
    advanced_at: f64,
    opened: bool,
}

type VentItem = (
    Entity,
    &'static LavaVent,
    Option<&'static VentPosition>,
    Option<&'static OnTerrain>,
    &'static mut LavaVentStatus,
    Option<&'static mut FrontTrack>,
);

/// Messages a vent step writes.
#[derive(bevy::ecs::system::SystemParam)]
pub(crate) struct VentMessages<'w> {
    opened: MessageWriter<'w, LavaVentOpened>,
    front: MessageWriter<'w, LavaFlowFront>,
    stopped: MessageWriter<'w, LavaFlowStopped>,
    changed: MessageWriter<'w, TerrainChanged>,
    faults: MessageWriter<'w, SimFault>,
}

/// Gathers the vents by terrain, steps each terrain's runout, writes frozen lava into the
/// terrain (change detection bypassed, one [`TerrainChanged`]) and, once per second, the
/// vents' status and messages.
pub(crate) fn step_vent_lava(
    time: Res<Time>,
    settings: Res<VentLavaSettings>,
    mut commands: Commands,
    mut vents: Query<VentItem>,
    mut terrains: Query<(Entity, &mut Terrain, Option<&mut TerrainLava>, Option<&mut AirHeatSources>)>,
    mut out: VentMessages,
) {
    let dt = time.delta_secs_f64() * settings.time_scale;
    if dt.is_nan() || dt <= 0.0 {
        return;
    }
    if let Err(e) = settings.validate() {
        for (.., mut status, _) in &mut vents {
            status.error = Some(format!("VentLavaSettings: {e}"));
        }
        return;
    }
    // Gather: each valid vent to its terrain, in entity order, and whether it emits now (a
    // stopped vent's flow is still followed).
    let mut by_terrain: Vec<(Entity, Entity, Vent, bool)> = Vec::new();
    for (e, vent, at, on, mut status, track) in &mut vents {
        let error = match (vent.validate(), at, on) {
            (Err(err), ..) => Some(err.to_string()),
            (_, None, _) | (_, _, None) => Some("the volcano stands on no terrain".to_string()),
            (Ok(()), Some(at), Some(on)) => {
                let feeds = vent.active && vent.rate > 0.0;
                by_terrain.push((on.0, e, vent.vent(Vec2::new(at.0.x, at.0.z)), feeds));
                None
            }
        };
        if status.error != error {
            status.error = error;
        }
        if track.is_none() {
            commands.entity(e).insert(FrontTrack::default());
        }
    }
    by_terrain.sort_by_key(|(t, e, ..)| (*t, *e));
    let second =
        volcano_core::clock::crossings(time.elapsed(), time.delta(), SECOND, std::time::Duration::ZERO) > 0;
    // Terrains with emitting vents, and those whose lava still flows and cools after its
    // vents stopped or were despawned.
    let mut stepped: Vec<Entity> = by_terrain.iter().filter(|v| v.3).map(|(t, ..)| *t).collect();
    stepped.extend(terrains.iter().filter(|(_, _, lava, _)| lava.is_some()).map(|(e, ..)| e));
    stepped.sort_unstable();
    stepped.dedup();
    for terrain_entity in stepped {
        let Ok((_, mut terrain, lava, sources)) = terrains.get_mut(terrain_entity) else { continue };
        let placement = terrain.placement();
        let fresh = || Runout::new(&terrain, settings.runout, &settings.params);
        let mut lava = match lava {
            Some(l) if l.built_at == placement && l.runout.settings() == settings.runout => l,
            Some(mut l) => {
                warn!("terrain {terrain_entity}: moved or re-resolved; its vent lava starts again");
                match fresh() {
                    Ok(r) => l.runout = r,
                    Err(e) => {
                        warn!("terrain {terrain_entity}: no vent lava: {e}");
                        continue;
                    }
                }
                l.built_at = placement;
                l
            }
            None => {
                match fresh() {
                    Ok(runout) => {
                        commands.entity(terrain_entity).insert(TerrainLava {
                            runout,
                            last_step: Default::default(),
                            built_at: placement,
                            behind_s: 0.0,
                            substeps_per_s: 0.0,
                        });
                    }
                    Err(e) => warn!("terrain {terrain_entity}: no vent lava: {e}"),
                }
                continue; // steps from the next tick, once inserted
            }
        };
        let fed: Vec<Vent> = by_terrain
            .iter()
            .filter(|(t, .., feeds)| *t == terrain_entity && *feeds)
            .map(|(_, _, v, _)| *v)
            .collect();
        let cells = lava.runout.tiles().len() * crate::view::RUNOUT_TILE * crate::view::RUNOUT_TILE;
        let step_s = lava.budgeted(dt, cells, settings.substep_budget);
        if step_s < dt && lava.behind_s == 0.0 {
            warn!(
                "terrain {terrain_entity}: vent lava needs more than {} cell-substeps a tick; its clock \
                 falls behind the game's (VentLavaSettings::substep_budget, TerrainLava::behind_s)",
                settings.substep_budget
            );
        }
        lava.behind_s += dt - step_s;
        let report = lava.runout.step(&terrain, &settings.params, &fed, step_s);
        lava.substeps_per_s = report.substeps as f64 / step_s;
        if report.mobility_capped && !lava.last_step.mobility_capped {
            warn!(
                "terrain {terrain_entity}: vent lava at the substep cap ({} substeps): the flow is slowed to stay stable",
                report.substeps
            );
        }
        if report.repaired_cells > 0 {
            let fault = SimFault {
                lost_lava_m3: report.lost_m3,
                ..SimFault::new(terrain_entity, SimDomain::Lava, report.repaired_cells as u64)
            };
            fault.warn();
            out.faults.write(fault);
        }
        lava.last_step = report;
        // The sea entry's steam and heat, for the air above (the laze plume).
        let laze = sea_entry(&report, step_s, &terrain);
        match sources {
            Some(mut s) => AirHeatSources::set_kind(&mut s, AirHeatKind::SeaEntry, laze),
            None if laze.is_some() => {
                commands.entity(terrain_entity).insert(AirHeatSources(laze.into_iter().collect()));
            }
            None => {}
        }
        match lava.runout.write_frozen(terrain.bypass_change_detection()) {
            Ok(moved) if !moved.is_empty() => {
                out.changed.write(TerrainChanged { terrain: terrain_entity, region: moved });
            }
            Ok(_) => {}
            Err(e) => warn!("terrain {terrain_entity}: frozen vent lava not written: {e}"),
        }
        let area = lava.runout.grid().cell() * lava.runout.grid().cell();
        // What each feeding vent emitted, in the order `fed` gave them.
        let mut emitted = lava.runout.emitted_by_vent().iter();
        for (_, volcano, vent, feeds) in by_terrain.iter().filter(|(t, ..)| *t == terrain_entity) {
            let v = if *feeds { emitted.next().copied().unwrap_or(0.0) } else { 0.0 };
            let Ok((.., mut status, track)) = vents.get_mut(*volcano) else { continue };
            status.emitted_m3 += v;
            let Some(mut track) = track else { continue };
            if !track.opened && v > 0.0 {
                track.opened = true;
                out.opened.write(LavaVentOpened { volcano: *volcano, position: vent.centre.as_vec2() });
            }
            if !second {
                continue;
            }
            let st = lava.runout.stats(vent.centre, settings.params.min_thickness);
            let now = lava.runout.time();
            let advanced = st.runout_m > track.last_runout + lava.runout.grid().cell();
            // Distance gained over the last second of the lava clock, per simulated second.
            let elapsed = now - track.last_time;
            status.front_speed_m_s =
                if elapsed > 0.0 { ((st.front_m - track.last_front).max(0.0) / elapsed) as f32 } else { 0.0 };
            track.last_front = st.front_m;
            track.last_time = now;
            status.runout_m = status.runout_m.max(st.runout_m);
            status.front = st.front.map(|p| p.as_vec2());
            if advanced {
                track.last_runout = st.runout_m;
                track.advanced_at = now;
                status.stopped = false;
                if let Some(p) = st.front {
                    out.front.write(LavaFlowFront {
                        volcano: *volcano,
                        position: p.as_vec2(),
                        distance_m: st.front_m as f32,
                        speed_m_s: status.front_speed_m_s,
                    });
                }
            } else if !status.stopped && now - track.advanced_at >= FRONT_STOP_S && st.covered_m2 > area {
                status.stopped = true;
                out.stopped.write(LavaFlowStopped { volcano: *volcano, runout_m: status.runout_m as f32 });
            }
        }
    }
}

/// Enthalpy (J/kg) to boil sea water from 20 °C: `c_w ΔT + L_v` with c_w = 3,990 J/(kg K)
/// (sea water) over 80 K and L_v = 2.257 MJ/kg at 100 °C.
pub const SEA_STEAM_ENTHALPY: f64 = 3_990.0 * 80.0 + 2.257e6;

/// Radius (m) of a sea entry's source of steam at the shore.
const SEA_ENTRY_RADIUS: f64 = 100.0;

/// A step's sea entry as a source of heat and steam for the air: the quench heat's rate over
/// the step's `dt` (simulated seconds), all of it boiling sea water (an upper bound: part of it
/// warms the sea), at the quenched lava's centre on the sea surface. `None` without quenching.
fn sea_entry(
    report: &crate::model::runout::RunoutReport,
    dt: f64,
    terrain: &Terrain,
) -> Option<AirHeatSource> {
    let at = report.quench_at?;
    let heat_w = report.quench_heat / dt;
    (heat_w > 0.0 && heat_w.is_finite()).then(|| {
        let (x, z) = (at.x as f32, at.y as f32);
        AirHeatSource {
            at: Vec3::new(x, terrain.height_at(x, z).max(terrain.sea_level()), z),
            heat_w,
            vapour_kg_s: heat_w / SEA_STEAM_ENTHALPY,
            radius_m: SEA_ENTRY_RADIUS,
            kind: AirHeatKind::SeaEntry,
        }
    })
}
