//! Errors for parameters that enter from users (constructors, RON presets, files).

use thiserror::Error;

/// A parameter or file rejected where it entered. The message names the parameter, the value
/// and the accepted range so a user can fix it without reading the code.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ConfigError {
    /// A numeric parameter is NaN, infinite, or outside its accepted range.
    #[error("invalid parameter `{name}` = {value}: {reason}")]
    InvalidParameter {
        /// Parameter name as written in presets.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What is accepted.
        reason: String,
    },
    /// A RON text could not be parsed.
    #[error("malformed RON: {0}")]
    Ron(String),
    /// An image could not be read or has an unsupported format.
    #[error("image error: {0}")]
    Image(String),
    /// A file could not be read or written.
    #[error("I/O error on {path}: {message}")]
    Io {
        /// Path of the file.
        path: String,
        /// The system's message.
        message: String,
    },
    /// A file was read but what it holds was rejected: the file, and the error inside it.
    #[error("{path}: {source}")]
    InFile {
        /// Path of the file.
        path: String,
        /// What was wrong in it.
        source: Box<ConfigError>,
    },
    /// A name (scene, preset) is unknown.
    #[error("unknown {kind} `{name}`; known: {known}")]
    UnknownName {
        /// What kind of name ("scene", "preset").
        kind: &'static str,
        /// The requested name.
        name: String,
        /// Comma-separated list of known names.
        known: String,
    },
}

impl ConfigError {
    /// This error as found in the file at `path` (an I/O error or one already placed in a file
    /// names its file already and is returned as it is).
    pub fn in_file(self, path: &std::path::Path) -> Self {
        match self {
            e @ (ConfigError::Io { .. } | ConfigError::InFile { .. }) => e,
            e => ConfigError::InFile { path: path.display().to_string(), source: Box::new(e) },
        }
    }
}

/// Checks that `value` is finite and strictly positive.
pub fn positive(name: &'static str, value: f64) -> Result<f64, ConfigError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ConfigError::InvalidParameter {
            name,
            value,
            reason: "must be a finite number greater than 0".into(),
        })
    }
}

/// Checks that `value` is finite and within `[min, max]`.
pub fn in_range(name: &'static str, value: f64, min: f64, max: f64) -> Result<f64, ConfigError> {
    if value.is_finite() && value >= min && value <= max {
        Ok(value)
    } else {
        Err(ConfigError::InvalidParameter {
            name,
            value,
            reason: format!("must be a finite number in [{min}, {max}]"),
        })
    }
}

/// Checks that `value` is finite.
pub fn finite(name: &'static str, value: f64) -> Result<f64, ConfigError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ConfigError::InvalidParameter { name, value, reason: "must be finite".into() })
    }
}

impl From<ron::error::SpannedError> for ConfigError {
    fn from(e: ron::error::SpannedError) -> Self {
        ConfigError::Ron(e.to_string())
    }
}
