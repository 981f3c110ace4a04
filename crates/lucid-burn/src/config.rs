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

/// The keys that `requested` (TOML text) sets to other values than `recorded` (a run's
/// configuration, as TOML) has, as `key = requested (the run has recorded)`; keys in `free`
/// may differ. Numbers compare by value (`1` equals `1.0`).
pub fn changed_keys(requested: &str, recorded: &str, free: &[&str]) -> Result<Vec<String>, String> {
    let requested: toml::Table = toml::from_str(requested).map_err(|e| toml_error(requested, &e))?;
    let recorded: toml::Table = toml::from_str(recorded).map_err(|e| toml_error(recorded, &e))?;
    let mut changed = Vec::new();
    compare_tables(&requested, Some(&recorded), "", free, &mut changed);
    Ok(changed)
}

fn compare_tables(a: &toml::Table, b: Option<&toml::Table>, prefix: &str, free: &[&str], out: &mut Vec<String>) {
    for (key, value) in a {
        let path = if prefix.is_empty() { key.clone() } else { format!("{prefix}.{key}") };
        let other = b.and_then(|b| b.get(key));
        match value {
            toml::Value::Table(table) => compare_tables(table, other.and_then(toml::Value::as_table), &path, free, out),
            _ if free.contains(&path.as_str()) => {}
            _ => {
                let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
                let same = match (other, number(value)) {
                    (Some(o), Some(x)) => number(o) == Some(x),
                    (Some(o), None) => o == value,
                    (None, _) => false,
                };
                if !same {
                    let had = other.map_or("nothing".to_string(), |o| o.to_string());
                    out.push(format!("{path} = {value} (the run has {had})"));
                }
            }
        }
    }
}

/// A configuration file's text (empty for the defaults) with `KEY=VALUE` overrides applied
/// (`--set train.steps=500`: dotted keys, TOML values, a bare word taken as a string), as
/// TOML, and where it came from for messages.
pub fn config_text(file: Option<&std::path::Path>, overrides: &[String]) -> Result<(String, String), String> {
    let (text, origin) = match file {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
            // A byte-order mark (Windows editors write one) is not part of the TOML.
            (text.strip_prefix('\u{feff}').unwrap_or(&text).to_string(), path.display().to_string())
        }
        None => (String::new(), "default configuration".to_string()),
    };
    let mut value: toml::Table = toml::from_str(&text).map_err(|e| format!("{origin}: {}", toml_error(&text, &e)))?;
    for item in overrides {
        let (key, raw) = item.split_once('=').ok_or_else(|| format!("--set {item}: expected KEY=VALUE"))?;
        let parsed: toml::Value = toml::from_str::<toml::Table>(&format!("v = {raw}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(raw.to_string()));
        let mut table = &mut value;
        let parts: Vec<&str> = key.trim().split('.').collect();
        for part in &parts[..parts.len() - 1] {
            table = table
                .entry(part.to_string())
                .or_insert_with(|| toml::Value::Table(Default::default()))
                .as_table_mut()
                .ok_or_else(|| format!("--set {item}: {part} is not a table"))?;
        }
        table.insert(parts[parts.len() - 1].to_string(), parsed);
    }
    let origin = if overrides.is_empty() { origin } else { format!("{origin} with --set {}", overrides.join(" ")) };
    Ok((toml::to_string(&value).map_err(|e| format!("{origin}: {e}"))?, origin))
}
