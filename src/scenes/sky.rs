//! The optional sky of a scene: exposure, ambient light and the gradient sky's colours, for
//! scenes that are not lit like the default day (`eruption_night`). Every field is optional;
//! an omitted one keeps `volcano_render::SkySettings`' default. Applied when the scene spawns
//! its camera (with the `render` feature; a headless run parses and checks it only).

use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use volcano_core::error::{ConfigError, finite, in_range, positive};

/// A linear RGB colour in a scene file, each channel 0–10 (display units: 1.0 is white after
/// exposure for the sky colours; a tint for the ambient light).
pub type SceneRgb = (f32, f32, f32);

/// A scene's sky (`sky: Some((exposure_ev100: Some(9.0), …))` in a scene file).
#[derive(Debug, Clone, Copy, Default, PartialEq, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneSky {
    /// Camera exposure (EV100, −10–20); the default is a sunny day's 13. Emissive surfaces
    /// (lava, the vent, in nits) and lights scale with it; the sky colours below do not.
    pub exposure_ev100: Option<f32>,
    /// Ambient (sky fill) light, cd/m² (0–100,000).
    pub ambient_brightness: Option<f32>,
    /// Ambient light colour.
    pub ambient_colour: Option<SceneRgb>,
    /// Gradient sky colour straight up.
    pub zenith: Option<SceneRgb>,
    /// Gradient sky colour at the horizon (and the distance fog's).
    pub horizon: Option<SceneRgb>,
    /// Gradient sky colour below the horizon.
    pub ground: Option<SceneRgb>,
    /// Distance at which the fog leaves 5 % contrast (m, > 0).
    pub visibility_m: Option<f32>,
}

impl SceneSky {
    /// Checks every field that is set.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if let Some(ev) = self.exposure_ev100 {
            in_range("sky.exposure_ev100", ev as f64, -10.0, 20.0)?;
        }
        if let Some(b) = self.ambient_brightness {
            in_range("sky.ambient_brightness", b as f64, 0.0, 100_000.0)?;
        }
        for (name, colour) in [
            ("sky.ambient_colour", self.ambient_colour),
            ("sky.zenith", self.zenith),
            ("sky.horizon", self.horizon),
            ("sky.ground", self.ground),
        ] {
            if let Some((r, g, b)) = colour {
                for v in [r, g, b] {
                    finite(name, v as f64)?;
                    in_range(name, v as f64, 0.0, 10.0)?;
                }
            }
        }
        if let Some(v) = self.visibility_m {
            positive("sky.visibility_m", v as f64)?;
        }
        Ok(())
    }

    /// Writes the fields that are set into `settings`.
    #[cfg(feature = "render")]
    pub fn apply(&self, settings: &mut volcano_render::SkySettings) {
        let rgb = |(r, g, b): SceneRgb| bevy::color::LinearRgba::rgb(r, g, b);
        if let Some(ev) = self.exposure_ev100 {
            settings.exposure_ev100 = ev;
        }
        if let Some(b) = self.ambient_brightness {
            settings.ambient_brightness = b;
        }
        if let Some(c) = self.ambient_colour {
            settings.ambient_color = rgb(c).into();
        }
        let g = &mut settings.gradient;
        if let Some(c) = self.zenith {
            g.zenith = rgb(c);
        }
        if let Some(c) = self.horizon {
            g.horizon = rgb(c);
        }
        if let Some(c) = self.ground {
            g.ground = rgb(c);
        }
        if let Some(v) = self.visibility_m {
            g.visibility = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_sky_fields_are_named() {
        let ok = SceneSky { exposure_ev100: Some(9.0), horizon: Some((0.01, 0.02, 0.05)), ..default() };
        assert!(ok.validate().is_ok());
        let e = SceneSky { exposure_ev100: Some(f32::NAN), ..default() }.validate().unwrap_err();
        assert!(e.to_string().contains("exposure_ev100"), "{e}");
        let e = SceneSky { zenith: Some((0.1, -0.2, 0.3)), ..default() }.validate().unwrap_err();
        assert!(e.to_string().contains("sky.zenith"), "{e}");
        let e = SceneSky { visibility_m: Some(0.0), ..default() }.validate().unwrap_err();
        assert!(e.to_string().contains("visibility_m"), "{e}");
    }

    #[cfg(feature = "render")]
    #[test]
    fn only_the_fields_set_change_the_settings() {
        let mut s = volcano_render::SkySettings::default();
        let before = s.clone();
        SceneSky { exposure_ev100: Some(9.0), ..default() }.apply(&mut s);
        assert_eq!(s.exposure_ev100, 9.0);
        assert_eq!(volcano_render::SkySettings { exposure_ev100: before.exposure_ev100, ..s }, before);
    }
}
