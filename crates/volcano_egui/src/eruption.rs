//! "Eruption" window: every eruption parameter of the first volcano with an [`Eruption`], the
//! preset switch, the wind, the pyroclastic-flow parameters, sphere counts, the column's view mode, and a live plot of slice
//! density against altitude with the ambient air (thesis Fig 3.5 A, live).
//!
//! Edits are made on a copy and written back only if [`Eruption::validate`] accepts them; a
//! rejected edit shows the validation message and leaves the running eruption untouched.
//! Like the model, edits of v₀, ρ₀, r₀, T₀ and wind apply to slices emitted afterwards.

use bevy::prelude::*;
use bevy_egui::{EguiContexts, egui};
use egui_plot::{Legend, Line, Plot, PlotPoints, Points};
use volcano_core::atmosphere::AtmosphereModel;
use volcano_plume::{Eruption, PlumeSlice, PlumeViewSettings, Preset, WindProfile};
use volcano_render::PlumeRenderMode;

/// Window state: visibility and the last rejected edit.
#[derive(Resource, Debug, Clone, Default, Reflect)]
#[reflect(Resource)]
pub struct EruptionPanel {
    /// Show the window.
    pub visible: bool,
    /// Message of the last edit the validation rejected (cleared by a valid edit).
    pub error: Option<String>,
}

pub(crate) fn build(app: &mut App) {
    app.register_type::<EruptionPanel>()
        .insert_resource(EruptionPanel { visible: true, error: None })
        .add_systems(bevy_egui::EguiPrimaryContextPass, eruption_window);
}

fn slider(ui: &mut egui::Ui, value: &mut f64, range: std::ops::RangeInclusive<f64>, text: &str) -> bool {
    ui.add(egui::Slider::new(value, range).text(text)).changed()
}

fn log_slider(ui: &mut egui::Ui, value: &mut f64, range: std::ops::RangeInclusive<f64>, text: &str) -> bool {
    ui.add(egui::Slider::new(value, range).logarithmic(true).text(text)).changed()
}

/// Draws the parameter widgets on `e`; returns whether anything changed.
fn parameter_widgets(ui: &mut egui::Ui, e: &mut Eruption) -> bool {
    let mut changed = false;
    ui.horizontal(|ui| {
        ui.label("preset");
        for preset in Preset::ALL {
            if ui.button(preset.name()).clicked() {
                e.params = preset.params();
                changed = true;
            }
        }
    });
    changed |= ui.checkbox(&mut e.active, "erupting").changed();
    let p = &mut e.params;
    egui::CollapsingHeader::new("Vent (new slices)").default_open(true).show(ui, |ui| {
        changed |= slider(ui, &mut p.v0, 10.0..=400.0, "v₀ (m/s)");
        changed |= slider(ui, &mut p.r0, 5.0..=500.0, "r₀ (m)");
        changed |= log_slider(ui, &mut p.rho0, 0.5..=1000.0, "ρ₀ (kg/m³)");
        changed |= slider(ui, &mut p.t0, 300.0..=1600.0, "T₀ (K)");
        changed |= slider(ui, &mut p.vent_altitude, -500.0..=6000.0, "vent altitude (m)");
    });
    egui::CollapsingHeader::new("Slice model").show(ui, |ui| {
        changed |= slider(ui, &mut p.drag_coefficient, 0.0..=2.0, "C_d drag");
        changed |= slider(ui, &mut p.wind_coefficient, 0.0..=2000.0, "λ wind");
        changed |= slider(ui, &mut p.ks, 0.0..=0.5, "k_s entrainment");
        changed |= slider(ui, &mut p.kw, 0.0..=2.0, "k_w entrainment");
        changed |= slider(ui, &mut p.tau, 0.1..=30.0, "τ (s)");
        changed |= log_slider(ui, &mut p.sigma_col, 1e-9..=1e-2, "σ_col (kg/m³/s)");
        changed |= ui.checkbox(&mut p.contraction, "contraction on mixing").changed();
        ui.horizontal(|ui| {
            ui.label("atmosphere");
            for (m, name) in
                [(AtmosphereModel::Thesis, "thesis"), (AtmosphereModel::UsStandard1976, "US 1976")]
            {
                changed |= ui.radio_value(&mut p.atmosphere, m, name).changed();
            }
        });
    });
    egui::CollapsingHeader::new("Wind").default_open(true).show(ui, |ui| {
        let (mut max, mut top, mut dir) = match p.wind {
            WindProfile::Linear { max, top, direction_deg } => (max, top, direction_deg),
            WindProfile::Calm => (0.0, 12_000.0, 0.0),
            WindProfile::Table(_) => {
                ui.label("table profile (edit it in the preset file)");
                return;
            }
        };
        let mut c = slider(ui, &mut max, 0.0..=WindProfile::MAX_SPEED, "speed at top (m/s)");
        c |= slider(ui, &mut top, 1_000.0..=20_000.0, "top (m)");
        c |= slider(ui, &mut dir, 0.0..=360.0, "toward (° ccw from +x)");
        if c {
            p.wind = if max > 0.0 {
                WindProfile::Linear { max, top, direction_deg: dir }
            } else {
                WindProfile::Calm
            };
            changed = true;
        }
    });
    egui::CollapsingHeader::new("Pyroclastic flows").show(ui, |ui| {
        let py = &mut e.pyroclastic;
        changed |= slider(ui, &mut py.sigma_pyr, 0.0..=2.0, "σ_pyr (kg/m³/s)");
        changed |= slider(ui, &mut py.cluster_radius, 5.0..=500.0, "cluster radius r_pyr (m)");
        changed |= ui.add(egui::Slider::new(&mut py.min_cluster, 1..=200).text("min cluster size")).changed();
        changed |= slider(ui, &mut py.drag_coefficient, 0.0..=2.0, "sphere C_d");
        changed |= slider(ui, &mut py.wind_coefficient, 0.0..=50.0, "sphere λ");
        changed |= slider(ui, &mut py.deposit_density, 200.0..=3000.0, "deposit density (kg/m³)");
        changed |= slider(ui, &mut py.settle_speed, 0.0..=5.0, "settle speed (m/s)");
        changed |= slider(ui, &mut py.repose_angle_deg, 5.0..=60.0, "deposit repose angle (°)");
    });
    egui::CollapsingHeader::new("Spheres").show(ui, |ui| {
        let s = &mut e.spheres;
        changed |= ui.add(egui::Slider::new(&mut s.s1_per_slice, 1..=64).text("s1 per slice")).changed();
        changed |= slider(ui, &mut s.size_jitter, 0.0..=0.9, "size jitter");
        changed |= slider(ui, &mut s.radial_jitter, 0.0..=0.6, "radial jitter");
        changed |= ui.add(egui::Slider::new(&mut s.s2_per_s1, 0..=500).text("s2 per s1")).changed();
        changed |= ui.add(egui::Slider::new(&mut s.s3_per_s2, 0..=100).text("s3 per s2")).changed();
        changed |= slider(ui, &mut e.umbrella_lifetime, 0.0..=3600.0, "umbrella lifetime (s)");
    });
    changed
}

fn view_widgets(ui: &mut egui::Ui, mode: &mut PlumeRenderMode, view: &mut PlumeViewSettings) {
    egui::CollapsingHeader::new("View").show(ui, |ui| {
        ui.horizontal_wrapped(|ui| {
            for (m, name) in [
                (PlumeRenderMode::Ash, "ash"),
                (PlumeRenderMode::AshWithSlices, "ash + slices"),
                (PlumeRenderMode::DebugSpheres, "s1 spheres"),
                (PlumeRenderMode::DebugSlices, "slices"),
            ] {
                ui.radio_value(mode, m, name);
            }
        });
        ui.checkbox(&mut view.billboards, "smoke billboards");
        ui.checkbox(&mut view.detail, "detail spheres");
        ui.add(egui::Slider::new(&mut view.max_instances, 0..=3_000_000).text("max instances"));
        ui.add(egui::Slider::new(&mut view.billboard_scale, 0.5..=3.0).text("puff size"));
    });
}

/// Live Fig 3.5 A: every live slice's density at its altitude, and the air profile.
fn density_plot(ui: &mut egui::Ui, e: &Eruption, slices: &[[f64; 2]]) {
    let air = e.params.atmosphere.profile();
    let top = slices.iter().map(|p| p[1]).fold(2_000.0_f64, f64::max) * 1.1;
    let air_line: PlotPoints = (0..=60)
        .map(|i| {
            let z = top * i as f64 / 60.0;
            [air.density(e.params.vent_altitude + z).max(1e-6).log10(), z]
        })
        .collect();
    Plot::new("density_vs_altitude")
        .height(220.0)
        .legend(Legend::default())
        .x_axis_label("log₁₀ ρ (kg/m³)")
        .y_axis_label("altitude above vent (m)")
        .show(ui, |plot| {
            plot.line(Line::new("air", air_line));
            plot.points(Points::new("slices", PlotPoints::from(slices.to_vec())).radius(2.0));
        });
}

fn eruption_window(
    mut contexts: EguiContexts,
    mut panel: ResMut<EruptionPanel>,
    mut eruptions: Query<(Entity, &mut Eruption)>,
    slices: Query<&PlumeSlice>,
    mut mode: Option<ResMut<PlumeRenderMode>>,
    mut view: Option<ResMut<PlumeViewSettings>>,
) -> Result {
    if !panel.visible {
        return Ok(());
    }
    let Some((entity, mut eruption)) = eruptions.iter_mut().min_by_key(|(e, _)| *e) else {
        return Ok(());
    };
    let ctx = contexts.ctx_mut()?;
    let mut edited = eruption.clone();
    let mut changed = false;
    let points: Vec<[f64; 2]> = slices
        .iter()
        .filter(|s| s.volcano == entity)
        .map(|s| [s.state.density.max(1e-6).log10(), s.state.position.z])
        .collect();
    let mut error = panel.error.clone();
    // Top right, clear of the "Volcano" side panel on the left.
    let corner = ctx.content_rect().right_top() + egui::vec2(-10.0, 10.0);
    egui::Window::new("Eruption")
        .default_width(320.0)
        .pivot(egui::Align2::RIGHT_TOP)
        .default_pos(corner)
        .show(ctx, |ui| {
            egui::ScrollArea::vertical().max_height(420.0).show(ui, |ui| {
                changed = parameter_widgets(ui, &mut edited);
                if let (Some(mode), Some(view)) = (mode.as_deref_mut(), view.as_deref_mut()) {
                    let (mut m, mut v) = (*mode, view.clone());
                    view_widgets(ui, &mut m, &mut v);
                    if m != *mode {
                        *mode = m;
                    }
                    if v != *view {
                        *view = v;
                    }
                }
            });
            if let Some(msg) = &error {
                ui.colored_label(egui::Color32::from_rgb(230, 80, 60), format!("rejected: {msg}"));
            }
            ui.label(format!("{} live slices", points.len()));
            density_plot(ui, &edited, &points);
        });
    if changed {
        match edited.validate() {
            Ok(()) => {
                *eruption = edited;
                error = None;
            }
            Err(e) => error = Some(e.to_string()),
        }
    }
    if panel.error != error {
        panel.error = error;
    }
    Ok(())
}
