//! Lava rendering (thesis chapter 5, docs/RENDERING.md (lava)).
//!
//! - **Surface**: one mesh per [`LavaState`] (a child of the field entity, vertices at the cell
//!   centres on the lava surface, see [`surface_mesh`]), rebuilt at most every
//!   [`LavaRenderSettings::rebuild_every_frames`] frames after the lava changed. Its outline
//!   runs inside the cells where the lava's coverage crosses ½ ([`margin`]), not along the cell
//!   staircase. In the lit view its emissive texture (a few texels per cell, `Rgba16Float`) is
//!   the [`incandescent`] colour of the crust-top temperature (a black body: bright orange at
//!   the vent, dull red under a thin skin, dark under a rigid crust) with hotter cracks along
//!   the edges of crust plates and mottling ([`crust`]); its albedo darkens from glassy
//!   red-brown to basalt with the crust, varies over metres, and world-space detail textures
//!   add grain, roughness and centimetre bumps. The glow blooms on cameras that opt in to HDR
//!   ([`crate::GlowCamera`]).
//! - **Folds**: every fold particle is a rope segment (a capsule of diameter 1.3 ℓ, 1.3 L long
//!   along its tangent so neighbours overlap, at its vertical offset and rolling height above
//!   the surface), one entity per particle sharing one mesh and material, so Bevy batches them
//!   into instanced draws; they cast shadows ([`LavaRenderSettings::fold_shadows`]).
//! - **Glow light**: one shadowless point light per field, of the power and colour its
//!   emission gives out, lights the ground and folds around the flow ([`light`]).
//! - **Debug views** ([`LavaRenderMode`]): crust thickness in the colours of thesis Figs
//!   5.11–5.13 (red < 8 mm, green 8 mm–2 cm, blue > 2 cm; folds white) and lava thickness.

pub mod crust;
mod folds;
mod fountain;
pub mod light;
pub mod margin;
mod runout;
mod surface;

use bevy::asset::RenderAssetUsages;
use bevy::image::ImageSampler;
use bevy::light::NotShadowCaster;
use bevy::mesh::{Indices, UvChannel};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use volcano_core::Terrain;
use volcano_lava::{LavaField, LavaState};

use crate::terrain::{MeshSurface, TerrainMesh};

pub use crust::{GlowPattern, REFERENCE_TEMPERATURE, glow_texels, incandescent};
pub use folds::{FoldInstance, fold_transform};
pub use fountain::{FountainClots, FountainGlow, fountain_glow};
pub use light::{GlowLight, LavaGlow, glow_light, glow_lights, glow_range};
pub use runout::{RunoutGlow, RunoutTileSurface, runout_glow};
pub use surface::{crust_albedo, debug_crust, frozen_albedo, keep_over_terrain, surface_mesh};

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
    /// Fold ropes cast shadows (one more draw per rope and shadow cascade).
    pub fold_shadows: bool,
    /// The glowing lava lights its surroundings: shadowless point lights along each field
    /// ([`light::glow_lights`]).
    pub glow_light: bool,
    /// At most this many glow lights per field (0: none); a compact lobe gets one, a long
    /// tongue one per stretch about twice as long as it is wide.
    pub glow_light_count: u32,
}

impl Default for LavaRenderSettings {
    fn default() -> Self {
        Self {
            rebuild_every_frames: 2,
            emissive_nits: 40_000.0,
            show_folds: true,
            fold_shadows: true,
            glow_light: true,
            glow_light_count: 8,
        }
    }
}

/// The surface mesh child of a [`LavaField`] entity.
#[derive(Component, Debug, Clone)]
pub struct LavaSurface {
    /// Emissive texture ([`crust::texels_per_cell`] texels per cell side).
    pub image: Handle<Image>,
    /// This surface's material.
    pub material: Handle<StandardMaterial>,
    frames: u32,
    dirty: bool,
    texels: Vec<u8>,
    pattern: GlowPattern,
}

impl LavaSurface {
    /// Whether `update_surfaces` rebuilt this surface (mesh and glow) in the current frame.
    pub fn rebuilt_this_frame(&self) -> bool {
        self.frames == 0 && !self.dirty
    }
}

/// The crust's tileable detail textures (albedo grain, roughness, normal map), shared by every
/// lava surface.
#[derive(Resource, Debug, Clone)]
struct LavaDetail {
    albedo: Handle<Image>,
    roughness: Handle<Image>,
    normal: Handle<Image>,
}

impl FromWorld for LavaDetail {
    fn from_world(world: &mut World) -> Self {
        let [albedo, roughness, normal] = crust::detail_images();
        let mut images = world.resource_mut::<Assets<Image>>();
        Self { albedo: images.add(albedo), roughness: images.add(roughness), normal: images.add(normal) }
    }
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
            .register_type::<LavaGlow>()
            .register_type::<RunoutGlow>()
            .register_type::<FountainGlow>()
            .add_systems(
                PostUpdate,
                (
                    update_surfaces,
                    keep_surfaces_in_world_space.after(update_surfaces),
                    folds::update_fold_instances,
                    light::update_glow_lights.after(update_surfaces),
                    runout::update_runout_tiles,
                    fountain::update_fountains,
                )
                    .before(TransformSystems::Propagate),
            );
    }

    fn finish(&self, app: &mut App) {
        if app.world().contains_resource::<Assets<StandardMaterial>>()
            && app.world().contains_resource::<Assets<Mesh>>()
            && app.world().contains_resource::<Assets<Image>>()
        {
            app.init_resource::<folds::FoldAssets>().init_resource::<LavaDetail>();
        }
    }
}

/// A `width × height` emissive texture of `Rgba16Float` texels (black if `texels` is empty).
fn emissive_image(width: usize, height: usize, mut texels: Vec<u8>) -> Image {
    texels.resize(8 * width * height, 0);
    let size = Extent3d { width: width as u32, height: height as u32, depth_or_array_layers: 1 };
    let mut image = Image::new(
        size,
        TextureDimension::D2,
        texels,
        TextureFormat::Rgba16Float,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::linear();
    image
}

/// Sets `material` up for `mode`: in the lit view the detail textures on UV 1, in the debug
/// views plain vertex colours.
fn style_material(
    material: &mut StandardMaterial,
    mode: LavaRenderMode,
    settings: &LavaRenderSettings,
    detail: Option<&LavaDetail>,
) {
    let lit = mode == LavaRenderMode::Lit;
    material.unlit = !lit;
    let s = if lit { settings.emissive_nits.max(0.0) } else { 0.0 };
    material.emissive = LinearRgba::rgb(s, s, s);
    let detail = detail.filter(|_| lit);
    material.base_color_texture = detail.map(|d| d.albedo.clone());
    material.metallic_roughness_texture = detail.map(|d| d.roughness.clone());
    material.normal_map_texture = detail.map(|d| d.normal.clone());
    // The roughness map holds the roughness itself.
    material.perceptual_roughness = if detail.is_some() { 1.0 } else { 0.45 };
}

/// What [`update_surfaces`] reads of a field.
type FieldItem = (
    Entity,
    &'static LavaField,
    Ref<'static, LavaState>,
    Option<&'static Transform>,
    Option<&'static Children>,
);

/// The local transform that draws a child at `world` under a parent at `parent`. A field's
/// lava is simulated in world coordinates (its grid already moved by the entity's
/// translation), so its surface and lights, children of the entity, cancel the entity's
/// transform (a rotation or scale the simulation ignores is ignored here too).
pub(crate) fn in_world_space(parent: Option<&Transform>, world: Transform) -> Transform {
    match parent {
        Some(p) if *p != Transform::IDENTITY => {
            Transform::from_matrix(p.to_matrix().inverse() * world.to_matrix())
        }
        _ => world,
    }
}

/// A field whose transform or children changed.
type MovedOrNewChildren = Or<(Changed<Transform>, Changed<Children>)>;

/// Keeps the surface child of every moved field where the simulation has the lava.
fn keep_surfaces_in_world_space(
    fields: Query<(&Transform, &Children), (With<LavaState>, MovedOrNewChildren)>,
    mut surfaces: Query<&mut Transform, (With<LavaSurface>, Without<LavaState>)>,
) {
    for (parent, children) in &fields {
        let local = in_world_space(Some(parent), Transform::IDENTITY);
        for child in children.iter() {
            if let Ok(mut t) = surfaces.get_mut(child) {
                t.set_if_neq(local);
            }
        }
    }
}

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
    detail: Option<Res<LavaDetail>>,
) {
    let detail = detail.as_deref();
    let (Some(meshes), Some(images), Some(materials)) =
        (meshes.as_mut(), images.as_mut(), materials.as_mut())
    else {
        return;
    };
    let restyle = mode.is_changed() || settings.is_changed();
    for (entity, field, state, frame, children) in &fields {
        let existing = children.and_then(|c| c.iter().find(|c| surfaces.contains(*c)));
        let Some(child) = existing else {
            let pattern = GlowPattern::new(&state.flow);
            let image = images.add(emissive_image(pattern.width, pattern.height, Vec::new()));
            let mut material = StandardMaterial {
                base_color: Color::WHITE,
                emissive_texture: Some(image.clone()),
                emissive_exposure_weight: 1.0,
                reflectance: 0.35,
                base_color_channel: UvChannel::Uv1,
                metallic_roughness_channel: UvChannel::Uv1,
                normal_map_channel: UvChannel::Uv1,
                ..default()
            };
            style_material(&mut material, *mode, &settings, detail);
            let material = materials.add(material);
            let mesh = surface_mesh(&state.flow, &state.surface.crust, &field.params, *mode);
            commands.entity(entity).insert_if_new((Transform::IDENTITY, Visibility::default()));
            commands.spawn((
                Name::new("Lava surface"),
                LavaSurface {
                    image,
                    material: material.clone(),
                    frames: 0,
                    dirty: true,
                    texels: Vec::new(),
                    pattern,
                },
                Mesh3d(meshes.add(mesh)),
                MeshMaterial3d(material),
                in_world_space(frame, Transform::IDENTITY),
                Visibility::Hidden,
                // A sheet centimetres to decimetres thick: its own shadows are negligible (one
                // less shadow pass). It still receives shadows (ropes, obstacles).
                NotShadowCaster,
                ChildOf(entity),
            ));
            continue;
        };
        let Ok((mut surface, mesh3d, mut visibility)) = surfaces.get_mut(child) else { continue };
        let surface = &mut *surface;
        surface.frames = surface.frames.saturating_add(1);
        surface.dirty |= state.is_changed() || restyle;
        if restyle && let Some(mut m) = materials.get_mut(&surface.material) {
            style_material(&mut m, *mode, &settings, detail);
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
            keep_over_terrain(&mut mesh, |x, z| drawn.height_at(x, z));
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
            if !surface.pattern.fits(&state.flow) {
                surface.pattern = GlowPattern::new(&state.flow);
            }
            glow_texels(&state.flow, crust, &field.params, &surface.pattern, &mut surface.texels);
            let (w, h) = (surface.pattern.width, surface.pattern.height);
            let _ = images.insert(surface.image.id(), emissive_image(w, h, surface.texels.clone()));
            // Touch the material so its bind group picks up the new texture (`into_inner` marks
            // it modified; a bare `get_mut` marks nothing in Bevy 0.19).
            if let Some(m) = materials.get_mut(&surface.material) {
                m.into_inner();
            }
        }
        surface.frames = 0;
        surface.dirty = false;
    }
}
