//! Terrain rendering: one vertex-coloured mesh per [`Terrain`] entity (a child of it, rebuilt
//! whenever the terrain is added or changed, and updated in place over the nodes a
//! [`TerrainChanged`] message names), an opt-in far ring around it ([`TerrainHorizon`]) and a
//! glowing marker over each volcano's vent.
//!
//! The heightfield is downsampled with an integer stride so a mesh has at most
//! [`MAX_VERTICES_PER_SIDE`]² vertices. Colours follow land-cover rules with procedural detail
//! ([`ground_color`]: rock on steep slopes, scoria and ash on the upper cone, vegetation low,
//! snow high, value-noise variation); nodes under frozen lava (the terrain's added layer) turn
//! basalt grey. The material ([`TerrainMaterial`]) adds per-pixel detail finer than the
//! vertices ([`GroundDetail`], module `detail`).

use bevy::asset::RenderAssetUsages;
use bevy::color::{Color, ColorToComponents, LinearRgba, Srgba};
use bevy::mesh::{Indices, Mesh, Mesh3d, PrimitiveTopology};
use bevy::pbr::{MeshMaterial3d, StandardMaterial};
use bevy::prelude::*;
mod cover;
pub mod deposit;
mod detail;
mod horizon;
mod region;

use volcano_core::{LandCover, Terrain, TerrainChanged, VentPosition, Volcano};

pub use cover::{GroundSample, Relief, ground_color, value_noise};
pub(crate) use cover::{lattice_hash, mix, smoothstep};
pub use deposit::{DepositRenderPlugin, DepositTint};
pub use detail::{GROUND_DETAIL_SHADER, GroundDetail, GroundDetailExtension, TerrainMaterial};
pub use horizon::{HorizonError, TerrainHorizon, TerrainHorizonMesh, horizon_mesh};

use region::update_changed_regions;
pub use region::{MeshSurface, update_terrain_mesh};

/// Upper bound on the vertices per side of a terrain mesh (the stride is chosen to respect it).
pub const MAX_VERTICES_PER_SIDE: usize = 512;

/// Marks the mesh child that renders a [`Terrain`] entity.
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct TerrainMesh {
    /// Sample stride used when the mesh was last built (1 = full resolution).
    pub stride: usize,
}

/// On a [`Terrain`] entity: no mesh for it (a game that draws its own ground, or a collision-
/// only terrain). Adding it later removes the mesh child.
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct UnrenderedTerrain;

/// Marks the child that shows a [`Volcano`]'s vent (an emissive short cylinder of the vent
/// radius, centred on [`VentPosition`]).
#[derive(Component, Debug, Clone, Copy, Default, Reflect)]
#[reflect(Component, Default, Debug)]
pub struct VentMarker;

/// Builds terrain meshes and vent markers in `Update`.
#[derive(Debug, Default, Clone)]
pub struct TerrainRenderPlugin;

impl Plugin for TerrainRenderPlugin {
    fn build(&self, app: &mut App) {
        detail::build(app);
        app.register_type::<TerrainMesh>()
            .register_type::<VentMarker>()
            .register_type::<UnrenderedTerrain>()
            .register_type::<TerrainHorizon>()
            .register_type::<TerrainHorizonMesh>()
            .add_message::<TerrainChanged>()
            .add_systems(
                Update,
                (
                    drop_unrendered_meshes,
                    (build_terrain_meshes, update_changed_regions).chain(),
                    (horizon::drop_horizons, horizon::build_horizons).chain(),
                    update_vent_markers,
                    keep_terrain_meshes_in_world_space
                        .after(build_terrain_meshes)
                        .after(horizon::build_horizons),
                ),
            );
    }

    fn finish(&self, app: &mut App) {
        // After every plugin's build, so the mesh and material asset stores exist.
        if app.world().contains_resource::<Assets<StandardMaterial>>()
            && app.world().contains_resource::<Assets<TerrainMaterial>>()
            && app.world().contains_resource::<Assets<Mesh>>()
        {
            app.init_resource::<TerrainAssets>();
        }
    }
}

/// Shared handles, created when the plugin finishes (needs the PBR asset stores).
#[derive(Resource)]
struct TerrainAssets {
    terrain_material: Handle<TerrainMaterial>,
    vent_material: Handle<StandardMaterial>,
    vent_mesh: Handle<Mesh>,
}

impl FromWorld for TerrainAssets {
    fn from_world(world: &mut World) -> Self {
        // An invalid setting at start-up is reported by `detail::apply_ground_detail`.
        let detail = world.get_resource::<GroundDetail>().copied().filter(|d| d.validate().is_ok());
        let base = StandardMaterial {
            base_color: Color::WHITE,
            perceptual_roughness: 0.95,
            metallic: 0.0,
            reflectance: 0.25,
            ..default()
        };
        let extension = GroundDetailExtension::from(detail.unwrap_or(GroundDetail::OFF));
        let terrain_material =
            world.resource_mut::<Assets<TerrainMaterial>>().add(TerrainMaterial { base, extension });
        let mut materials = world.resource_mut::<Assets<StandardMaterial>>();
        // Emissive in nits, scaled by the camera exposure: glows orange-red at daylight exposure.
        let vent_material = materials.add(StandardMaterial {
            base_color: Color::srgb(0.35, 0.03, 0.01),
            emissive: LinearRgba::rgb(15_000.0, 1_500.0, 225.0),
            emissive_exposure_weight: 1.0,
            perceptual_roughness: 0.8,
            ..default()
        });
        let vent_mesh = world.resource_mut::<Assets<Mesh>>().add(Cylinder::new(1.0, 1.0));
        Self { terrain_material, vent_material, vent_mesh }
    }
}

/// Colour of lava frozen into the terrain (linear; the lava renderer's frozen albedo).
fn basalt() -> LinearRgba {
    LinearRgba::from(Srgba::rgb(0.12, 0.115, 0.11))
}

/// Mean thickness (m) of the added layer at which a node is drawn wholly as frozen lava.
pub const FROZEN_FULL_COVER: f64 = 0.05;

/// Colour of terrain node `(i, j)` drawn at `altitude` with unit normal `normal`:
/// [`ground_color`] of its land cover, turning to basalt as the node's added layer (frozen lava,
/// a mean over the node's footprint) thickens to [`FROZEN_FULL_COVER`].
pub fn terrain_color(
    terrain: &Terrain,
    relief: Relief,
    (i, j): (usize, usize),
    altitude: f32,
    normal: Vec3,
) -> LinearRgba {
    let sample = GroundSample {
        cover: terrain.cover().get(i, j),
        position: terrain.heights().position(i, j),
        altitude,
        normal,
        footprint: terrain.heights().cell() as f32,
    };
    let base = ground_color(sample, relief);
    match terrain.added() {
        Some(a) => mix(base, basalt(), smoothstep(0.0, FROZEN_FULL_COVER as f32, a.get(i, j) as f32)),
        None => base,
    }
}

/// Sample indices `0, s, 2s, …` along an axis of `n` samples, always ending at `n − 1`.
pub(crate) fn sample_axis(n: usize, stride: usize) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).step_by(stride.max(1)).collect();
    if v.last() != Some(&(n - 1)) {
        v.push(n - 1);
    }
    v
}

/// Stride that keeps at most `max_per_side` samples per side of an `n`-sample axis.
pub(crate) fn stride_for(n: usize, max_per_side: usize) -> usize {
    let max = max_per_side.max(2);
    if n <= max { 1 } else { (n - 1).div_ceil(max - 1).max(1) }
}

/// The mesh samples of a terrain: which nodes are vertices, and how each vertex looks.
pub(crate) struct MeshSamples<'a> {
    terrain: &'a Terrain,
    pub(crate) xs: Vec<usize>,
    pub(crate) ys: Vec<usize>,
    /// Computed on first use (placing things on the mesh needs no colours).
    relief: std::cell::OnceCell<Relief>,
}

impl<'a> MeshSamples<'a> {
    pub(crate) fn new(terrain: &'a Terrain, stride: usize) -> Self {
        let h = terrain.heights();
        Self {
            terrain,
            xs: sample_axis(h.nx(), stride),
            ys: sample_axis(h.ny(), stride),
            relief: std::cell::OnceCell::new(),
        }
    }

    /// The terrain's relief, for the colour rules.
    pub(crate) fn relief(&self) -> Relief {
        *self.relief.get_or_init(|| Relief::of(self.terrain))
    }

    /// Drawn altitude of node `(i, j)`: water is lifted to sea level.
    pub(crate) fn surface(&self, i: usize, j: usize) -> f32 {
        let h = self.terrain.heights().get(i, j);
        if self.terrain.cover().get(i, j) == LandCover::Water { h.max(self.terrain.sea_level()) } else { h }
    }

    /// Position, normal (central differences over the neighbouring mesh samples, one-sided at
    /// the edges) and colour of vertex `(a, b)`.
    pub(crate) fn vertex(&self, a: usize, b: usize) -> ([f32; 3], [f32; 3], [f32; 4]) {
        let (xs, ys, heights) = (&self.xs, &self.ys, self.terrain.heights());
        let (i, j) = (xs[a], ys[b]);
        let p = heights.position(i, j);
        let (i0, i1) = (xs[a.saturating_sub(1)], xs[(a + 1).min(xs.len() - 1)]);
        let (j0, j1) = (ys[b.saturating_sub(1)], ys[(b + 1).min(ys.len() - 1)]);
        let dx = heights.position(i1, j).x - heights.position(i0, j).x;
        let dz = heights.position(i, j1).y - heights.position(i, j0).y;
        let dhdx = if dx > 0.0 { (self.surface(i1, j) - self.surface(i0, j)) / dx } else { 0.0 };
        let dhdz = if dz > 0.0 { (self.surface(i, j1) - self.surface(i, j0)) / dz } else { 0.0 };
        let n = Vec3::new(-dhdx, 1.0, -dhdz).normalize_or(Vec3::Y);
        let y = self.surface(i, j);
        let colour = terrain_color(self.terrain, self.relief(), (i, j), y, n).to_f32_array();
        ([p.x, y, p.y], n.to_array(), colour)
    }

    /// Vertex index range `[lo, hi]` along an axis whose mesh depends on nodes `lo_n..=hi_n`
    /// (one more mesh sample each side: the normals use their neighbours).
    pub(crate) fn affected(axis: &[usize], lo_n: usize, hi_n: usize) -> Option<(usize, usize)> {
        let first = axis.iter().position(|&n| n >= lo_n)?;
        let last = axis.iter().rposition(|&n| n <= hi_n)?;
        // Samples between two vertices change no vertex but the two around them.
        let (first, last) = if first > last { (last, first) } else { (first, last) };
        Some((first.saturating_sub(1), (last + 1).min(axis.len() - 1)))
    }
}

/// Builds the render mesh of `terrain`: positions in world metres (grid `(x, y)` → world
/// `(x, z)`, height → `y`; water is lifted to sea level), smooth normals from central
/// differences, vertex colours from [`terrain_color`]. At most `max_per_side`² vertices.
/// Returns the mesh and the stride used.
pub fn terrain_mesh(terrain: &Terrain, max_per_side: usize) -> (Mesh, usize) {
    let heights = terrain.heights();
    let stride = stride_for(heights.nx().max(heights.ny()), max_per_side);
    let samples = MeshSamples::new(terrain, stride);
    let (xs, ys) = (&samples.xs, &samples.ys);
    let count = xs.len() * ys.len();
    let mut positions = Vec::with_capacity(count);
    let mut normals = Vec::with_capacity(count);
    let mut colors = Vec::with_capacity(count);
    let mut uvs = Vec::with_capacity(count);
    for b in 0..ys.len() {
        for a in 0..xs.len() {
            let (p, n, c) = samples.vertex(a, b);
            positions.push(p);
            normals.push(n);
            colors.push(c);
            uvs.push([a as f32 / (xs.len() - 1).max(1) as f32, b as f32 / (ys.len() - 1).max(1) as f32]);
        }
    }

    let w = xs.len() as u32;
    let mut indices = Vec::with_capacity((xs.len() - 1) * (ys.len() - 1) * 6);
    for b in 0..ys.len() as u32 - 1 {
        for a in 0..w - 1 {
            let v00 = b * w + a;
            let v10 = v00 + 1;
            let v01 = v00 + w;
            let v11 = v01 + 1;
            // Counter-clockwise seen from above (+y).
            indices.extend_from_slice(&[v00, v01, v10, v10, v01, v11]);
        }
    }

    // Kept in the main world too: the deposit tint rewrites its colours.
    let mesh = Mesh::new(PrimitiveTopology::TriangleList, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
        .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, uvs)
        .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, colors)
        .with_inserted_indices(Indices::U32(indices));
    (mesh, stride)
}

/// A terrain's mesh or far-ring child.
type DrawnGround = Or<(With<TerrainMesh>, With<TerrainHorizonMesh>)>;

/// Despawns the mesh and far-ring children of terrains that became [`UnrenderedTerrain`].
fn drop_unrendered_meshes(
    mut commands: Commands,
    terrains: Query<&Children, (With<Terrain>, Added<UnrenderedTerrain>)>,
    meshes: Query<(), DrawnGround>,
) {
    for child in terrains.iter().flatten() {
        if meshes.contains(*child) {
            commands.entity(*child).despawn();
        }
    }
}

/// A changed terrain that is drawn.
type RenderedTerrainChanged = (Changed<Terrain>, Without<UnrenderedTerrain>);

/// Builds or replaces the mesh child of every added or changed [`Terrain`] (not of
/// [`UnrenderedTerrain`]s).
fn build_terrain_meshes(
    mut commands: Commands,
    terrains: Query<(Entity, &Terrain, Option<&Children>), RenderedTerrainChanged>,
    mut mesh_children: Query<(&Mesh3d, &mut TerrainMesh)>,
    mut meshes: ResMut<Assets<Mesh>>,
    assets: Option<Res<TerrainAssets>>,
) {
    let Some(assets) = assets else { return };
    for (entity, terrain, children) in &terrains {
        let (mesh, stride) = terrain_mesh(terrain, MAX_VERTICES_PER_SIDE);
        let existing = children.and_then(|c| c.iter().find(|c| mesh_children.contains(*c)));
        if let Some(child) = existing
            && let Ok((handle, mut marker)) = mesh_children.get_mut(child)
            && meshes.insert(handle.id(), mesh.clone()).is_ok()
        {
            marker.stride = stride;
            continue;
        }
        if let Some(child) = existing {
            commands.entity(child).despawn();
        }
        // The mesh is in world coordinates: the terrain entity needs a transform (identity
        // unless the user placed it) and visibility for the child to render.
        commands.entity(entity).insert_if_new((Transform::IDENTITY, Visibility::default()));
        commands.spawn((
            Name::new("Terrain mesh"),
            TerrainMesh { stride },
            Mesh3d(meshes.add(mesh)),
            MeshMaterial3d(assets.terrain_material.clone()),
            Transform::IDENTITY,
            ChildOf(entity),
        ));
    }
}

/// A terrain whose transform or children changed.
type MovedOrNewChildren = Or<(Changed<Transform>, Changed<Children>)>;

/// The terrain's meshes are built in world coordinates from its grids, which the core plugin
/// moves to the entity's translation; as children of the entity they take a transform that
/// cancels the entity's, so they are drawn where the simulation has the ground whatever the
/// entity's transform (a rotation or scale the simulation ignores is ignored here too).
fn keep_terrain_meshes_in_world_space(
    terrains: Query<(&Transform, &Children), (With<Terrain>, MovedOrNewChildren)>,
    mut meshes: Query<&mut Transform, (DrawnGround, Without<Terrain>)>,
) {
    for (parent, children) in &terrains {
        let cancel = Transform::from_matrix(parent.to_matrix().inverse());
        for child in children.iter() {
            if let Ok(mut t) = meshes.get_mut(child)
                && *t != cancel
            {
                *t = cancel;
            }
        }
    }
}

/// What [`update_vent_markers`] reads of a volcano.
type VolcanoVent =
    (Entity, &'static Volcano, &'static VentPosition, &'static Transform, Option<&'static Children>);

/// A volcano whose radius or vent moved.
type VentChanged = Or<(Changed<Volcano>, Changed<VentPosition>)>;

/// Spawns or resizes the vent marker of every volcano whose vent or radius changed.
fn update_vent_markers(
    mut commands: Commands,
    volcanoes: Query<VolcanoVent, VentChanged>,
    mut markers: Query<&mut Transform, (With<VentMarker>, Without<Volcano>)>,
    assets: Option<Res<TerrainAssets>>,
) {
    let Some(assets) = assets else { return };
    for (entity, volcano, vent, frame, children) in &volcanoes {
        // An invalid radius (a reflected edit) keeps the marker as it was.
        if volcano.validate().is_err() || !vent.0.is_finite() {
            continue;
        }
        let r = volcano.vent_radius();
        let h = (0.6 * r).max(10.0);
        // Local offset of the vent in the volcano's frame (normally zero: the core plugin snaps
        // the volcano's transform onto the vent). Sunk by a quarter so it sits in the ground.
        let local = frame.compute_affine().inverse().transform_point3(vent.0) + Vec3::Y * (0.25 * h);
        let transform = Transform::from_translation(local).with_scale(Vec3::new(r, h, r));
        let existing = children.and_then(|c| c.iter().find(|c| markers.contains(*c)));
        if let Some(child) = existing
            && let Ok(mut t) = markers.get_mut(child)
        {
            *t = transform;
            continue;
        }
        commands.entity(entity).insert_if_new(Visibility::default());
        commands.spawn((
            Name::new("Vent marker"),
            VentMarker,
            Mesh3d(assets.vent_mesh.clone()),
            MeshMaterial3d(assets.vent_material.clone()),
            transform,
            ChildOf(entity),
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_core::{NodeRegion, StratovolcanoParams};

    #[test]
    fn stride_caps_vertices_and_keeps_edges() {
        assert_eq!(stride_for(96, 512), 1);
        assert_eq!(stride_for(512, 512), 1);
        let s = stride_for(4097, 512);
        let axis = sample_axis(4097, s);
        assert!(axis.len() <= 512, "{} samples", axis.len());
        assert_eq!((axis[0], *axis.last().unwrap()), (0, 4096));
    }

    #[test]
    fn mesh_follows_the_heightfield() {
        let terrain =
            StratovolcanoParams { resolution: 65, cell: 300.0, ..Default::default() }.generate().unwrap();
        let (mesh, stride) = terrain_mesh(&terrain, 33);
        assert_eq!(stride, 2);
        assert_eq!(mesh.count_vertices(), 33 * 33);
        let Some(Indices::U32(idx)) = mesh.indices() else { panic!("u32 indices") };
        assert_eq!(idx.len(), 32 * 32 * 6);
        let pos = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        // Vertex (a, b) = grid sample (2a, 2b), lifted to sea level if water.
        let p = pos[5 * 33 + 7];
        let g = terrain.heights().position(14, 10);
        assert_eq!((p[0], p[2]), (g.x, g.y));
        assert!((p[1] - terrain.heights().get(14, 10).max(terrain.sea_level())).abs() < 1e-3);
        // Every triangle faces up.
        for t in idx.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(pos[i as usize]));
            assert!((b - a).cross(c - a).y > 0.0);
        }
    }

    /// The terrain plugin on a headless app without a renderer (meshes are only assets),
    /// transforms propagated.
    fn mesh_app() -> App {
        let mut app = App::new();
        app.add_plugins((
            MinimalPlugins,
            bevy::asset::AssetPlugin::default(),
            bevy::transform::TransformPlugin,
        ))
        .init_asset::<Mesh>()
        .init_asset::<StandardMaterial>()
        .add_plugins((volcano_core::VolcanoCorePlugin, TerrainRenderPlugin));
        app.finish();
        app.cleanup();
        app
    }

    /// A 33² stratovolcano of 500 m cells.
    fn small_terrain() -> Terrain {
        StratovolcanoParams { resolution: 33, cell: 500.0, ..Default::default() }.generate().unwrap()
    }

    /// A terrain placed by its entity's transform is drawn where the simulation has it: its
    /// mesh vertices are the moved grid's samples and the mesh child's global transform is the
    /// identity, whatever the parent's translation (and a rotation the simulation ignores).
    #[test]
    fn a_placed_terrain_is_drawn_where_the_simulation_has_it() {
        let mut app = mesh_app();
        let built = small_terrain();
        let moved = Vec3::new(5_000.0, 0.0, -20_000.0);
        let placed = Transform::from_translation(moved).with_rotation(Quat::from_rotation_y(0.3));
        let t = app.world_mut().spawn((built.clone(), placed)).id();
        for _ in 0..3 {
            app.update();
        }
        let world = app.world_mut();
        let (mesh, global) = world
            .query_filtered::<(&Mesh3d, &GlobalTransform), With<TerrainMesh>>()
            .single(world)
            .map(|(m, g)| (m.0.clone(), *g))
            .unwrap();
        let meshes = world.resource::<Assets<Mesh>>();
        let pos =
            meshes.get(&mesh).unwrap().attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        let drawn = global.transform_point(Vec3::from(pos[0]));
        let sample = built.heights().origin() + moved.xz();
        assert!(
            (drawn.xz() - sample).length() < 0.05,
            "vertex 0 drawn at {drawn}, the ground is at {sample}"
        );
        assert_eq!(world.get::<Terrain>(t).unwrap().heights().origin(), sample);
    }

    /// Terrain and volcano on a headless app (no renderer): one mesh child and one vent marker,
    /// replaced in place when the terrain changes.
    #[test]
    fn mesh_child_and_vent_marker_follow_the_entities() {
        let mut app = mesh_app();
        let t = app.world_mut().spawn(small_terrain()).id();
        let v = app.world_mut().spawn((Volcano::default(), Transform::from_xyz(100.0, 0.0, -50.0))).id();
        for _ in 0..3 {
            app.update();
        }
        let world = app.world_mut();
        let meshes: Vec<(Entity, Handle<Mesh>)> = world
            .query_filtered::<(&ChildOf, &Mesh3d), With<TerrainMesh>>()
            .iter(world)
            .map(|(c, m)| (c.parent(), m.0.clone()))
            .collect();
        assert_eq!(meshes.len(), 1);
        assert_eq!(meshes[0].0, t);
        let markers: Vec<(Entity, Transform)> = world
            .query_filtered::<(&ChildOf, &Transform), With<VentMarker>>()
            .iter(world)
            .map(|(c, tr)| (c.parent(), *tr))
            .collect();
        assert_eq!(markers.len(), 1);
        assert_eq!(markers[0].0, v);
        // Scaled to the vent radius, sitting on the snapped vent (local frame of the volcano).
        assert_eq!(markers[0].1.scale.x, 100.0);
        assert!(markers[0].1.translation.x.abs() < 1e-3 && markers[0].1.translation.y > 0.0);

        // Edit the terrain: the same child gets the new mesh.
        world.get_mut::<Terrain>(t).unwrap().heights_mut().map_in_place(|h| h + 1000.0);
        app.update();
        let world = app.world_mut();
        let after: Vec<Handle<Mesh>> =
            world.query_filtered::<&Mesh3d, With<TerrainMesh>>().iter(world).map(|m| m.0.clone()).collect();
        assert_eq!(after, vec![meshes[0].1.clone()]);
        let mesh = world.resource::<Assets<Mesh>>().get(&after[0]).unwrap();
        let pos = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        let min_y = pos.iter().map(|p| p[1]).fold(f32::INFINITY, f32::min);
        assert!(min_y > 1000.0, "mesh not rebuilt: lowest vertex {min_y}");

        // Frozen lava written without change detection plus a `TerrainChanged`: the same mesh
        // is updated over the region and matches a full rebuild.
        let region = NodeRegion { i0: 10, j0: 12, ni: 3, nj: 2 };
        let mut terrain = world.get_mut::<Terrain>(t).unwrap();
        terrain.bypass_change_detection().add_thickness(region, &[2.0; 6]).unwrap();
        world.write_message(TerrainChanged { terrain: t, region });
        app.update();
        let world = app.world_mut();
        let handle = world.query_filtered::<&Mesh3d, With<TerrainMesh>>().single(world).unwrap().0.clone();
        assert_eq!(handle, meshes[0].1);
        let (full, _) = terrain_mesh(world.get::<Terrain>(t).unwrap(), MAX_VERTICES_PER_SIDE);
        let mesh = world.resource::<Assets<Mesh>>().get(&handle).unwrap();
        assert_eq!(mesh.attribute(Mesh::ATTRIBUTE_POSITION), full.attribute(Mesh::ATTRIBUTE_POSITION));
        let pos = mesh.attribute(Mesh::ATTRIBUTE_POSITION).unwrap().as_float3().unwrap();
        let h = world.get::<Terrain>(t).unwrap().base_heights().get(11, 12);
        assert!((pos[12 * 33 + 11][1] - (h + 2.0)).abs() < 1e-3, "vertex not raised");
    }

    #[test]
    fn frozen_lava_turns_the_terrain_basalt() {
        let mut t = Terrain::flat(4, 10.0, 100.0).unwrap();
        let relief = Relief::of(&t);
        let colour = |t: &Terrain, i, j| terrain_color(t, relief, (i, j), 100.0, Vec3::Y);
        let ground = colour(&t, 2, 1);
        t.add_thickness(NodeRegion { i0: 1, j0: 1, ni: 2, nj: 1 }, &[FROZEN_FULL_COVER, 0.01]).unwrap();
        let full = colour(&t, 1, 1);
        assert!((full.red - basalt().red).abs() < 1e-6 && (full.green - basalt().green).abs() < 1e-6);
        let partly = colour(&t, 2, 1);
        assert!(partly.red < ground.red && partly.red > basalt().red, "{partly:?}");
        assert_eq!(
            colour(&t, 0, 0),
            terrain_color(&Terrain::flat(4, 10.0, 100.0).unwrap(), relief, (0, 0), 100.0, Vec3::Y)
        );
    }
}
