//! Configuration pieces every trainer shares.

use serde::{Deserialize, Serialize};

/// Background colour behind the scene.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Background {
    /// White (the NeRF-synthetic evaluation convention).
    White,
    /// Black.
    Black,
    /// A random colour per ray and step (training only): the model cannot hide the
    /// background in the scene, so it learns true transparency.
    Random,
}

/// A TOML error on one line: the message and where it is.
pub fn toml_error(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim().replace('\n', " ");
    match e.span() {
        Some(span) => {
            let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
            format!("line {line}: {message}")
        }
        None => message,
    }
}

/// Parses a configuration from TOML text and validates it; `origin` (the file) prefixes
/// every message.
pub fn parse_config<T: serde::de::DeserializeOwned>(
    text: &str,
    origin: &str,
    validate: impl FnOnce(&T) -> Result<(), String>,
) -> Result<T, String> {
    let config: T = toml::from_str(text).map_err(|e| format!("{origin}: {}", toml_error(text, &e)))?;
    validate(&config).map_err(|e| format!("{origin}: {e}"))?;
    Ok(config)
}

/// `Ok` if `v` is a finite positive number, else a message naming `key`.
pub fn positive(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 { Ok(()) } else { Err(format!("{key} must be a positive number, got {v}")) }
}

/// `Ok` if `v` is finite and not negative, else a message naming `key`.
pub fn non_negative(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(format!("{key} must be zero or positive, got {v}")) }
}
