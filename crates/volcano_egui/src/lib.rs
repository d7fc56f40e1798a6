//! egui tuning panels for the volcano plugin set (bevy_egui 0.40, the version
//! bevy-inspector-egui 0.37 uses, so both can share an app).
//!
//! [`VolcanoEguiPlugin`] adds `EguiPlugin` unless the app already has it, draws a "Volcano" side
//! panel (simulation pause/step/speed, tick counters, frame time and FPS) and an "Eruption"
//! window ([`EruptionPanel`]: every eruption parameter, presets, wind, view, live density plot) in
//! `EguiPrimaryContextPass`, and keeps [`volcano_render::PointerCaptured`] up to date so the
//! orbit camera ignores the mouse while egui uses it.

mod atmosphere;
mod eruption;
mod lava;

pub use atmosphere::{AtmospherePanel, map_rgb, map_to_grid, ramp};
pub use eruption::EruptionPanel;
pub use lava::LavaPanel;

use bevy::prelude::*;
use bevy::time::Real;
use bevy_egui::input::EguiWantsInput;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};
use volcano_core::units::BASE_TICK_SECONDS;
use volcano_core::{SimControl, SimTick};
use volcano_render::PointerCaptured;

/// Range of the simulation speed slider (multiples of real time).
pub const SPEED_RANGE: std::ops::RangeInclusive<f32> = 0.1..=4.0;

/// The volcano tuning panel. Needs a render app with a window (`DefaultPlugins`) and
/// `volcano_core::VolcanoCorePlugin`; works alongside another egui user: it adds `EguiPlugin`
/// only if missing, so an app that configures its own must add it *before* this plugin.
///
/// The panel draws on the primary egui context, which bevy_egui puts on the first camera. With
/// bevy_egui 0.40 nothing is drawn on an HDR camera (seen with llvmpipe), which is why
/// `volcano_render::camera_bundle` cameras are LDR.
#[derive(Debug, Default, Clone)]
pub struct VolcanoEguiPlugin;

impl Plugin for VolcanoEguiPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<EguiPlugin>() {
            app.add_plugins(EguiPlugin::default());
        }
        app.register_type::<PanelState>()
            .init_resource::<PanelState>()
            .init_resource::<PointerCaptured>()
            .add_systems(PreUpdate, capture_pointer)
            .add_systems(Update, measure_frame_time)
            .add_systems(EguiPrimaryContextPass, volcano_panel);
        eruption::build(app);
        lava::build(app);
        atmosphere::build(app);
    }
}

/// Panel state: whether it is shown and the smoothed frame time.
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource, Debug, Default)]
pub struct PanelState {
    /// Show the panel.
    pub visible: bool,
    /// Exponentially smoothed real frame time (seconds); 0 until the first frame.
    pub frame_time: f64,
}

impl Default for PanelState {
    fn default() -> Self {
        Self { visible: true, frame_time: 0.0 }
    }
}

impl PanelState {
    /// Smoothing weight of the newest frame in [`PanelState::frame_time`].
    pub const SMOOTHING: f64 = 0.05;

    /// Folds one frame's duration (seconds) into the smoothed frame time.
    pub fn record_frame(&mut self, dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        self.frame_time = if self.frame_time > 0.0 {
            self.frame_time + Self::SMOOTHING * (dt - self.frame_time)
        } else {
            dt
        };
    }

    /// Frames per second from the smoothed frame time (0 before the first frame).
    pub fn fps(&self) -> f64 {
        if self.frame_time > 0.0 { 1.0 / self.frame_time } else { 0.0 }
    }
}

/// Mirrors egui's pointer use into [`PointerCaptured`] (egui writes `EguiWantsInput` at the end of
/// the previous frame; this runs before the camera reads the mouse).
fn capture_pointer(wants: Option<Res<EguiWantsInput>>, mut captured: ResMut<PointerCaptured>) {
    let busy = wants.is_some_and(|w| w.wants_pointer_input() || w.is_using_pointer() || w.is_popup_open());
    if captured.0 != busy {
        captured.0 = busy;
    }
}

fn measure_frame_time(time: Res<Time<Real>>, mut panel: ResMut<PanelState>) {
    panel.record_frame(time.delta_secs_f64());
}

/// Simulated time in seconds for a number of base ticks.
pub fn simulated_seconds(ticks: u64) -> f64 {
    ticks as f64 * BASE_TICK_SECONDS
}

fn volcano_panel(
    mut contexts: EguiContexts,
    panel: Res<PanelState>,
    control: Option<ResMut<SimControl>>,
    tick: Option<Res<SimTick>>,
    mut virtual_time: ResMut<Time<Virtual>>,
) -> Result {
    if !panel.visible {
        return Ok(());
    }
    let ctx = contexts.ctx_mut()?;
    let mut control = control;
    #[expect(
        deprecated,
        reason = "Panel::show_inside needs a parent Ui; the context-level show is fine here"
    )]
    egui::Panel::left("Volcano").resizable(true).default_size(220.0).show(ctx, |ui| {
        ui.heading("Volcano");
        ui.separator();
        ui.label(egui::RichText::new("Simulation").strong());
        match control.as_deref_mut() {
            Some(control) => {
                ui.horizontal(|ui| {
                    let label = if control.paused { "▶ Resume" } else { "⏸ Pause" };
                    if ui.button(label).clicked() {
                        control.paused = !control.paused;
                    }
                    if ui.add_enabled(control.paused, egui::Button::new("Step")).clicked() {
                        control.step_ticks(1);
                    }
                });
                if control.pending_ticks() > 0 {
                    ui.label(format!("{} tick(s) pending", control.pending_ticks()));
                }
            }
            None => {
                ui.label("(no VolcanoCorePlugin)");
            }
        }
        let mut speed = virtual_time.relative_speed();
        let slider = egui::Slider::new(&mut speed, SPEED_RANGE).logarithmic(true).suffix("×").text("speed");
        if ui.add(slider).changed() && speed.is_finite() {
            virtual_time.set_relative_speed(speed.clamp(*SPEED_RANGE.start(), *SPEED_RANGE.end()));
        }
        let ticks = tick.map_or(0, |t| t.0);
        egui::Grid::new("volcano_sim_stats").num_columns(2).show(ui, |ui| {
            ui.label("ticks");
            ui.monospace(format!("{ticks}"));
            ui.end_row();
            ui.label("simulated");
            ui.monospace(format!("{:.2} s", simulated_seconds(ticks)));
            ui.end_row();
        });
        ui.separator();
        ui.label(egui::RichText::new("Performance").strong());
        egui::Grid::new("volcano_perf_stats").num_columns(2).show(ui, |ui| {
            ui.label("frame");
            ui.monospace(format!("{:.1} ms", panel.frame_time * 1e3));
            ui.end_row();
            ui.label("FPS");
            ui.monospace(format!("{:.0}", panel.fps()));
            ui.end_row();
        });
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothing_and_fps() {
        let mut p = PanelState::default();
        assert_eq!(p.fps(), 0.0);
        p.record_frame(0.02);
        assert!((p.fps() - 50.0).abs() < 1e-9);
        p.record_frame(f64::NAN);
        p.record_frame(-1.0);
        assert!((p.frame_time - 0.02).abs() < 1e-12);
        for _ in 0..500 {
            p.record_frame(0.01);
        }
        assert!((p.frame_time - 0.01).abs() < 1e-6);
        assert!((simulated_seconds(150) - 3.0).abs() < 1e-12);
    }
}
