//! "Lava" window (shown while a `LavaField` exists): the lava patches, the state and parameters
//! of the selected one (viscosity, cooling, crust, folds), the test terrains of thesis
//! Fig 5.10, sources, and the lava view. Ctrl + left click on a terrain places a `LavaSource`
//! there: on the patch under the click, or on a new patch started on whichever terrain was
//! clicked (the "new patch" size and rate of the window); a button starts one at the view
//! centre.
//!
//! Edits are made on a copy and written back only if `LavaParams::validate` and
//! `FoldParams::validate` accept them; a rejected edit shows the message in red and leaves the
//! running field untouched.

use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_egui::{EguiContexts, egui};
use volcano_core::Terrain;
use volcano_lava::{
    FoldParams, LavaField, LavaFieldStatus, LavaParams, LavaSource, LavaState, Placement, ScenarioKind,
    ViscosityModel, scenario_terrain,
};
use volcano_render::{LavaRenderMode, LavaRenderSettings, OrbitCamera, PointerCaptured, VolcanoViewer};

/// Window state.
#[derive(Resource, Debug, Clone, Reflect)]
#[reflect(Resource)]
pub struct LavaPanel {
    /// Show the window.
    pub visible: bool,
    /// Message of the last edit the validation rejected (cleared by a valid edit).
    pub error: Option<String>,
    /// Slope (degrees) of the test terrains the switch builds.
    pub slope_deg: f64,
    /// Rate (m³/s) of sources placed by Ctrl + click.
    pub new_source_rate: f64,
    /// The Fig 5.10 table last chosen; "restart" rebuilds it (the scene starts on the long
    /// obstacle).
    #[reflect(ignore)]
    pub table: ScenarioKind,
    /// The patch shown and edited (the first one if unset or gone).
    pub selected: Option<Entity>,
    /// Cells per side of a patch started by Ctrl + click off every patch.
    pub new_patch_cells: u32,
    /// Cell size (m) of such a patch.
    pub new_patch_cell: f64,
}

impl Default for LavaPanel {
    fn default() -> Self {
        Self {
            visible: true,
            error: None,
            slope_deg: 3.0,
            new_source_rate: 1.0,
            table: ScenarioKind::Obstacle,
            selected: None,
            new_patch_cells: 256,
            new_patch_cell: 1.0,
        }
    }
}

/// Whether the "Lava" window was drawn in the last egui pass (Ctrl + click acts only then).
#[derive(Resource, Debug, Default)]
struct LavaWindowShown(bool);

pub(crate) fn build(app: &mut App) {
    app.register_type::<LavaPanel>()
        .init_resource::<LavaPanel>()
        .init_resource::<LavaWindowShown>()
        .add_systems(Update, place_source_on_click)
        .add_systems(bevy_egui::EguiPrimaryContextPass, lava_window);
}

fn slider(ui: &mut egui::Ui, value: &mut f64, range: std::ops::RangeInclusive<f64>, text: &str) -> bool {
    ui.add(egui::Slider::new(value, range).text(text)).changed()
}

fn drag(ui: &mut egui::Ui, value: &mut f64, speed: f64, text: &str) -> bool {
    ui.horizontal(|ui| {
        let c = ui.add(egui::DragValue::new(value).speed(speed)).changed();
        ui.label(text);
        c
    })
    .inner
}

/// Viscosity, cooling and crust widgets; returns whether anything changed.
fn param_widgets(ui: &mut egui::Ui, p: &mut LavaParams) -> bool {
    let mut changed = false;
    egui::CollapsingHeader::new("Viscosity").default_open(true).show(ui, |ui| {
        let vft = !matches!(p.viscosity, ViscosityModel::Constant(_));
        ui.horizontal(|ui| {
            if ui.radio(vft, "VFT (FLOWGO basalt)").clicked() && !vft {
                p.viscosity = ViscosityModel::FLOWGO_BASALT;
                changed = true;
            }
            if ui.radio(!vft, "constant").clicked() && vft {
                p.viscosity = ViscosityModel::Constant(1000.0);
                changed = true;
            }
        });
        match &mut p.viscosity {
            ViscosityModel::Constant(eta) => {
                changed |=
                    ui.add(egui::Slider::new(eta, 1.0..=1e6).logarithmic(true).text("η (Pa·s)")).changed();
            }
            ViscosityModel::Vft { a, b, c } => {
                changed |= drag(ui, a, 0.01, "A (log10 Pa·s)");
                changed |= drag(ui, b, 1.0, "B (K)");
                changed |= drag(ui, c, 1.0, "C (K)");
            }
            ViscosityModel::Crystallising { phi_hot, phi_cold, .. } => {
                ui.label("VFT melt with crystals (Einstein–Roscoe)");
                changed |= slider(ui, phi_hot, 0.0..=0.5, "crystals, hot");
                changed |= slider(ui, phi_cold, 0.0..=0.57, "crystals, cold");
                *phi_cold = phi_cold.max(*phi_hot);
            }
        }
        changed |= slider(ui, &mut p.yield_strength, 0.0..=5000.0, "yield strength (Pa)");
    });
    egui::CollapsingHeader::new("Cooling").show(ui, |ui| {
        changed |= ui.checkbox(&mut p.cooling, "cooling").changed();
        changed |= slider(ui, &mut p.emissivity, 0.0..=1.0, "emissivity");
        changed |= slider(ui, &mut p.convection, 0.0..=200.0, "convection (W/m²/K)");
        changed |= slider(ui, &mut p.base_heat_transfer, 0.0..=200.0, "base transfer (W/m²/K)");
        changed |= drag(ui, &mut p.liquidus, 1.0, "liquidus (K)");
        changed |= drag(ui, &mut p.solidus, 1.0, "solidus (K)");
    });
    egui::CollapsingHeader::new("Crust").show(ui, |ui| {
        changed |= slider(ui, &mut p.rigid_crust, 0.005..=0.1, "rigid crust (m)");
        changed |= slider(ui, &mut p.crust_reset_ratio, 0.0..=1.0, "reset ratio");
        changed |= ui.checkbox(&mut p.crust_drag, "crust slows the flow").changed();
        changed |= ui
            .add(
                egui::Slider::new(&mut p.crust_viscosity_ratio, 1.0..=1e6)
                    .logarithmic(true)
                    .text("ν_crust/ν_lava (5.4)"),
            )
            .changed();
        changed |= slider(ui, &mut p.breakout_inflation, 0.01..=2.0, "breakout inflation (m)");
    });
    changed
}

/// Fold widgets; returns whether anything changed.
fn fold_widgets(ui: &mut egui::Ui, f: &mut FoldParams) -> bool {
    let mut changed = false;
    egui::CollapsingHeader::new("Folds").show(ui, |ui| {
        changed |= ui.checkbox(&mut f.enabled, "folds").changed();
        changed |= ui.checkbox(&mut f.rolling, "rolling collisions (§5.5.2.3)").changed();
        changed |= slider(ui, &mut f.first_min_crust, 0.0..=0.05, "first: min crust (m)");
        changed |= slider(ui, &mut f.first_min_lava, 0.0..=2.0, "first: min lava (m)");
        changed |= slider(ui, &mut f.first_min_height_diff, 0.0..=1.0, "first: min height diff (m)");
        changed |= slider(ui, &mut f.next_min_crust, 0.0..=0.05, "next: min crust (m)");
        changed |= slider(ui, &mut f.next_min_lava, 0.0..=2.0, "next: min lava (m)");
        changed |= slider(ui, &mut f.chain_min_crust, 0.0..=0.05, "chain: min crust (m)");
        changed |= slider(ui, &mut f.particle_length, 0.05..=2.0, "particle length L (m)");
        changed |= slider(ui, &mut f.rise_time, 0.0..=30.0, "rise time (s)");
        changed |= slider(ui, &mut f.bury_depth, 0.0..=1.0, "bury overridden within (× contact)");
    });
    changed
}

/// Replaces the terrain by the Fig 5.10 table `kind` (same size) and restarts the field.
fn switch_terrain(
    commands: &mut Commands,
    kind: ScenarioKind,
    slope: f64,
    terrain: (Entity, &Terrain),
    field: (Entity, &LavaField),
) -> Result<(), String> {
    let (n, cell) = (field.1.placement.nx, field.1.placement.cell);
    let margin = terrain.1.heights().nx().saturating_sub(n) / 2;
    let t = scenario_terrain(kind, n, cell, slope, margin).map_err(|e| e.to_string())?;
    commands.entity(terrain.0).insert(t);
    restart(commands, field);
    Ok(())
}

/// Respawns the field (its lava, crust and folds are lost; sources stay).
fn restart(commands: &mut Commands, (entity, field): (Entity, &LavaField)) {
    commands.entity(entity).despawn();
    commands.spawn((Name::new("Lava field"), field.clone()));
}

#[allow(clippy::too_many_arguments)]
fn lava_window(
    mut commands: Commands,
    mut contexts: EguiContexts,
    mut panel: ResMut<LavaPanel>,
    mut fields: Query<(Entity, &mut LavaField, Option<&LavaState>, Option<&LavaFieldStatus>)>,
    terrains: Query<(Entity, &Terrain)>,
    mut sources: Query<(Entity, &mut LavaSource)>,
    mut mode: Option<ResMut<LavaRenderMode>>,
    mut settings: Option<ResMut<LavaRenderSettings>>,
    cameras: Query<&OrbitCamera, With<VolcanoViewer>>,
    mut shown: ResMut<LavaWindowShown>,
) -> Result {
    shown.0 = false;
    if !panel.visible {
        return Ok(());
    }
    let mut patches: Vec<Entity> = fields.iter().map(|(e, ..)| e).collect();
    patches.sort_unstable();
    let Some(&first) = patches.first() else { return Ok(()) };
    let chosen = panel.selected.filter(|e| patches.contains(e)).unwrap_or(first);
    let Ok((entity, mut field, state, status)) = fields.get_mut(chosen) else { return Ok(()) };
    // The terrain under the selected patch (the first terrain before it is built).
    let under = state.and_then(|s| s.imprint.as_ref()).and_then(|l| terrains.get(l.terrain).ok());
    let table_terrain = under.or_else(|| terrains.iter().min_by_key(|(e, _)| *e));
    let mut selected = chosen;
    let ctx = contexts.ctx_mut()?;
    shown.0 = true;
    let mut edited = field.clone();
    let mut changed = false;
    let mut error = panel.error.clone();
    let corner = ctx.content_rect().right_top() + egui::vec2(-10.0, 10.0);
    egui::Window::new("Lava").default_width(330.0).pivot(egui::Align2::RIGHT_TOP).default_pos(corner).show(
        ctx,
        |ui| {
            ui.horizontal(|ui| {
                ui.label(format!("{} patch(es):", patches.len()));
                egui::ComboBox::from_id_salt("lava patch")
                    .selected_text(format!("{selected}"))
                    .show_ui(ui, |ui| {
                        for &p in &patches {
                            ui.selectable_value(&mut selected, p, format!("{p}"));
                        }
                    });
                if ui.button("✖ remove").on_hover_text("its frozen lava stays in the terrain").clicked() {
                    commands.entity(entity).despawn();
                }
            });
            if let Some(s) = state {
                let b = s.flow.budget();
                ui.label(format!(
                    "t = {:.1} s · {:.1} m³ liquid · {:.1} m³ frozen · {} substeps",
                    s.flow.time(),
                    s.flow.lava_volume(),
                    b.solidified,
                    s.last_substeps
                ));
                ui.label(format!(
                    "{} folds · {} particles · {} breakouts",
                    s.folds.fold_count(),
                    s.folds.particle_count(),
                    s.breakouts.count
                ));
            }
            if let Some(LavaFieldStatus::Rejected(msg)) = status {
                ui.colored_label(egui::Color32::from_rgb(230, 80, 60), format!("field rejected: {msg}"));
            }
            ui.horizontal(|ui| {
                ui.label("terrain (Fig 5.10)");
                for (kind, name) in [
                    (ScenarioKind::Obstacle, "long obstacle"),
                    (ScenarioKind::Split, "small obstacle"),
                    (ScenarioKind::Canyon, "canyon"),
                ] {
                    if ui.button(name).clicked()
                        && let Some(t) = table_terrain
                    {
                        match switch_terrain(&mut commands, kind, panel.slope_deg, t, (entity, &field)) {
                            Ok(()) => panel.table = kind,
                            Err(e) => error = Some(e),
                        }
                    }
                }
            });
            ui.horizontal(|ui| {
                ui.add(egui::Slider::new(&mut panel.slope_deg, 0.0..=20.0).text("slope (°)"));
                // Frozen lava is written into the terrain, so a restart rebuilds the table too.
                if ui.button("restart").on_hover_text("fresh table, no lava").clicked()
                    && let Some(t) = table_terrain
                    && let Err(e) =
                        switch_terrain(&mut commands, panel.table, panel.slope_deg, t, (entity, &field))
                {
                    error = Some(e);
                }
            });
            egui::ScrollArea::vertical().max_height(380.0).show(ui, |ui| {
                changed |= param_widgets(ui, &mut edited.params);
                changed |= fold_widgets(ui, &mut edited.folds);
                egui::CollapsingHeader::new("Sources").show(ui, |ui| {
                    ui.label("Ctrl + left click on a patch places a source; elsewhere on a terrain it starts a new patch there.");
                    slider(ui, &mut panel.new_source_rate, 0.0..=5.0, "new source rate (m³/s)");
                    ui.add(egui::Slider::new(&mut panel.new_patch_cells, 16..=512).text("new patch cells"));
                    slider(ui, &mut panel.new_patch_cell, 0.25..=4.0, "new patch cell (m)");
                    if ui.button("new patch at the view centre").clicked()
                        && let Some(focus) = cameras.iter().next().map(|c| c.focus)
                    {
                        let (n, cell, rate) =
                            (panel.new_patch_cells as usize, panel.new_patch_cell, panel.new_source_rate);
                        let xz = Vec2::new(focus.x, focus.z);
                        match start_patch(&mut commands, terrains.iter().map(|(_, t)| t), xz, (n, cell, rate)) {
                            Ok(()) => error = None,
                            Err(e) => error = Some(e),
                        }
                    }
                    for (source_entity, mut src) in &mut sources {
                        ui.horizontal(|ui| {
                            let mut s = src.clone();
                            let mut c =
                                ui.add(egui::Slider::new(&mut s.rate, 0.0..=5.0).text("m³/s")).changed();
                            c |= ui
                                .add(egui::Slider::new(&mut s.temperature, 1100.0..=1600.0).text("K"))
                                .changed();
                            if c && s.validate().is_ok() {
                                *src = s;
                            }
                            if ui.button("✖").clicked() {
                                commands.entity(source_entity).despawn();
                            }
                        });
                    }
                });
                egui::CollapsingHeader::new("View").default_open(true).show(ui, |ui| {
                    if let Some(mode) = mode.as_deref_mut() {
                        let mut m = *mode;
                        for option in LavaRenderMode::ALL {
                            ui.radio_value(&mut m, option, option.label());
                        }
                        if m != *mode {
                            *mode = m;
                        }
                    }
                    if let Some(settings) = settings.as_deref_mut() {
                        let mut s = settings.clone();
                        ui.checkbox(&mut s.show_folds, "fold particles");
                        ui.add(egui::Slider::new(&mut s.emissive_nits, 0.0..=200_000.0).text("glow (nits)"));
                        ui.add(
                            egui::Slider::new(&mut s.rebuild_every_frames, 1..=30)
                                .text("rebuild every N frames"),
                        );
                        if s != *settings {
                            *settings = s;
                        }
                    }
                });
            });
            if let Some(msg) = &error {
                ui.colored_label(egui::Color32::from_rgb(230, 80, 60), format!("rejected: {msg}"));
            }
        },
    );
    if changed {
        match edited.params.validate().and_then(|_| edited.folds.validate()) {
            Ok(()) => {
                *field = edited;
                error = None;
            }
            Err(e) => error = Some(e.to_string()),
        }
    }
    if panel.error != error {
        panel.error = error;
    }
    if panel.selected != Some(selected) {
        panel.selected = Some(selected);
    }
    Ok(())
}

/// Ctrl + left click on a terrain places a source there, only while the "Lava" window is shown
/// and no UI has the pointer: on the patch under the point, or on a new patch (the panel's size)
/// started on the clicked terrain.
#[allow(clippy::too_many_arguments)]
fn place_source_on_click(
    mut commands: Commands,
    buttons: Option<Res<ButtonInput<MouseButton>>>,
    keys: Option<Res<ButtonInput<KeyCode>>>,
    captured: Option<Res<PointerCaptured>>,
    mut panel: ResMut<LavaPanel>,
    shown: Res<LavaWindowShown>,
    windows: Query<&Window, With<PrimaryWindow>>,
    cameras: Query<(&Camera, &GlobalTransform), With<VolcanoViewer>>,
    terrains: Query<(Entity, &Terrain)>,
    fields: Query<&LavaState>,
) {
    let (Some(buttons), Some(keys)) = (buttons, keys) else { return };
    if !(panel.visible && shown.0) {
        return;
    }
    let ctrl = keys.any_pressed([KeyCode::ControlLeft, KeyCode::ControlRight]);
    if !(ctrl && buttons.just_pressed(MouseButton::Left)) || captured.is_some_and(|c| c.0) {
        return;
    }
    let (Ok(window), Some((camera, transform))) = (windows.single(), cameras.iter().next()) else { return };
    let Some(cursor) = window.cursor_position() else { return };
    let Ok(ray) = camera.viewport_to_world(transform, cursor) else { return };
    // The nearest terrain hit along the ray.
    let Some((terrain, hit)) = terrains
        .iter()
        .filter_map(|(_, t)| t.raycast(ray.origin, *ray.direction).map(|h| (t, h)))
        .min_by(|a, b| a.1.distance_squared(ray.origin).total_cmp(&b.1.distance_squared(ray.origin)))
    else {
        return;
    };
    let xz = Vec2::new(hit.x, hit.z);
    let (n, cell, rate) = (panel.new_patch_cells as usize, panel.new_patch_cell, panel.new_source_rate);
    if fields.iter().any(|s| s.flow.cell_at(xz).is_some()) {
        if let Ok(src) = LavaSource::new(rate).and_then(|s| s.at(hit)).and_then(|s| s.with_radius(0.75)) {
            commands.spawn((Name::new("Lava source"), src));
        }
    } else if let Err(e) = start_patch(&mut commands, [terrain], xz, (n, cell, rate)) {
        panel.error = Some(e);
    }
}

/// Starts a patch of `n × n` cells of `cell` m fed `rate` m³/s at the liquidus from `xz`, on
/// the first of `terrains` under that point (placed downslope of it, inside the terrain).
fn start_patch<'a>(
    commands: &mut Commands,
    terrains: impl IntoIterator<Item = &'a Terrain>,
    xz: Vec2,
    (n, cell, rate): (usize, f64, f64),
) -> Result<(), String> {
    let terrain = terrains
        .into_iter()
        .find(|t| t.contains(xz.x, xz.y))
        .ok_or_else(|| format!("no terrain under ({:.0}, {:.0})", xz.x, xz.y))?;
    let placement = Placement::downslope_of(terrain, xz, n, cell).map_err(|e| e.to_string())?;
    let field = LavaField::new(placement, LavaParams::default()).map_err(|e| e.to_string())?;
    let position = Vec3::new(xz.x, terrain.height_at(xz.x, xz.y), xz.y);
    let src = LavaSource::new(rate)
        .and_then(|s| s.at(position))
        .and_then(|s| s.with_radius(0.75))
        .map_err(|e| e.to_string())?;
    commands.spawn((Name::new("Lava field"), field));
    commands.spawn((Name::new("Lava source"), src));
    Ok(())
}
