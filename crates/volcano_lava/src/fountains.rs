//! A Hawaiian fountain over a volcano's lava vent (docs/physics/fountain.md §8.1): put a
//! [`LavaFountain`] beside a [`LavaVent`] and, while the vent emits, clots of its lava are
//! thrown up over it (or along its fissure: a curtain of fire) and fall back where its lava
//! feeds the flow. The fountain's heat and magmatic water go into the air as an
//! [`AirHeatSource`] on the volcano, which the coupling lifts into the atmosphere as the
//! fountain's gas plume. Renderers read the clots in [`LavaFountainState`].
//!
//! The fountain runs on the lava clock unscaled: clots fly in real seconds even when
//! `VentLavaSettings::time_scale` speeds the flow up.

use bevy::math::DVec3;
use bevy::prelude::*;
use volcano_core::prelude::*;
use volcano_core::rng::{derive_stream, stream_id};
use volcano_core::volcano::{OnTerrain, VentPosition};

use crate::model::fountain::{Fountain, FountainAir, FountainParams, FountainReport, FountainSource};
use crate::vents::{LavaVent, VentLavaSettings};

/// A lava fountain over the [`LavaVent`] of the same volcano (checked every step: an invalid
/// value stops it and says why in [`LavaFountainState::error`]).
#[derive(Component, Debug, Clone, PartialEq, Reflect)]
#[require(LavaFountainState)]
#[reflect(Component, Default)]
pub struct LavaFountain {
    /// What it throws.
    pub params: FountainParams,
}

impl Default for LavaFountain {
    /// A 100 m fountain of 20 cm spatter ([`FountainParams::default`]).
    fn default() -> Self {
        Self { params: FountainParams::default() }
    }
}

impl LavaFountain {
    /// A fountain `height` m high (in [1, 2000]) at sea-level air density: the exit speed that
    /// throws the default clots that high against the air's drag.
    pub fn with_height(height: f64) -> Result<Self, ConfigError> {
        volcano_core::error::in_range("fountain height", height, 1.0, 2_000.0)?;
        let d = FountainParams::default();
        let params = FountainParams { exit_speed: d.speed_for_height(height, SEA_LEVEL_AIR_DENSITY), ..d };
        params.validate()?;
        Ok(Self { params })
    }
}

/// Air density at sea level (kg/m³) for [`LavaFountain::with_height`].
const SEA_LEVEL_AIR_DENSITY: f64 = 1.225;

/// A fountain's clots in flight and what its last step did (written by the plugin). Saved with
/// the world (one opaque value), so a reloaded fountain continues the same.
#[derive(Component, Debug, Clone, Default, PartialEq, Reflect)]
#[reflect(opaque)]
#[reflect(Component, Default)]
pub struct LavaFountainState {
    /// The model: clots in flight and its random stream (built at the first step).
    pub fountain: Option<Fountain>,
    /// What the last step did (`capped`: launches skipped at `max_clots`, a limiter).
    pub last_step: FountainReport,
    /// Heat flux into the air over the last step (W).
    pub heat_w: f64,
    /// Why the fountain throws nothing (invalid values, no lava vent, no terrain).
    pub error: Option<String>,
}

type FountainItem = (
    Entity,
    &'static Volcano,
    &'static LavaFountain,
    Option<&'static LavaVent>,
    Option<&'static VentPosition>,
    Option<&'static OnTerrain>,
    &'static mut LavaFountainState,
    Option<&'static mut AirHeatSources>,
);

/// Steps every fountain on the lava clock (unscaled), lands its clots on the terrain, and
/// keeps the volcano's fountain [`AirHeatSource`] at its heat and vapour rates.
pub(crate) fn step_fountains(
    time: Res<Time>,
    settings: Res<VentLavaSettings>,
    mut commands: Commands,
    mut fountains: Query<FountainItem>,
    terrains: Query<&Terrain>,
) {
    let dt = time.delta_secs_f64();
    if dt.is_nan() || dt <= 0.0 {
        return;
    }
    for (entity, volcano, fountain, vent, at, on, mut state, sources) in &mut fountains {
        let terrain = on.and_then(|on| terrains.get(on.0).ok());
        let checked =
            fountain.params.validate().map_err(|e| e.to_string()).and_then(|()| match (vent, at, terrain) {
                (None, ..) => Err("no LavaVent on the volcano".to_string()),
                (_, None, _) | (_, _, None) => Err("the volcano stands on no terrain".to_string()),
                (Some(v), Some(at), Some(t)) => v.validate().map(|()| (v, at, t)).map_err(|e| e.to_string()),
            });
        let (vent, at, terrain) = match checked {
            Ok(ok) => ok,
            Err(e) => {
                if state.error.as_ref() != Some(&e) {
                    warn!("volcano {entity}: its lava fountain throws nothing: {e}");
                    state.error = Some(e);
                }
                continue;
            }
        };
        if state.error.is_some() {
            state.error = None;
        }
        if state.fountain.as_ref().is_none_or(|f| f.params() != &fountain.params) {
            let keep = state.fountain.take();
            let built = match keep {
                Some(mut f) => f.set_params(fountain.params).map(|()| f),
                None => Fountain::new(
                    fountain.params,
                    derive_stream(volcano.seed(), stream_id("lava fountain", 0)),
                ),
            };
            match built {
                Ok(f) => state.fountain = Some(f),
                Err(e) => {
                    state.error = Some(e.to_string());
                    continue;
                }
            }
        }
        let centre = Vec2::new(at.0.x, at.0.z) + vent.offset;
        let ground = terrain.height_at(centre.x, centre.y) as f64;
        let source = FountainSource {
            vent: DVec3::new(centre.x as f64, ground, centre.y as f64),
            fissure: DVec3::new(vent.fissure.x as f64, 0.0, vent.fissure.y as f64),
            radius: vent.radius,
            rate: vent.rate,
            temperature: vent.temperature,
            lava_density: settings.params.density,
        };
        let profile = volcano_core::UsStandard1976;
        let air = FountainAir { temperature: profile.temperature(ground), density: profile.density(ground) };
        let Some(model) = state.fountain.as_mut() else { continue };
        let emits = vent.active && vent.rate > 0.0;
        let report = model
            .step(dt, emits.then_some(&source), air, |x, z| terrain.height_at(x as f32, z as f32) as f64);
        if report.capped > 0 && state.last_step.capped == 0 {
            warn!(
                "volcano {entity}: lava fountain at max_clots ({}): launches are skipped",
                fountain.params.max_clots
            );
        }
        state.heat_w = report.heat_j / dt;
        state.last_step = report;
        let heat = AirHeatSource {
            at: Vec3::new(centre.x, ground as f32, centre.y),
            heat_w: state.heat_w,
            vapour_kg_s: report.vapour_kg / dt,
            radius_m: vent.radius + vent.fissure.length() as f64,
            kind: AirHeatKind::Fountain,
        };
        match sources {
            Some(mut s) => AirHeatSources::set_kind(&mut s, AirHeatKind::Fountain, [heat]),
            None => {
                commands.entity(entity).insert(AirHeatSources(vec![heat]));
            }
        }
    }
}
