//! Debug/preview view of the eruption column: every s1 sphere and umbrella sphere as a lit
//! ash-coloured sphere (one shared mesh and two materials, so Bevy batches them). The plume
//! plugin keeps their transforms (scale = radius); this module only attaches visuals.
//! Billboards and instanced detail spheres come with the plume rendering work.

use bevy::prelude::*;
use volcano_plume::{S1, Umbrella};

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

/// Adds visuals to plume spheres as they appear.
#[derive(Debug, Default, Clone)]
pub struct PlumeRenderPlugin;

impl Plugin for PlumeRenderPlugin {
    fn build(&self, app: &mut App) {
        app.add_systems(Startup, setup).add_systems(PostUpdate, (attach_column, attach_umbrella));
    }
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

fn attach_column(
    mut commands: Commands,
    visuals: Option<Res<PlumeVisuals>>,
    added: Query<Entity, Added<S1>>,
) {
    let Some(v) = visuals else { return };
    for e in &added {
        commands.entity(e).insert((
            Mesh3d(v.mesh.clone()),
            MeshMaterial3d(v.column.clone()),
            Visibility::default(),
        ));
    }
}

fn attach_umbrella(
    mut commands: Commands,
    visuals: Option<Res<PlumeVisuals>>,
    added: Query<Entity, Added<Umbrella>>,
) {
    let Some(v) = visuals else { return };
    for e in &added {
        commands.entity(e).insert((Mesh3d(v.mesh.clone()), MeshMaterial3d(v.umbrella.clone())));
    }
}
