//! "Atmosphere" window (thesis §4.2 authoring): switch between the built-in scenarios, pause
//! and resume the weather, look at any field of any layer as a 2D map with a colour ramp
//! (the per-layer views of Fig 4.6), and paint into the state fields (T, H, W, ash, wind) of
//! any layer with the pointer on the map while the weather is paused.
//!
//! Strokes go through `volcano_atmosphere::paint`, which rejects non-finite values,
//! `Set` values outside a field's limits and brushes outside the domain (shown in red, the
//! state untouched) and clamps additions; amounts never go negative or into terrain.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use volcano_atmosphere::view::{GridSpec, MapField, field_values};
use volcano_atmosphere::{
    AirLayer, Atmosphere, BUILTIN_SCENARIOS, Brush, PaintField, PaintMode, WeatherScenario, WeatherStep,
    paint, spawn_scenario_with,
};
use volcano_core::{ConfigError, DomainClock, Terrain};

/// Window state: what is shown and the brush.
#[derive(Resource, Debug, Clone, Reflect)]
#[reflect(opaque)]
pub struct AtmospherePanel {
    /// Show the window.
    pub visible: bool,
    /// Layer shown and painted (0 = lowest).
    pub layer: usize,
    /// Field shown on the map.
    pub map_field: MapField,
    /// Field painted.
    pub paint_field: PaintField,
    /// Set or add.
    pub mode: PaintMode,
    /// Brush value (or increment).
    pub value: f64,
    /// Brush radius (m).
    pub radius_m: f64,
    /// Steps run at once when a scenario is switched in (developed weather at once).
    pub prespin_steps: u32,
    /// Switched-in scenarios bring their own terrain (ridge, coast, islands) instead of
    /// keeping the scene's.
    pub scenario_terrain: bool,
    /// Message of the last rejected edit or switch.
    pub error: Option<String>,
}

impl Default for AtmospherePanel {
    fn default() -> Self {
        Self {
            visible: true,
            layer: 0,
            map_field: MapField::Water,
            paint_field: PaintField::Temperature,
            mode: PaintMode::Add,
            value: 5.0,
            radius_m: 3000.0,
            prespin_steps: 60,
            scenario_terrain: true,
            error: None,
        }
    }
}

pub(crate) fn build(app: &mut App) {
    app.register_type::<AtmospherePanel>()
        .init_resource::<AtmospherePanel>()
        .add_systems(bevy_egui::EguiPrimaryContextPass, atmosphere_window);
}

/// Colour ramp for maps: `t` in [0, 1] from dark blue through cyan, green and yellow to red
/// (clamped); NaN is mid grey.
pub fn ramp(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [20.0, 30.0, 120.0],
        [30.0, 170.0, 220.0],
        [60.0, 190.0, 90.0],
        [240.0, 220.0, 60.0],
        [200.0, 40.0, 30.0],
    ];
    if t.is_nan() {
        return [128, 128, 128];
    }
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let c = |k: usize| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])).round() as u8;
    [c(0), c(1), c(2)]
}

/// RGB bytes of an `n × n` field (row 0 of the field at the bottom, so north is up) scaled
/// from the 1st to the 99th percentile of its finite values (a few extreme cells do not
/// flatten the rest; values beyond are clamped), and that range. A constant field maps to
/// mid-ramp.
pub fn map_rgb(values: &[f64], n: usize) -> (Vec<u8>, (f64, f64)) {
    let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    finite.sort_by(f64::total_cmp);
    let (lo, hi) = if finite.is_empty() {
        (0.0, 0.0)
    } else {
        let last = (finite.len() - 1) as f64;
        (finite[(0.01 * last).floor() as usize], finite[(0.99 * last).ceil() as usize])
    };
    let span = hi - lo;
    let mut rgb = Vec::with_capacity(n * n * 3);
    for row in (0..n).rev() {
        for col in 0..n {
            let v = values.get(row * n + col).copied().unwrap_or(f64::NAN);
            let t = if !v.is_finite() {
                f64::NAN
            } else if span > 0.0 {
                (v - lo) / span
            } else {
                0.5
            };
            rgb.extend_from_slice(&ramp(t));
        }
    }
    (rgb, (lo, hi))
}

/// Grid position (m, domain centred on 0) under a pointer at `(u, v)` in the map image,
/// both in [0, 1] from its top-left corner (north up).
pub fn map_to_grid(u: f32, v: f32, extent: f64) -> (f64, f64) {
    ((u as f64 - 0.5) * extent, (0.5 - v as f64) * extent)
}

fn field_name(f: MapField) -> &'static str {
    match f {
        MapField::Temperature => "T (K)",
        MapField::Humidity => "H (g/m³)",
        MapField::Water => "W (g/m³)",
        MapField::Ash => "ash (g/m³)",
        MapField::WindX => "wind x (m/s)",
        MapField::WindY => "wind y (m/s)",
        MapField::Pressure => "P (m²/s)",
        MapField::Convection => "C (m/s)",
        MapField::Uplift => "U (m/s)",
        MapField::Vertical => "D (m/s)",
        MapField::Damping => "σ",
    }
}

/// Replaces the atmosphere by scenario `name`, over its own terrain (which then replaces the
/// scene's) or over the scene's terrain.
fn switch_scenario(
    commands: &mut Commands,
    name: &str,
    old: Option<Entity>,
    terrain: Option<(Entity, &Terrain)>,
    panel: &AtmospherePanel,
) -> Result<(), ConfigError> {
    let scenario = WeatherScenario::builtin(name)?;
    let own = if panel.scenario_terrain || terrain.is_none() {
        let state = scenario.build(None)?;
        Some(Terrain::new(state.ground.height.clone(), state.ground.cover.clone(), 0.0)?)
    } else {
        None
    };
    let over = own.as_ref().or(terrain.map(|(_, t)| t));
    spawn_scenario_with(commands, &scenario, None, over, panel.prespin_steps)?;
    if let Some(old) = old {
        commands.entity(old).despawn();
    }
    if let Some(t) = own {
        match terrain {
            Some((e, _)) => {
                commands.entity(e).insert(t);
            }
            None => {
                commands.spawn((Name::new("Terrain"), t));
            }
        }
    }
    Ok(())
}

#[expect(clippy::too_many_arguments, reason = "one window over the atmosphere's entities")]
fn atmosphere_window(
    mut commands: Commands,
    mut contexts: EguiContexts,
    mut panel: ResMut<AtmospherePanel>,
    atmospheres: Query<(Entity, &Atmosphere)>,
    mut layers: Query<&mut AirLayer>,
    terrains: Query<(Entity, &Terrain)>,
    clock: Option<ResMut<Time<DomainClock<WeatherStep>>>>,
    mut texture: Local<Option<(egui::TextureHandle, Vec<u8>)>>,
) -> Result {
    if !panel.visible {
        return Ok(());
    }
    // Only in apps with an atmosphere (the other scenes' windows stay uncluttered).
    let Some(atmo) = atmospheres.iter().min_by_key(|(e, _)| *e) else {
        return Ok(());
    };
    let atmo = Some(atmo);
    let ctx = contexts.ctx_mut()?;
    let mut p = panel.clone();
    let mut switch_to: Option<&str> = None;
    let mut clock = clock;
    let corner = ctx.content_rect().right_top() + egui::vec2(-10.0, 10.0);
    egui::Window::new("Atmosphere")
        .default_width(300.0)
        .pivot(egui::Align2::RIGHT_TOP)
        .default_pos(corner)
        .show(ctx, |ui| {
            ui.horizontal_wrapped(|ui| {
                ui.label("scenario");
                for (name, _) in BUILTIN_SCENARIOS {
                    if ui.button(name).clicked() {
                        switch_to = Some(name);
                    }
                }
            });
            ui.checkbox(&mut p.scenario_terrain, "with the scenario's terrain");
            ui.add(egui::Slider::new(&mut p.prespin_steps, 0..=480).text("pre-spin steps"));
            let paused = clock.as_ref().is_some_and(|c| c.context().is_paused());
            if let Some(clock) = clock.as_deref_mut() {
                ui.horizontal(|ui| {
                    let label = if paused { "▶ Resume weather" } else { "⏸ Pause weather" };
                    if ui.button(label).clicked() {
                        clock.context_mut().set_paused(!paused);
                    }
                    if ui.add_enabled(paused, egui::Button::new("Step")).clicked() {
                        clock.context_mut().request_steps(1);
                    }
                });
                let mut scale = clock.context().time_scale();
                let slider =
                    egui::Slider::new(&mut scale, 1.0..=300.0).logarithmic(true).text("weather s per s");
                if ui.add(slider).changed() && clock.context_mut().set_time_scale(scale).is_err() {
                    p.error = Some(format!("time scale {scale} rejected"));
                }
            }
            let Some((entity, atmo)) = atmo else {
                ui.label("no atmosphere: pick a scenario");
                return;
            };
            let hour = (atmo.start_hour + atmo.time_s / 3600.0).rem_euclid(24.0);
            ui.label(format!("weather time {:.0} min (local {hour:.1} h)", atmo.time_s / 60.0));
            let mut mine: Vec<Mut<AirLayer>> = layers.iter_mut().filter(|l| l.atmosphere == entity).collect();
            mine.sort_by_key(|l| l.index);
            if mine.is_empty() {
                return;
            }
            p.layer = p.layer.min(mine.len() - 1);
            ui.horizontal(|ui| {
                ui.add(egui::Slider::new(&mut p.layer, 0..=mine.len() - 1).text("layer"));
                ui.label(format!("{:.0} m", mine[p.layer].fields.altitude));
            });
            egui::ComboBox::from_label("map").selected_text(field_name(p.map_field)).show_ui(ui, |ui| {
                for f in MapField::ALL {
                    ui.selectable_value(&mut p.map_field, f, field_name(f));
                }
            });
            let n = mine[p.layer].fields.t.nx();
            let values = field_values(&mine[p.layer].fields, p.map_field);
            let (rgb, (lo, hi)) = map_rgb(&values, n);
            // Upload only when the picture changes: a texture replaced every frame is never
            // ready to draw on a slow (software) renderer.
            let image = || egui::ColorImage::from_rgb([n, n], &rgb);
            let (tex, shown) = texture.get_or_insert_with(|| {
                let t = ui.ctx().load_texture("atmosphere_map", image(), egui::TextureOptions::NEAREST);
                (t, rgb.clone())
            });
            if *shown != rgb {
                tex.set(image(), egui::TextureOptions::NEAREST);
                *shown = rgb.clone();
            }
            let response = ui.add(
                egui::Image::new((tex.id(), egui::vec2(256.0, 256.0))).sense(egui::Sense::click_and_drag()),
            );
            ui.label(format!("{lo:.3} … {hi:.3}   (blue to red)"));
            ui.separator();
            ui.label(egui::RichText::new("Paint (weather paused)").strong());
            egui::ComboBox::from_label("field").selected_text(p.paint_field.label()).show_ui(ui, |ui| {
                for f in PaintField::ALL {
                    ui.selectable_value(&mut p.paint_field, f, f.label());
                }
            });
            ui.horizontal(|ui| {
                ui.radio_value(&mut p.mode, PaintMode::Add, "add");
                ui.radio_value(&mut p.mode, PaintMode::Set, "set");
                ui.add(egui::DragValue::new(&mut p.value).speed(0.1).prefix("value "));
            });
            ui.add(egui::Slider::new(&mut p.radius_m, 200.0..=20_000.0).logarithmic(true).text("radius (m)"));
            let pointer =
                response.interact_pointer_pos().filter(|_| response.dragged() || response.clicked());
            if let Some(pos) = pointer {
                if !paused {
                    p.error = Some("pause the weather to paint".into());
                } else {
                    let r = response.rect;
                    let (u, v) = ((pos.x - r.left()) / r.width(), (pos.y - r.top()) / r.height());
                    let Ok(grid) = GridSpec::new(atmo.n, atmo.dx) else { return };
                    let (x_m, y_m) = map_to_grid(u, v, grid.extent());
                    let brush = Brush {
                        field: p.paint_field,
                        mode: p.mode,
                        value: p.value,
                        x_m,
                        y_m,
                        radius_m: p.radius_m,
                    };
                    let layer = &mut mine[p.layer];
                    // A rejected stroke leaves the layer untouched (checked before writing).
                    match brush.validate(grid).and_then(|_| paint(&mut layer.fields, grid, &brush)) {
                        Ok(_) => p.error = None,
                        Err(e) => p.error = Some(e.to_string()),
                    }
                }
            }
            if let Some(msg) = &p.error {
                ui.colored_label(egui::Color32::from_rgb(230, 80, 60), format!("rejected: {msg}"));
            }
        });
    if let Some(name) = switch_to {
        let old = atmo.map(|(e, _)| e);
        let terrain = terrains.iter().next();
        match switch_scenario(&mut commands, name, old, terrain, &p) {
            Ok(()) => p.error = None,
            Err(e) => p.error = Some(format!("{name}: {e}")),
        }
    }
    if p.layer != panel.layer
        || p.map_field != panel.map_field
        || p.paint_field != panel.paint_field
        || p.mode != panel.mode
        || p.value != panel.value
        || p.radius_m != panel.radius_m
        || p.prespin_steps != panel.prespin_steps
        || p.scenario_terrain != panel.scenario_terrain
        || p.error != panel.error
    {
        *panel = p;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_ends_and_nan() {
        assert_eq!(ramp(0.0), [20, 30, 120]);
        assert_eq!(ramp(1.0), [200, 40, 30]);
        assert_eq!(ramp(-5.0), ramp(0.0));
        assert_eq!(ramp(7.0), ramp(1.0));
        assert_eq!(ramp(f64::NAN), [128, 128, 128]);
        // Halfway between stops 1 and 2 (t = 0.375).
        assert_eq!(ramp(0.375), [45, 180, 155]);
    }

    #[test]
    fn map_is_scaled_and_north_up() {
        let n = 2;
        // Row 0 (south) = [0, 1], row 1 (north) = [2, NaN].
        let (rgb, range) = map_rgb(&[0.0, 1.0, 2.0, f64::NAN], n);
        assert_eq!(range, (0.0, 2.0));
        // First image row is the north row.
        assert_eq!(&rgb[0..3], &ramp(1.0));
        assert_eq!(&rgb[3..6], &[128, 128, 128]);
        assert_eq!(&rgb[6..9], &ramp(0.0));
        assert_eq!(&rgb[9..12], &ramp(0.5));
        // One extreme cell among 400 does not set the scale.
        let mut v = vec![1.0; 400];
        v[7] = 1e6;
        v[8] = 0.0;
        let (_, r) = map_rgb(&v, 20);
        assert_eq!(r, (1.0, 1.0));
        let v: Vec<f64> = (0..400).map(|i| if i == 3 { 1e6 } else { (i % 20) as f64 }).collect();
        let (_, r) = map_rgb(&v, 20);
        assert_eq!(r, (0.0, 19.0));
        let (flat, r) = map_rgb(&[3.0; 4], 2);
        assert_eq!(r, (3.0, 3.0));
        assert!(flat.chunks(3).all(|c| c == ramp(0.5)));
    }

    #[test]
    fn pointer_maps_to_the_grid_north_up() {
        assert_eq!(map_to_grid(0.5, 0.5, 1000.0), (0.0, 0.0));
        assert_eq!(map_to_grid(0.0, 0.0, 1000.0), (-500.0, 500.0));
        assert_eq!(map_to_grid(1.0, 1.0, 1000.0), (500.0, -500.0));
    }
}
