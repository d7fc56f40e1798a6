//! Lava rendering (thesis chapter 5, docs/ARCHITECTURE.md §6).
//!
//! - **Surface**: one mesh per [`LavaState`] (a child of the field entity, vertices at the cell
//!   centres on the lava surface, see [`surface_mesh`]), rebuilt at most every
//!   [`LavaRenderSettings::rebuild_every_frames`] frames after the lava changed. In the lit
//!   view its emissive texture is the [`incandescent`] colour of each cell's crust-top
//!   temperature (a black body: bright orange at the vent, dull red under a thin skin, dark
//!   under a rigid crust) and its albedo darkens from glassy red-brown to basalt with the crust.
//! - **Folds**: every fold particle is a cylinder (length L, diameter ℓ, along its tangent, at
//!   its vertical offset and rolling height above the surface), one entity per particle sharing
//!   one mesh and material, so Bevy batches them into instanced draws.
//! - **Debug views** ([`LavaRenderMode`]): crust thickness in the colours of thesis Figs
//!   5.11–5.13 (red < 8 mm, green 8 mm–2 cm, blue > 2 cm; folds white) and lava thickness.

mod folds;
mod surface;

use bevy::asset::RenderAssetUsages;
use bevy::image::ImageSampler;
use bevy::mesh::Indices;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use volcano_core::Terrain;
use volcano_lava::{LavaField, LavaState};

use crate::terrain::{MeshSurface, TerrainMesh};

pub use folds::FoldInstance;
pub use surface::{
    REFERENCE_TEMPERATURE, crust_albedo, debug_crust, emissive_texels, frozen_albedo, incandescent,
    keep_over_terrain, surface_mesh,
};

/// How lava is drawn (a resource; switch it live from a panel).
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Reflect)]
#[reflect(Resource)]
pub enum LavaRenderMode {
    /// Incandescent surface darkened by the crust, lit folds (the main view).
    #[default]
    Lit,
    /// Crust thickness in the thesis' debug colours (Figs 5.11–5.13), folds white; unlit.
    DebugCrust,
    /// Lava thickness (black → red → yellow → white up to the field's maximum); unlit.
    DebugThickness,
}

impl LavaRenderMode {
    /// Every mode, for panels.
    pub const ALL: [Self; 3] = [Self::Lit, Self::DebugCrust, Self::DebugThickness];

    /// Label for panels.
    pub fn label(self) -> &'static str {
        match self {
            Self::Lit => "Lit (incandescent)",
            Self::DebugCrust => "Debug: crust (Figs 5.11–5.13)",
            Self::DebugThickness => "Debug: thickness",
        }
    }
}

/// Tuning of the lava look (a resource).
#[derive(Resource, Debug, Clone, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct LavaRenderSettings {
    /// Rebuild a changed surface (and move the folds) at most every this many frames (≥ 1).
    pub rebuild_every_frames: u32,
    /// Luminance (nits, scaled by the camera exposure) of a black body at
    /// [`REFERENCE_TEMPERATURE`] in the red channel.
    pub emissive_nits: f32,
    /// Draw the fold particles.
    pub show_folds: bool,
}

impl Default for LavaRenderSettings {
    fn default() -> Self {
        Self { rebuild_every_frames: 2, emissive_nits: 40_000.0, show_folds: true }
    }
}

/// The surface mesh child of a [`LavaField`] entity.
#[derive(Component, Debug, Clone)]
pub struct LavaSurface {
    /// Emissive texture (one texel per cell).
    pub image: Handle<Image>,
    /// This surface's material.
    pub material: Handle<StandardMaterial>,
    frames: u32,
    dirty: bool,
    texels: Vec<u8>,
}

/// Adds the lava surface and fold visuals to [`LavaState`] entities.
#[derive(Debug, Default, Clone)]
pub struct LavaRenderPlugin;

impl Plugin for LavaRenderPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<LavaRenderMode>()
            .init_resource::<LavaRenderSettings>()
            .register_type::<LavaRenderMode>()
            .register_type::<LavaRenderSettings>()
            .add_systems(
                PostUpdate,
                (update_surfaces, folds::update_fold_instances).before(TransformSystems::Propagate),
            );
    }

    fn finish(&self, app: &mut App) {
        if app.world().contains_resource::<Assets<StandardMaterial>>()
            && app.world().contains_resource::<Assets<Mesh>>()
            && app.world().contains_resource::<Assets<Image>>()
        {
            app.init_resource::<folds::FoldAssets>();
        }
    }
}

/// A black `nx × ny` emissive texture.
fn emissive_image(nx: usize, ny: usize, texels: Vec<u8>) -> Image {
    let size = Extent3d { width: nx as u32, height: ny as u32, depth_or_array_layers: 1 };
    let mut image = Image::new(
        size,
        TextureDimension::D2,
        texels,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::linear();
    image
}

/// Sets `material` up for `mode`.
fn style_material(material: &mut StandardMaterial, mode: LavaRenderMode, settings: &LavaRenderSettings) {
    let lit = mode == LavaRenderMode::Lit;
    material.unlit = !lit;
    let s = if lit { settings.emissive_nits.max(0.0) } else { 0.0 };
    material.emissive = LinearRgba::rgb(s, s, s);
}

/// What [`update_surfaces`] reads of a field.
type FieldItem = (Entity, &'static LavaField, Ref<'static, LavaState>, Option<&'static Children>);

/// Creates, restyles and rebuilds the surface child of every lava field.
#[allow(clippy::too_many_arguments)]
fn update_surfaces(
    mut commands: Commands,
    mode: Res<LavaRenderMode>,
    settings: Res<LavaRenderSettings>,
    fields: Query<FieldItem>,
    mut surfaces: Query<(&mut LavaSurface, &Mesh3d, &mut Visibility)>,
    terrains: Query<(&Terrain, &Children)>,
    terrain_meshes: Query<&TerrainMesh>,
    mut meshes: Option<ResMut<Assets<Mesh>>>,
    mut images: Option<ResMut<Assets<Image>>>,
    mut materials: Option<ResMut<Assets<StandardMaterial>>>,
) {
    let (Some(meshes), Some(images), Some(materials)) =
        (meshes.as_mut(), images.as_mut(), materials.as_mut())
    else {
        return;
    };
    let restyle = mode.is_changed() || settings.is_changed();
    for (entity, field, state, children) in &fields {
        let existing = children.and_then(|c| c.iter().find(|c| surfaces.contains(*c)));
        let Some(child) = existing else {
            let (nx, ny) = (state.flow.nx(), state.flow.ny());
            let image = images.add(emissive_image(nx, ny, vec![0; 4 * nx * ny]));
            let mut material = StandardMaterial {
                base_color: Color::WHITE,
                emissive_texture: Some(image.clone()),
                emissive_exposure_weight: 1.0,
                perceptual_roughness: 0.45,
                reflectance: 0.35,
                ..default()
            };
            style_material(&mut material, *mode, &settings);
            let material = materials.add(material);
            let mesh = surface_mesh(&state.flow, &state.surface.crust, &field.params, *mode);
            commands.entity(entity).insert_if_new((Transform::IDENTITY, Visibility::default()));
            commands.spawn((
                Name::new("Lava surface"),
                LavaSurface { image, material: material.clone(), frames: 0, dirty: true, texels: Vec::new() },
                Mesh3d(meshes.add(mesh)),
                MeshMaterial3d(material),
                Transform::IDENTITY,
                Visibility::Hidden,
                ChildOf(entity),
            ));
            continue;
        };
        let Ok((mut surface, mesh3d, mut visibility)) = surfaces.get_mut(child) else { continue };
        let surface = &mut *surface;
        surface.frames = surface.frames.saturating_add(1);
        surface.dirty |= state.is_changed() || restyle;
        if restyle && let Some(mut m) = materials.get_mut(&surface.material) {
            style_material(&mut m, *mode, &settings);
        }
        if !surface.dirty || surface.frames < settings.rebuild_every_frames.max(1) {
            continue;
        }
        let crust = &state.surface.crust;
        let mut mesh = surface_mesh(&state.flow, crust, &field.params, *mode);
        // On the drawn terrain under the field, if it has a mesh.
        let under = state.imprint.as_ref().and_then(|l| terrains.get(l.terrain).ok());
        let stride = under.and_then(|(_, c)| c.iter().find_map(|c| terrain_meshes.get(c).ok()));
        if let (Some((terrain, _)), Some(m)) = (under, stride) {
            let drawn = MeshSurface::new(terrain, m.stride);
            keep_over_terrain(&mut mesh, &state.flow, &field.params, |x, z| drawn.height_at(x, z));
        }
        let empty = mesh.indices().is_none_or(Indices::is_empty);
        let shown = if empty { Visibility::Hidden } else { Visibility::Inherited };
        if *visibility != shown {
            *visibility = shown;
        }
        if !empty {
            let _ = meshes.insert(mesh3d.id(), mesh);
        }
        if *mode == LavaRenderMode::Lit {
            emissive_texels(&state.flow, crust, &field.params, &mut surface.texels);
            let texels = surface.texels.clone();
            let _ =
                images.insert(surface.image.id(), emissive_image(state.flow.nx(), state.flow.ny(), texels));
            // Touch the material so its bind group picks up the new texture.
            let _ = materials.get_mut(&surface.material);
        }
        surface.frames = 0;
        surface.dirty = false;
    }
}
