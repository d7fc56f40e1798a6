//! Debug view of the eruption column: every s1 sphere and umbrella sphere as a lit
//! ash-coloured mesh sphere (one shared mesh and two materials, so Bevy batches them), and
//! each slice as a gizmo circle of radius r in its plane with its velocity. The plume plugin
//! keeps the sphere transforms (scale = radius); this module only attaches visuals, shown
//! when [`PlumeRenderMode`] asks for them.

use bevy::prelude::*;
use volcano_plume::{PlumeSlice, S1, Umbrella};

use super::PlumeRenderMode;

/// Shared handles of the column's visuals.
#[derive(Resource, Debug, Clone)]
pub struct PlumeVisuals {
    /// Unit sphere.
    pub mesh: Handle<Mesh>,
    /// Material of spheres still on their slice (darker, denser ash).
    pub column: Handle<StandardMaterial>,
    /// Material of umbrella spheres (paler, diluted ash).
    pub umbrella: Handle<StandardMaterial>,
}

pub(super) fn build(app: &mut App) {
    app.add_systems(Startup, setup)
        .add_systems(PostUpdate, (attach_column, attach_umbrella, show_debug_spheres).chain())
        .add_systems(PostUpdate, draw_slices);
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let mesh =
        meshes.add(Sphere::new(1.0).mesh().ico(2).unwrap_or_else(|_| Sphere::new(1.0).mesh().uv(16, 8)));
    let ash = |c: Color| StandardMaterial {
        base_color: c,
        perceptual_roughness: 1.0,
        reflectance: 0.1,
        ..default()
    };
    let column = materials.add(ash(Color::srgb(0.36, 0.33, 0.31)));
    let umbrella = materials.add(ash(Color::srgb(0.62, 0.60, 0.58)));
    commands.insert_resource(PlumeVisuals { mesh, column, umbrella });
}

fn debug_visibility(mode: PlumeRenderMode) -> Visibility {
    if mode.debug_spheres() { Visibility::Inherited } else { Visibility::Hidden }
}

fn attach_column(
    mut commands: Commands,
    visuals: Option<Res<PlumeVisuals>>,
    mode: Res<PlumeRenderMode>,
    added: Query<Entity, Added<S1>>,
) {
    let Some(v) = visuals else { return };
    for e in &added {
        commands.entity(e).insert((
            Mesh3d(v.mesh.clone()),
            MeshMaterial3d(v.column.clone()),
            debug_visibility(*mode),
        ));
    }
}

fn attach_umbrella(
    mut commands: Commands,
    visuals: Option<Res<PlumeVisuals>>,
    mode: Res<PlumeRenderMode>,
    added: Query<Entity, Added<Umbrella>>,
) {
    let Some(v) = visuals else { return };
    for e in &added {
        commands.entity(e).insert((
            Mesh3d(v.mesh.clone()),
            MeshMaterial3d(v.umbrella.clone()),
            debug_visibility(*mode),
        ));
    }
}

/// s1 or umbrella spheres.
type AnySphere = Or<(With<S1>, With<Umbrella>)>;

/// Applies a mode change to every existing sphere.
fn show_debug_spheres(mode: Res<PlumeRenderMode>, mut spheres: Query<&mut Visibility, AnySphere>) {
    if !mode.is_changed() {
        return;
    }
    let v = debug_visibility(*mode);
    for mut vis in &mut spheres {
        vis.set_if_neq(v);
    }
}

/// Slices as circles of radius r in their plane, with a velocity tick (debug modes only).
fn draw_slices(mode: Res<PlumeRenderMode>, slices: Query<(&PlumeSlice, &Transform)>, mut gizmos: Gizmos) {
    if !mode.debug_slices() {
        return;
    }
    for (slice, t) in &slices {
        let r = slice.state.r as f32;
        // The slice plane is the local xz plane (local y = direction of motion).
        let iso =
            Isometry3d::new(t.translation, t.rotation * Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
        let hue = (1.0 - (slice.state.density as f32 / 200.0).clamp(0.0, 1.0)) * 200.0;
        let colour = Color::hsl(hue, 0.9, 0.55);
        gizmos.circle(iso, r, colour);
        let v = volcano_plume::components::plume_to_world(slice.state.velocity);
        gizmos.line(t.translation, t.translation + v.normalize_or_zero() * r, colour);
    }
}
