//! [`VolcanoQuality`]: one resource that picks grid sizes, instance caps, cloud-volume
//! resolution and the plume's caps for a machine. It lives in the umbrella crate because it
//! sets the settings of several crates at once (`volcano_plume`'s [`PlumeCaps`] and
//! [`PlumeViewSettings`], `volcano_render`'s `CloudRenderSettings` and `AshFallSettings`, the
//! scene's atmosphere grid); the crates themselves keep their own settings resources and know
//! nothing of it.
//!
//! Nothing happens unless a game inserts the resource: without it every crate keeps its own
//! defaults, which are the `High` column ([`VolcanoQuality::High`] is today's values). When it
//! is inserted or changed, [`VolcanoQualityPlugin`] writes the level's [`QualitySettings`]
//! into those resources in `PreUpdate` (overwriting edits of the same fields). What needs a
//! restart: the atmosphere grid, read when a scene ([`crate::scenes::VolcanoScenePlugin`])
//! spawns its atmosphere at startup. Everything else applies on the next frame.

use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use volcano_plume::{PlumeCaps, PlumeViewSettings};

/// Quality level (a resource; insert it before `App::run`, or change it live).
#[derive(Resource, Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Reflect, Serialize, Deserialize)]
#[reflect(Resource, Debug, Default)]
pub enum VolcanoQuality {
    /// Coarse weather, small clouds, few instances, tight caps (the soak runs at this level).
    Low,
    /// Half the weather resolution, smaller clouds.
    Medium,
    /// The crates' defaults.
    #[default]
    High,
    /// Twice the weather resolution, larger clouds, more instances.
    Ultra,
}

/// What a level sets (plain numbers; docs/QUALITY.md gives their cost).
#[derive(Debug, Clone, PartialEq, Reflect)]
pub struct QualitySettings {
    /// Factor on a scene atmosphere's cells per side (a power of two, the result kept in
    /// 16–1024). Needs a restart.
    pub atmosphere_grid_scale: f64,
    /// Cloud volume voxels per side horizontally (`CloudRenderSettings::voxels_xy`).
    pub cloud_voxels_xy: u32,
    /// Cloud volume voxels vertically (`CloudRenderSettings::voxels_z`).
    pub cloud_voxels_z: u32,
    /// Ray-march steps per pixel through the clouds (`CloudRenderSettings::step_count`).
    pub cloud_steps: u32,
    /// Strength of the clouds' lumps noise (`CloudRenderSettings::detail`): 0 at `Low` skips
    /// the noise (up to eight value-noise lookups per sample inside the box), leaving smooth
    /// clouds.
    pub cloud_detail: f32,
    /// Density samples per ray-march step (`CloudRenderSettings::substeps`): fewer are cheaper
    /// and let thin decks seen edge-on break into a per-pixel checker again.
    pub cloud_substeps: u32,
    /// Ray-march steps per pixel through the ash-fall curtain (`AshFallSettings::step_count`).
    pub ash_fall_steps: u32,
    /// Density samples per ash-fall march step (`AshFallSettings::substeps`; as for the
    /// clouds, fewer are cheaper and let a thin sheet of ash break into a checker).
    pub ash_fall_substeps: u32,
    /// Plume instances per frame ([`PlumeViewSettings::max_instances`]): the detail spheres per
    /// parent fall evenly when the column has more parents than fit.
    pub max_instances: u32,
    /// Caps on live slices, pyroclastic particles, secondary columns and umbrella spheres.
    pub caps: PlumeCaps,
}

impl VolcanoQuality {
    /// Every level, lowest first.
    pub const ALL: [VolcanoQuality; 4] =
        [VolcanoQuality::Low, VolcanoQuality::Medium, VolcanoQuality::High, VolcanoQuality::Ultra];

    /// The level's numbers.
    pub fn settings(self) -> QualitySettings {
        let caps = |max_live_slices, max_particles, max_secondary_per_step, max_umbrella_spheres| PlumeCaps {
            max_live_slices,
            max_particles,
            max_secondary_per_step,
            max_umbrella_spheres,
        };
        let (clouds, ash) = render_defaults();
        match self {
            VolcanoQuality::Low => QualitySettings {
                atmosphere_grid_scale: 0.25,
                cloud_voxels_xy: 96,
                cloud_voxels_z: 40,
                cloud_steps: 64,
                cloud_detail: 0.0,
                cloud_substeps: 2,
                ash_fall_steps: 64,
                ash_fall_substeps: 2,
                max_instances: 150_000,
                caps: caps(2_000, 20_000, 16, 20_000),
            },
            VolcanoQuality::Medium => QualitySettings {
                atmosphere_grid_scale: 0.5,
                cloud_voxels_xy: 160,
                cloud_voxels_z: 64,
                cloud_steps: 128,
                cloud_detail: clouds.3,
                cloud_substeps: 4,
                ash_fall_steps: ash.0,
                ash_fall_substeps: 4,
                max_instances: 500_000,
                caps: caps(5_000, 100_000, 64, 50_000),
            },
            VolcanoQuality::High => QualitySettings {
                atmosphere_grid_scale: 1.0,
                cloud_voxels_xy: clouds.0,
                cloud_voxels_z: clouds.1,
                cloud_steps: clouds.2,
                cloud_detail: clouds.3,
                cloud_substeps: clouds.4,
                ash_fall_steps: ash.0,
                ash_fall_substeps: ash.1,
                max_instances: PlumeViewSettings::default().max_instances,
                caps: PlumeCaps::default(),
            },
            VolcanoQuality::Ultra => QualitySettings {
                atmosphere_grid_scale: 2.0,
                cloud_voxels_xy: 384,
                cloud_voxels_z: 128,
                cloud_steps: 256,
                cloud_detail: clouds.3,
                cloud_substeps: clouds.4,
                ash_fall_steps: 192,
                ash_fall_substeps: ash.1,
                max_instances: 3_000_000,
                caps: caps(50_000, 1_000_000, 2_000, 200_000),
            },
        }
    }

    /// Cells per side of an atmosphere whose scene asks for `scene_cells` (a power of two).
    pub fn atmosphere_cells(self, scene_cells: usize) -> usize {
        let n = (scene_cells as f64 * self.settings().atmosphere_grid_scale).round() as usize;
        n.clamp(16, 1024)
    }
}

/// The renderer's defaults a level keeps (the `High` column): `CloudRenderSettings`' voxels,
/// steps, lumps strength and samples per step, and `AshFallSettings`' steps and samples per
/// step.
type RenderDefaults = ((u32, u32, u32, f32, u32), (u32, u32));

#[cfg(feature = "render")]
fn render_defaults() -> RenderDefaults {
    let c = volcano_render::CloudRenderSettings::default();
    let a = volcano_render::AshFallSettings::default();
    ((c.voxels_xy, c.voxels_z, c.step_count, c.detail, c.substeps), (a.step_count, a.substeps))
}

/// Without the renderer these numbers are not used; they are its defaults.
#[cfg(not(feature = "render"))]
fn render_defaults() -> RenderDefaults {
    ((256, 96, 192, 0.5, 8), (128, 8))
}

/// Applies an inserted or changed [`VolcanoQuality`] (part of `VolcanoSimPlugins`).
#[derive(Debug, Default, Clone, Copy)]
pub struct VolcanoQualityPlugin;

impl Plugin for VolcanoQualityPlugin {
    fn build(&self, app: &mut App) {
        app.register_type::<VolcanoQuality>().add_systems(PreUpdate, apply_quality);
    }
}

/// What a level changed, for the log.
fn apply_quality(
    quality: Option<Res<VolcanoQuality>>,
    mut caps: Option<ResMut<PlumeCaps>>,
    mut view: Option<ResMut<PlumeViewSettings>>,
    #[cfg(feature = "render")] mut clouds: Option<ResMut<volcano_render::CloudRenderSettings>>,
    #[cfg(feature = "render")] mut ash_fall: Option<ResMut<volcano_render::AshFallSettings>>,
) {
    let Some(quality) = quality.filter(|q| q.is_changed()) else { return };
    let s = quality.settings();
    if let Some(caps) = caps.as_mut() {
        caps.set_if_neq(s.caps.clone());
    }
    if let Some(view) = view.as_mut()
        && view.max_instances != s.max_instances
    {
        view.max_instances = s.max_instances;
    }
    #[cfg(feature = "render")]
    if let Some(c) = clouds.as_mut()
        && (c.voxels_xy, c.voxels_z, c.step_count, c.detail, c.substeps)
            != (s.cloud_voxels_xy, s.cloud_voxels_z, s.cloud_steps, s.cloud_detail, s.cloud_substeps)
    {
        c.voxels_xy = s.cloud_voxels_xy;
        c.voxels_z = s.cloud_voxels_z;
        c.step_count = s.cloud_steps;
        c.detail = s.cloud_detail;
        c.substeps = s.cloud_substeps;
    }
    #[cfg(feature = "render")]
    if let Some(a) = ash_fall.as_mut()
        && (a.step_count, a.substeps) != (s.ash_fall_steps, s.ash_fall_substeps)
    {
        a.step_count = s.ash_fall_steps;
        a.substeps = s.ash_fall_substeps;
    }
    info!("quality {:?} applied (the atmosphere grid needs a restart)", *quality);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_is_valid_and_high_is_the_defaults() {
        for q in VolcanoQuality::ALL {
            let s = q.settings();
            s.caps.validate().unwrap();
            assert!(q.atmosphere_cells(128).is_power_of_two(), "{q:?}");
        }
        let high = VolcanoQuality::High.settings();
        assert_eq!(high.caps, PlumeCaps::default());
        assert_eq!(high.max_instances, PlumeViewSettings::default().max_instances);
        assert_eq!(VolcanoQuality::High.atmosphere_cells(128), 128);
        assert_eq!(VolcanoQuality::Low.atmosphere_cells(128), 32);
        assert_eq!(VolcanoQuality::default(), VolcanoQuality::High);
    }

    #[test]
    fn an_inserted_level_is_applied_and_a_change_applies_live() {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, VolcanoQualityPlugin))
            .init_resource::<PlumeCaps>()
            .init_resource::<PlumeViewSettings>();
        // Not inserted: a game's own settings are left alone.
        app.world_mut().resource_mut::<PlumeViewSettings>().max_instances = 1234;
        app.update();
        assert_eq!(app.world().resource::<PlumeViewSettings>().max_instances, 1234);
        app.insert_resource(VolcanoQuality::Low);
        app.update();
        let low = VolcanoQuality::Low.settings();
        assert_eq!(*app.world().resource::<PlumeCaps>(), low.caps);
        assert_eq!(app.world().resource::<PlumeViewSettings>().max_instances, low.max_instances);
        *app.world_mut().resource_mut::<VolcanoQuality>() = VolcanoQuality::Ultra;
        app.update();
        assert_eq!(*app.world().resource::<PlumeCaps>(), VolcanoQuality::Ultra.settings().caps);
    }

    #[cfg(feature = "render")]
    #[test]
    fn low_turns_the_cloud_lumps_off_and_high_brings_them_back() {
        use volcano_render::{AshFallSettings, CloudRenderSettings};
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, VolcanoQualityPlugin))
            .init_resource::<CloudRenderSettings>()
            .init_resource::<AshFallSettings>();
        app.insert_resource(VolcanoQuality::Low);
        app.update();
        let low = app.world().resource::<CloudRenderSettings>().clone();
        assert_eq!(low.detail, 0.0);
        assert_eq!(low.step_count, VolcanoQuality::Low.settings().cloud_steps);
        assert_eq!(low.substeps, 2);
        low.validate().unwrap();
        // The ash-fall curtain's march follows the level too (not High's 128 × 8).
        let ash = app.world().resource::<AshFallSettings>().clone();
        assert_eq!((ash.step_count, ash.substeps), (64, 2));
        ash.validate().unwrap();
        for q in VolcanoQuality::ALL {
            let s = q.settings();
            AshFallSettings { step_count: s.ash_fall_steps, substeps: s.ash_fall_substeps, ..default() }
                .validate()
                .unwrap();
        }
        *app.world_mut().resource_mut::<VolcanoQuality>() = VolcanoQuality::High;
        app.update();
        assert_eq!(*app.world().resource::<CloudRenderSettings>(), CloudRenderSettings::default());
        assert_eq!(*app.world().resource::<AshFallSettings>(), AshFallSettings::default());
    }
}
