//! egui tuning panels for the volcano plugin set (bevy_egui 0.40, the version
//! bevy-inspector-egui 0.37 uses, so both can share an app).
//!
//! [`VolcanoDebugPlugins`] (opt-in; not part of `volcano::VolcanoPlugins`) draws, in
//! `EguiPrimaryContextPass`, a "Volcano" side panel ([`VolcanoPanelPlugin`]: simulation
//! pause/step/speed on the volcano's own clocks, tick counters, frame time and FPS), the
//! "Eruption", "Lava" and "Atmosphere" windows (each its own plugin, so any can be disabled),
//! and keeps [`volcano_render::PointerCaptured`] up to date so the orbit camera ignores the mouse
//! while egui uses it.
//!
//! The game adds `EguiPlugin` itself, before or after these plugins (as bevy_egui asks of
//! plugins built on it: they must not add `EguiPlugin` for the user); without it the panels are
//! not drawn and a warning says so.
//!
//! [`EguiOverlayCameraPlugin`] (opt-in, used by the examples) draws egui on its own LDR overlay
//! camera, so the scene camera can be HDR with bloom: bevy_egui 0.40 draws nothing on an HDR
//! camera.
#![forbid(unsafe_code)]

mod atmosphere;
mod eruption;
mod lava;
mod overlay;

pub use atmosphere::{AtmospherePanel, map_rgb, map_to_grid, ramp};
pub use eruption::EruptionPanel;
pub use lava::LavaPanel;
pub use overlay::{EguiOverlayCamera, EguiOverlayCameraPlugin, overlay_camera_bundle};

use bevy::app::{PluginGroup, PluginGroupBuilder};
use bevy::prelude::*;
use bevy::time::Real;
use bevy_egui::input::EguiWantsInput;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};
use volcano_core::{SimControl, SimTick};
use volcano_render::PointerCaptured;

/// Range of the simulation speed slider (multiples of the game's time; see
/// [`SimControl::set_speed`]).
pub const SPEED_RANGE: std::ops::RangeInclusive<f64> = 0.1..=4.0;

/// The debug panels: [`VolcanoPanelPlugin`], [`EruptionPanelPlugin`], [`LavaPanelPlugin`],
/// [`AtmospherePanelPlugin`]. Need a render app with a window (`DefaultPlugins`),
/// `volcano_core::VolcanoCorePlugin` and the game's `EguiPlugin` (added before or after).
///
/// The panels draw on the primary egui context, which bevy_egui puts on the first camera. With
/// bevy_egui 0.40 nothing is drawn on an HDR camera (seen with llvmpipe), which is why
/// `volcano_render::camera_bundle` cameras are LDR; with [`EguiOverlayCameraPlugin`] the
/// context is on an overlay camera of its own and the scene camera may be HDR.
#[derive(Debug, Default, Clone, Copy)]
pub struct VolcanoDebugPlugins;

impl PluginGroup for VolcanoDebugPlugins {
    fn build(self) -> PluginGroupBuilder {
        PluginGroupBuilder::start::<Self>()
            .add(VolcanoPanelPlugin)
            .add(EruptionPanelPlugin)
            .add(LavaPanelPlugin)
            .add(AtmospherePanelPlugin)
    }
}

/// The "Volcano" side panel (pause, step, speed, ticks, simulated time, frame time) and the
/// pointer hand-off to the orbit camera.
#[derive(Debug, Default, Clone)]
pub struct VolcanoPanelPlugin;

impl Plugin for VolcanoPanelPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<PanelState>()
            .init_resource::<PanelState>()
            .init_resource::<PointerCaptured>()
            .add_systems(PreUpdate, capture_pointer)
            .add_systems(Update, measure_frame_time)
            .add_systems(EguiPrimaryContextPass, volcano_panel);
    }

    fn finish(&self, app: &mut App) {
        // In `finish`, so a game may add `EguiPlugin` after these plugins.
        if !app.is_plugin_added::<EguiPlugin>() {
            warn!(
                "VolcanoDebugPlugins: no EguiPlugin in the app, so the volcano panels are not drawn; add EguiPlugin"
            );
        }
    }
}

/// The "Eruption" window ([`EruptionPanel`]).
#[derive(Debug, Default, Clone)]
pub struct EruptionPanelPlugin;

impl Plugin for EruptionPanelPlugin {
    fn build(&self, app: &mut App) {
        eruption::build(app);
    }
}

/// The "Lava" window ([`LavaPanel`]) and Ctrl + click source placement while it is open.
#[derive(Debug, Default, Clone)]
pub struct LavaPanelPlugin;

impl Plugin for LavaPanelPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<PointerCaptured>();
        lava::build(app);
    }
}

/// The "Atmosphere" window ([`AtmospherePanel`]).
#[derive(Debug, Default, Clone)]
pub struct AtmospherePanelPlugin;

impl Plugin for AtmospherePanelPlugin {
    fn build(&self, app: &mut App) {
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

fn volcano_panel(
    mut contexts: EguiContexts,
    panel: Res<PanelState>,
    control: Option<ResMut<SimControl>>,
    tick: Option<Res<SimTick>>,
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
        if let Some(control) = control.as_deref_mut() {
            let mut speed = control.speed();
            let slider =
                egui::Slider::new(&mut speed, SPEED_RANGE).logarithmic(true).suffix("×").text("sim speed");
            if ui
                .add(slider)
                .on_hover_text("longer simulation steps; the game's clocks are untouched")
                .changed()
                && control.set_speed(speed).is_err()
            {
                warn!("simulation speed {speed} rejected");
            }
        }
        let simulated = control.as_deref().map_or(0.0, |c| c.simulated().as_secs_f64());
        let ticks = tick.map_or(0, |t| t.0);
        egui::Grid::new("volcano_sim_stats").num_columns(2).show(ui, |ui| {
            ui.label("ticks");
            ui.monospace(format!("{ticks}"));
            ui.end_row();
            ui.label("simulated");
            ui.monospace(format!("{simulated:.2} s"));
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
    }
}
