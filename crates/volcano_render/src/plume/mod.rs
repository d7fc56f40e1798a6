//! Eruption column rendering.
//!
//! - **Main view** ([`PlumeRenderMode::Ash`]): one instanced draw per frame of every sphere of
//!   every scale. s1 and umbrella spheres are camera-facing smoke billboards whose texture
//!   turns with the spin projected on the screen (thesis §3.7.1); s2/s3 detail spheres are
//!   lit sphere impostors; pyroclastic particles flattened dark puffs. All are coloured by
//!   density (dark brown-grey near the vent, light grey aloft), lit by the sun through the ash
//!   toward it and by the sky through the ash above (`volcano_plume::view::light_parents`, one
//!   frame behind on the async pool: `light_task`), with
//!   soft blended edges and an incandescent glow at the vent. [`update_parents`] packs the
//!   parents and their instance counts ([`layout`]: what each draws comes from
//!   `volcano_plume::view::plan_parents`); the vertex shader expands the detail spheres (see
//!   `pipeline`).
//! - **Debug views**: s1/umbrella spheres as mesh spheres and slices as gizmo circles.

mod debug;
mod depth;
pub mod layout;
mod light_task;
mod pipeline;

use bevy::asset::embedded_asset;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::prelude::*;
use volcano_plume::{AshLightSettings, PlumeViewSettings, PlumeViewpoint};

pub use debug::PlumeVisuals;
pub use depth::{ASH_DEPTH_FORMAT, AshDepthImage, ash_depth_image};
pub use layout::{AshParent, AshParents, PlumeParents, update_parents};
pub use pipeline::AshCloud;

use crate::camera::VolcanoViewer;

/// What the column looks like (a resource; switch it live from a panel).
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource)]
pub enum PlumeRenderMode {
    /// Smoke billboards + detail-sphere impostors (the main view).
    #[default]
    Ash,
    /// Mesh spheres for s1 and umbrella spheres, gizmo circles for slices.
    DebugSpheres,
    /// Gizmo circles for slices only.
    DebugSlices,
    /// The main view with the slice circles on top.
    AshWithSlices,
}

impl PlumeRenderMode {
    /// Whether the instanced ash is drawn.
    pub fn ash(self) -> bool {
        matches!(self, Self::Ash | Self::AshWithSlices)
    }
    /// Whether s1/umbrella spheres are drawn as meshes.
    pub fn debug_spheres(self) -> bool {
        self == Self::DebugSpheres
    }
    /// Whether slices are drawn as circles.
    pub fn debug_slices(self) -> bool {
        matches!(self, Self::DebugSpheres | Self::DebugSlices | Self::AshWithSlices)
    }
}

/// Adds the column's visuals (main and debug views) to plume entities.
#[derive(Debug, Default, Clone)]
pub struct PlumeRenderPlugin;

impl Plugin for PlumeRenderPlugin {
    fn build(&self, app: &mut App) {
        embedded_asset!(app, "ash.wgsl");
        layout::build(app);
        app.init_resource::<PlumeRenderMode>()
            .register_type::<PlumeRenderMode>()
            .register_type::<AshCloud>()
            .add_systems(Startup, spawn_ash_cloud)
            .add_systems(PostUpdate, (follow_camera, follow_sun, apply_mode).before(update_parents));
        debug::build(app);
        pipeline::build(app);
        depth::build(app);
    }
}

fn spawn_ash_cloud(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>) {
    commands.spawn((
        Name::new("Ash instances"),
        AshCloud,
        Mesh3d(meshes.add(Rectangle::new(1.0, 1.0))),
        Transform::default(),
        Visibility::default(),
        // The instances are positioned in the shader; the quad's own bounds mean nothing.
        NoFrustumCulling,
    ));
}

/// The projected spin needs the viewer's position (the first [`VolcanoViewer`]).
fn follow_camera(
    camera: Query<&GlobalTransform, With<VolcanoViewer>>,
    mut viewpoint: ResMut<PlumeViewpoint>,
) {
    let v = camera.iter().next().map(|t| t.translation());
    if viewpoint.0 != v {
        viewpoint.0 = v;
    }
}

/// The ash is lit by the first directional light (the sun), through the ash toward it.
fn follow_sun(sun: Query<&GlobalTransform, With<DirectionalLight>>, mut light: ResMut<AshLightSettings>) {
    let Some(t) = sun.iter().next() else { return };
    // A light shines along its forward (−z): the sun is behind it.
    let toward = t.back().as_vec3();
    if toward.is_finite() && light.sun != toward {
        light.sun = toward;
    }
}

/// The main view off means no instances (the debug views draw their own): a debug view turns
/// [`PlumeViewSettings::enabled`] off, going back to the main view turns it on again. The main
/// view from the start leaves it as the game set it (a game or tool may hide the ash).
fn apply_mode(
    mode: Res<PlumeRenderMode>,
    mut last: Local<Option<bool>>,
    mut settings: ResMut<PlumeViewSettings>,
) {
    let ash = mode.ash();
    let before = last.replace(ash);
    if before != Some(ash) && (before.is_some() || !ash) && settings.enabled != ash {
        settings.enabled = ash;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(mode: PlumeRenderMode, enabled: bool) -> App {
        let mut app = App::new();
        app.insert_resource(mode)
            .insert_resource(PlumeViewSettings { enabled, ..Default::default() })
            .add_systems(Update, apply_mode);
        app.update();
        app
    }

    fn enabled(app: &App) -> bool {
        app.world().resource::<PlumeViewSettings>().enabled
    }

    #[test]
    fn the_main_view_keeps_the_games_choice_and_debug_views_switch_the_ash() {
        // Hidden by the game before the first frame: stays hidden under the main view.
        let mut app = run(PlumeRenderMode::Ash, false);
        assert!(!enabled(&app));
        app.update();
        assert!(!enabled(&app));
        // A debug view turns it off, the main view back on.
        let mut app = run(PlumeRenderMode::DebugSpheres, true);
        assert!(!enabled(&app));
        *app.world_mut().resource_mut::<PlumeRenderMode>() = PlumeRenderMode::Ash;
        app.update();
        assert!(enabled(&app));
    }
}
