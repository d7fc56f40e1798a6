//! Per-pixel ground detail: the terrain's material is a [`StandardMaterial`] extended by
//! [`GroundDetailExtension`], whose fragment shader (`detail.wgsl`) adds what the mesh cannot
//! carry. The mesh has a vertex every 40 m on the default 512² terrain, so its colours and
//! normals hold nothing finer than about 80 m: seen from a few hundred metres, every slope on
//! its own would be a smooth, out-of-focus gradient.
//!
//! The shader sums gradient noise of the world position `(x, z)` at seven wavelengths from
//! 160 m down to 0.66 m (each 2.5 times finer; the coarsest overlap what the vertices carry, but
//! per pixel, so a slope seen from kilometres away is not a blur either) into a small height field, and uses it twice: its
//! gradient tilts the interpolated mesh normal (bumps and runnels that catch the sun), and the
//! octaves' values, equally weighted, vary the brightness of the vertex colour (patches from
//! tens of metres down to stones). Each octave fades out as the pixel's footprint rises from a
//! quarter to half its wavelength, so no octave is sampled fewer than two times per
//! wavelength: distant ground keeps the vertex colour and normal, without aliasing or shimmer.
//! The footprint is anisotropic, as a GPU's anisotropic texture filtering is: the ground-plane
//! steps to the next pixel across and down (`dpdx`, `dpdy` of the world `x, z`) are short
//! across a grazing view and long along it, so the fade follows the short one (but no less
//! than a quarter of the long one) and each octave is averaged over up to four taps spread
//! along the long one. Faded by the long step alone, every octave would be gone from the
//! ground a kilometre or more in front of a scene camera a few hundred metres up, and that
//! ground — most of every frame — would be a smooth smear (`tests/headless_ground_detail.rs`,
//! the grazing view).
//!
//! How much each pixel takes is read from its vertex colour (the land-cover rules of
//! [`super::ground_color`], the deposit tint and frozen lava are all in it): full relief on
//! rock, scoria, ash, soil and basalt; about a third on vegetation (greenness of the colour);
//! half on snow (bright); none on water (blue over red). These are look rules, not physics.

use bevy::asset::embedded_asset;
use bevy::pbr::{ExtendedMaterial, MaterialExtension, StandardMaterial};
use bevy::prelude::*;
use bevy::render::render_resource::AsBindGroup;
use bevy::shader::ShaderRef;
use volcano_core::ConfigError;
use volcano_core::error::in_range;

/// Asset path of the embedded shader.
pub const GROUND_DETAIL_SHADER: &str = "embedded://volcano_render/terrain/detail.wgsl";

/// The terrain's material: the standard PBR material (white base colour times the vertex
/// colours) with [`GroundDetailExtension`].
pub type TerrainMaterial = ExtendedMaterial<StandardMaterial, GroundDetailExtension>;

/// How strongly the terrain shows per-pixel detail (see the module docs). Changing the
/// resource updates the terrain material; an invalid value is reported once and ignored.
#[derive(Resource, Debug, Clone, Copy, PartialEq, Reflect)]
#[reflect(Resource, Default, Debug)]
pub struct GroundDetail {
    /// Scale of the brightness variation (0 = the vertex colour alone, 1 = default: about
    /// ±20 % on bare ground; at most [`GroundDetail::MAX`]).
    pub albedo: f32,
    /// Scale of the detail relief that tilts the normals (0 = the mesh normal alone, 1 =
    /// default: slopes of about 10° typical, tilts capped at 31°, on bare ground; at most [`GroundDetail::MAX`]).
    pub relief: f32,
}

impl Default for GroundDetail {
    fn default() -> Self {
        Self { albedo: 1.0, relief: 1.0 }
    }
}

impl GroundDetail {
    /// Largest accepted scale of either field.
    pub const MAX: f32 = 4.0;

    /// No detail: the terrain looks as its vertex colours and mesh normals alone.
    pub const OFF: Self = Self { albedo: 0.0, relief: 0.0 };

    /// Checks both fields (finite, in `0..=MAX`).
    pub fn validate(&self) -> Result<(), ConfigError> {
        in_range("GroundDetail.albedo", self.albedo as f64, 0.0, Self::MAX as f64)?;
        in_range("GroundDetail.relief", self.relief as f64, 0.0, Self::MAX as f64)?;
        Ok(())
    }
}

/// The detail extension of [`TerrainMaterial`]: the shader's uniform (`x` albedo scale, `y`
/// relief scale, `z`, `w` unused), copied from [`GroundDetail`].
#[derive(Asset, AsBindGroup, Debug, Clone, Copy, PartialEq, Reflect)]
pub struct GroundDetailExtension {
    /// Albedo and relief scales (see [`GroundDetail`]).
    #[uniform(100)]
    pub scales: Vec4,
}

impl From<GroundDetail> for GroundDetailExtension {
    fn from(d: GroundDetail) -> Self {
        Self { scales: Vec4::new(d.albedo, d.relief, 0.0, 0.0) }
    }
}

impl MaterialExtension for GroundDetailExtension {
    fn fragment_shader() -> ShaderRef {
        GROUND_DETAIL_SHADER.into()
    }

    fn deferred_fragment_shader() -> ShaderRef {
        GROUND_DETAIL_SHADER.into()
    }
}

/// Registers the shader, the material (its render plugin only when there is a renderer) and
/// the [`GroundDetail`] resource.
pub(super) fn build(app: &mut App) {
    embedded_asset!(app, "detail.wgsl");
    crate::add_material::<TerrainMaterial>(app);
    app.init_resource::<GroundDetail>()
        .register_type::<GroundDetail>()
        .register_type::<GroundDetailExtension>()
        .add_systems(Update, apply_ground_detail);
}

/// Copies a changed [`GroundDetail`] into the terrain material (an invalid one is logged once
/// per change and leaves the material as it was).
fn apply_ground_detail(
    detail: Res<GroundDetail>,
    assets: Option<Res<super::TerrainAssets>>,
    mut materials: Option<ResMut<Assets<TerrainMaterial>>>,
) {
    let (Some(assets), Some(materials)) = (assets, materials.as_mut()) else { return };
    if !detail.is_changed() && !assets.is_added() {
        return;
    }
    if let Err(e) = detail.validate() {
        error!("ground detail not applied: {e}");
        return;
    }
    let wanted = GroundDetailExtension::from(*detail);
    if materials.get(&assets.terrain_material).is_some_and(|m| m.extension != wanted)
        && let Some(mut m) = materials.get_mut(&assets.terrain_material)
    {
        m.extension = wanted;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_validated() {
        assert!(GroundDetail::default().validate().is_ok());
        assert!(GroundDetail::OFF.validate().is_ok());
        for bad in [-0.1, f32::NAN, f32::INFINITY, GroundDetail::MAX + 0.1] {
            assert!(GroundDetail { albedo: bad, ..default() }.validate().is_err(), "albedo {bad}");
            assert!(GroundDetail { relief: bad, ..default() }.validate().is_err(), "relief {bad}");
        }
    }

    /// A changed resource reaches the material; an invalid one leaves it as it was.
    #[test]
    fn the_material_follows_the_setting() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, bevy::asset::AssetPlugin::default()))
            .init_asset::<Mesh>()
            .init_asset::<StandardMaterial>()
            .add_plugins((volcano_core::VolcanoCorePlugin, super::super::TerrainRenderPlugin));
        app.finish();
        app.cleanup();
        app.update();
        let scales = |app: &App| {
            let handle = app.world().resource::<super::super::TerrainAssets>().terrain_material.clone();
            app.world().resource::<Assets<TerrainMaterial>>().get(&handle).unwrap().extension.scales
        };
        assert_eq!(scales(&app), Vec4::new(1.0, 1.0, 0.0, 0.0));
        *app.world_mut().resource_mut::<GroundDetail>() = GroundDetail { albedo: 0.5, relief: 2.0 };
        app.update();
        assert_eq!(scales(&app), Vec4::new(0.5, 2.0, 0.0, 0.0));
        *app.world_mut().resource_mut::<GroundDetail>() = GroundDetail { albedo: f32::NAN, relief: 0.0 };
        app.update();
        assert_eq!(scales(&app), Vec4::new(0.5, 2.0, 0.0, 0.0));
    }
}
