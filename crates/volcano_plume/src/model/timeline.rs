//! An eruption's story over time: a list of keys that set the vent (exit speed v₀, radius r₀
//! or mass eruption rate), switch the preset, or stop and restart the emission. A game scripts
//! an eruption with it (e.g. a Plinian phase that weakens until the column collapses into
//! pyroclastic flows) without code; `volcano` loads it as an asset (`*.timeline.ron`).
//!
//! Numeric channels (v₀, r₀, mass rate) are linear between the keys that give them and held
//! after the last; before the first key that gives a channel, the eruption keeps its own value.
//! Step channels (preset, active) take the value of the latest key at or before the time.
//!
//! `lava_rate` drives the volcano's own lava (a `LavaVent` beside the script; 0 stops it), so
//! one timeline tells a mixed eruption: a Plinian hour that ends in an effusive week.

use bevy::reflect::Reflect;
use serde::{Deserialize, Serialize};
use volcano_core::ConfigError;
use volcano_core::error::in_range;

use super::params::{PlumeParams, Preset};

/// One key of an [`EruptionTimeline`]. Every field but `at_s` is optional: a key sets only what
/// it names.
#[derive(Debug, Clone, PartialEq, Default, Reflect, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TimelineKey {
    /// Time of the key (s since the script started, ≥ 0; keys strictly increasing).
    pub at_s: f64,
    /// Vent exit speed v₀ (m/s, 0.1–1,000), linear between keys.
    pub v0: Option<f64>,
    /// Vent radius r₀ (m, 0.1–5,000), linear between keys. Not with `mass_rate` in one key.
    pub r0: Option<f64>,
    /// Mass eruption rate (kg/s, 1–10¹¹), linear between keys: sets r₀ from the current v₀
    /// ([`PlumeParams::with_mer`]).
    pub mass_rate: Option<f64>,
    /// From this key on, the preset's parameters (then the numeric channels apply).
    pub preset: Option<Preset>,
    /// From this key on, whether slices are emitted.
    pub active: Option<bool>,
    /// Effusion rate of the volcano's `LavaVent` (m³/s, 0–10⁶; 0 stops it), linear between
    /// keys. Applied by the `volcano` crate's plugins to a `LavaVent` on the scripted volcano.
    pub lava_rate: Option<f64>,
}

/// An eruption's keys in time order (see the module docs).
#[derive(Debug, Clone, PartialEq, Default, Reflect, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EruptionTimeline {
    /// The keys, strictly increasing in `at_s`.
    pub keys: Vec<TimelineKey>,
}

/// What a timeline says at one time; `None` where no key has set the channel yet.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TimelineState {
    /// Exit speed (m/s).
    pub v0: Option<f64>,
    /// Vent radius (m).
    pub r0: Option<f64>,
    /// Mass eruption rate (kg/s).
    pub mass_rate: Option<f64>,
    /// Preset in force.
    pub preset: Option<Preset>,
    /// Whether slices are emitted.
    pub active: Option<bool>,
    /// Lava effusion rate (m³/s).
    pub lava_rate: Option<f64>,
}

impl EruptionTimeline {
    /// Checks every key; the error names the first bad field (with its key's index).
    pub fn validate(&self) -> Result<(), ConfigError> {
        let mut last = f64::NEG_INFINITY;
        for (i, k) in self.keys.iter().enumerate() {
            let named = |field: &str, e: ConfigError| ConfigError::InvalidParameter {
                name: "timeline key",
                value: i as f64,
                reason: format!("keys[{i}].{field}: {e}"),
            };
            in_range("at_s", k.at_s, 0.0, 1e9).map_err(|e| named("at_s", e))?;
            if k.at_s <= last {
                return Err(named(
                    "at_s",
                    ConfigError::InvalidParameter {
                        name: "at_s",
                        value: k.at_s,
                        reason: format!("must be after the previous key's {last} s"),
                    },
                ));
            }
            last = k.at_s;
            if let Some(v) = k.v0 {
                in_range("v0", v, 0.1, 1_000.0).map_err(|e| named("v0", e))?;
            }
            if let Some(r) = k.r0 {
                in_range("r0", r, 0.1, 5_000.0).map_err(|e| named("r0", e))?;
            }
            if let Some(m) = k.mass_rate {
                in_range("mass_rate", m, 1.0, 1e11).map_err(|e| named("mass_rate", e))?;
            }
            if let Some(q) = k.lava_rate {
                in_range("lava_rate", q, 0.0, 1e6).map_err(|e| named("lava_rate", e))?;
            }
            if k.r0.is_some() && k.mass_rate.is_some() {
                return Err(named(
                    "mass_rate",
                    ConfigError::InvalidParameter {
                        name: "mass_rate",
                        value: k.mass_rate.unwrap_or_default(),
                        reason: "give r0 or mass_rate in one key, not both".into(),
                    },
                ));
            }
        }
        Ok(())
    }

    /// Parses and validates a RON text (`(keys: [(at_s: 0, v0: Some(200)), …])`).
    pub fn from_ron(text: &str) -> Result<Self, ConfigError> {
        let t: Self = ron::from_str(text)?;
        t.validate()?;
        Ok(t)
    }

    /// The channels at time `t` (s).
    pub fn sample(&self, t: f64) -> TimelineState {
        TimelineState {
            v0: self.linear(t, |k| k.v0),
            r0: self.linear(t, |k| k.r0),
            mass_rate: self.linear(t, |k| k.mass_rate),
            preset: self.latest(t, |k| k.preset),
            active: self.latest(t, |k| k.active),
            lava_rate: self.linear(t, |k| k.lava_rate),
        }
    }

    /// The time of the last key (s), 0 for an empty timeline.
    pub fn duration(&self) -> f64 {
        self.keys.last().map_or(0.0, |k| k.at_s)
    }

    fn linear(&self, t: f64, channel: impl Fn(&TimelineKey) -> Option<f64>) -> Option<f64> {
        let mut before: Option<(f64, f64)> = None;
        for k in &self.keys {
            let Some(v) = channel(k) else { continue };
            if k.at_s <= t {
                before = Some((k.at_s, v));
            } else {
                return before.map(|(t0, v0)| v0 + (v - v0) * (t - t0) / (k.at_s - t0));
            }
        }
        before.map(|(_, v)| v)
    }

    fn latest<T: Copy>(&self, t: f64, channel: impl Fn(&TimelineKey) -> Option<T>) -> Option<T> {
        self.keys.iter().take_while(|k| k.at_s <= t).filter_map(channel).last()
    }
}

impl TimelineState {
    /// Applies the numeric channels to `params` (v₀ first, then r₀ or the mass rate, which
    /// needs the new v₀). The caller applies a preset change before this. Errors (leaving
    /// `params` unchanged) if the result is out of range.
    pub fn apply(&self, params: &mut PlumeParams) -> Result<(), ConfigError> {
        let mut p = params.clone();
        if let Some(v0) = self.v0 {
            p.v0 = v0;
        }
        if let Some(r0) = self.r0 {
            p.r0 = r0;
        }
        if let Some(mer) = self.mass_rate {
            p = p.with_mer(mer, Some(p.v0))?;
        }
        p.validate()?;
        *params = p;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(at_s: f64) -> TimelineKey {
        TimelineKey { at_s, ..Default::default() }
    }

    #[test]
    fn channels_are_linear_between_their_keys_and_held_after() {
        let t = EruptionTimeline {
            keys: vec![
                TimelineKey { v0: Some(200.0), active: Some(true), ..key(0.0) },
                TimelineKey { preset: Some(Preset::PyroclasticShowcase), ..key(30.0) },
                TimelineKey { v0: Some(100.0), ..key(60.0) },
                TimelineKey { active: Some(false), ..key(90.0) },
            ],
        };
        t.validate().unwrap();
        assert_eq!(t.sample(0.0).v0, Some(200.0));
        // The preset key at 30 s gives no v0: the ramp runs from key 0 to key 2.
        assert_eq!(t.sample(30.0).v0, Some(150.0));
        assert_eq!(t.sample(45.0).v0, Some(125.0));
        assert_eq!(t.sample(500.0).v0, Some(100.0));
        assert_eq!(t.sample(29.9).preset, None);
        assert_eq!(t.sample(30.0).preset, Some(Preset::PyroclasticShowcase));
        assert_eq!(t.sample(89.0).active, Some(true));
        assert_eq!(t.sample(90.0).active, Some(false));
        assert_eq!(t.sample(10.0).r0, None, "no key gives r0: the eruption keeps its own");
    }

    #[test]
    fn a_plinian_hour_can_end_in_an_effusive_phase() {
        let t = EruptionTimeline::from_ron(
            "(keys: [(at_s: 0, preset: Some(PlinianShowcase), active: Some(true), lava_rate: Some(0)), \
             (at_s: 3600, active: Some(false), lava_rate: Some(0)), (at_s: 3900, lava_rate: Some(30)), \
             (at_s: 86400, lava_rate: Some(5))])",
        )
        .unwrap();
        assert_eq!((t.sample(1800.0).active, t.sample(1800.0).lava_rate), (Some(true), Some(0.0)));
        // The column stops at the hour; the lava rises to 30 m³/s over five minutes, then wanes.
        assert_eq!(t.sample(3600.0).active, Some(false));
        assert_eq!(t.sample(3750.0).lava_rate, Some(15.0));
        assert_eq!(t.sample(1e6).lava_rate, Some(5.0));
        let bad = EruptionTimeline { keys: vec![TimelineKey { lava_rate: Some(-1.0), ..key(0.0) }] };
        assert!(bad.validate().unwrap_err().to_string().contains("lava_rate"));
    }

    #[test]
    fn a_channel_before_its_first_key_is_left_to_the_eruption() {
        let t = EruptionTimeline { keys: vec![key(0.0), TimelineKey { r0: Some(50.0), ..key(10.0) }] };
        assert_eq!(t.sample(5.0).r0, None);
        assert_eq!(t.sample(10.0).r0, Some(50.0));
    }

    #[test]
    fn bad_keys_are_named() {
        let unordered = EruptionTimeline { keys: vec![key(10.0), key(10.0)] };
        let e = unordered.validate().unwrap_err().to_string();
        assert!(e.contains("keys[1].at_s"), "{e}");
        let slow = EruptionTimeline { keys: vec![TimelineKey { v0: Some(0.0), ..key(0.0) }] };
        let e = slow.validate().unwrap_err().to_string();
        assert!(e.contains("keys[0].v0"), "{e}");
        let both =
            EruptionTimeline { keys: vec![TimelineKey { r0: Some(9.0), mass_rate: Some(1e6), ..key(0.0) }] };
        assert!(both.validate().unwrap_err().to_string().contains("mass_rate"));
        let e = EruptionTimeline::from_ron("(keys: [(at_s: 0, vee0: Some(3))])").unwrap_err().to_string();
        assert!(e.contains("vee0"), "{e}");
        assert!(EruptionTimeline::from_ron("(keys: [(at_s: -1)])").is_err());
        assert!(
            EruptionTimeline::from_ron(
                "(keys: [(at_s: 0, v0: Some(200)), (at_s: 60, preset: Some(PyroclasticShowcase))])"
            )
            .is_ok()
        );
    }

    #[test]
    fn a_mass_rate_sizes_the_vent_for_the_current_speed() {
        let mut p = Preset::Physical.params();
        let s = TimelineState { v0: Some(120.0), mass_rate: Some(1e7), ..Default::default() };
        s.apply(&mut p).unwrap();
        assert_eq!(p.v0, 120.0);
        assert!((p.mass_eruption_rate() / 1e7 - 1.0).abs() < 1e-9, "{}", p.mass_eruption_rate());
        // Out of range after the change: nothing is applied.
        let before = p.clone();
        assert!(TimelineState { r0: Some(1e9), ..Default::default() }.apply(&mut p).is_err());
        assert_eq!(p, before);
    }
}
