//! Parameter and configuration files: TOML everywhere, with errors that name
//! the file, the line, the column and the section.
//!
//! One way to read parameters: [`read_section`] reads a named section of
//! any TOML file (`"planner"` of a campaign config, `""` for a whole
//! parameter file) into a [`ConfigSection`] type. Missing keys take that
//! type's own `Default` (its documented defaults, never another type's
//! preset); [`read_section_over`] lays the keys given over a base value
//! instead (the campaign config over its demo preset). Unknown keys are
//! refused in every case: a typo must not silently fall back to a default.

use std::marker::PhantomData;
use std::path::Path;

use serde::de::{DeserializeOwned, DeserializeSeed, IgnoredAny, MapAccess, Visitor};
use serde::{Deserializer, Serialize};

use crate::error::{Location, Result, SceneError};
use crate::fsio;

/// A parameter type read from a section of a TOML file: every key has a
/// default (`#[serde(default)]`), unknown keys are refused
/// (`#[serde(deny_unknown_fields)]`), and [`ConfigSection::check`] tests the
/// ranges after reading. Each crate keeps its own error type.
pub trait ConfigSection: Serialize + DeserializeOwned + Default + Clone {
    /// The error the type's readers return (a [`SceneError`] converts).
    type Error: From<SceneError>;

    /// Checks every range; `place` names the file and section
    /// (`"plan.toml"`, `"site.toml: [planner]"`) for the message, which
    /// names the key and its value.
    fn check(&self, place: &str) -> std::result::Result<(), Self::Error>;
}

/// Where a section is, for messages: `"file"` or `"file: [section]"`.
fn place(path: &Path, section: &str) -> String {
    if section.is_empty() {
        path.display().to_string()
    } else {
        format!("{}: [{section}]", path.display())
    }
}

/// Reads `section` of the TOML `text` into `T` and checks it; `path` names
/// the file in errors. `section` is a dotted table path (`"planner"`,
/// `"training.site"`) or `""` for the whole file; an absent section is all
/// defaults. Keys of other sections are not looked at (see [`check_keys`]).
pub fn read_section<T: ConfigSection>(
    text: &str,
    path: &Path,
    section: &str,
) -> std::result::Result<T, T::Error> {
    let t = parse_section::<T>(text, path, section)?.unwrap_or_default();
    t.check(&place(path, section))?;
    Ok(t)
}

/// [`read_section`] of a file ([`load_toml`]'s JSON refusal included).
pub fn load_section<T: ConfigSection>(
    path: &Path,
    section: &str,
) -> std::result::Result<T, T::Error> {
    let text = read_toml_text(path)?;
    read_section(&text, path, section)
}

/// Like [`read_section`], but the keys the section names are laid over
/// `base` (descending into tables; arrays and values are replaced whole),
/// so missing keys keep `base`'s values: what the campaign config does over
/// its demo preset, and Python's keyword overrides over a preset.
pub fn read_section_over<T: ConfigSection>(
    base: &T,
    text: &str,
    path: &Path,
    section: &str,
) -> std::result::Result<T, T::Error> {
    // Parsed as `T` first: syntax, type and unknown-key errors keep their
    // line and column.
    parse_section::<T>(text, path, section)?;
    let Some(given) = parse_section::<toml::Value>(text, path, section)? else {
        base.check(&place(path, section))?;
        return Ok(base.clone());
    };
    // The overlay goes through JSON, which has no NaN or infinity: name
    // such a value's key here rather than fail later on a `null`.
    if let Some((key, v)) = first_non_finite(&given, section.to_string()) {
        return Err(SceneError::InvalidArgument(format!(
            "{}: {key} = {v}: must be a finite number",
            path.display()
        ))
        .into());
    }
    let place = place(path, section);
    let given = serde_json::to_value(&given)
        .map_err(|e| SceneError::InvalidArgument(format!("{place}: configuration: {e}")))?;
    with_overrides(base, given, &place)
}

/// `base` with `given` laid over it key by key, descending into tables
/// present in both (arrays and values are replaced whole), then checked:
/// what a TOML section and a Python dict that name only the keys they
/// change both go through. `place` names the file and section in errors
/// (`""` for none).
pub fn with_overrides<T: ConfigSection>(
    base: &T,
    given: serde_json::Value,
    place: &str,
) -> std::result::Result<T, T::Error> {
    let t = overlaid(base, given, place)?;
    t.check(place)?;
    Ok(t)
}

/// `base` with `given` laid over it, through JSON. serde_json's error has
/// no path: the table at fault is found by laying `given`'s tables over
/// `base` one at a time.
fn overlaid<T: ConfigSection>(base: &T, given: serde_json::Value, place: &str) -> Result<T> {
    let prefix = if place.is_empty() {
        String::new()
    } else {
        format!("{place}: ")
    };
    let base = serde_json::to_value(base)
        .map_err(|e| SceneError::InvalidArgument(format!("{prefix}configuration: {e}")))?;
    let tables: Vec<(String, serde_json::Value)> = given
        .as_object()
        .map(|o| o.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
        .unwrap_or_default();
    let mut merged = base.clone();
    overlay(&mut merged, given);
    serde_json::from_value::<T>(merged).map_err(|e| {
        let at_fault = tables.iter().find_map(|(k, v)| {
            let mut one = base.clone();
            overlay(&mut one, serde_json::json!({ k.clone(): v.clone() }));
            serde_json::from_value::<T>(one).is_err().then(|| k.clone())
        });
        let m = match at_fault {
            Some(k) => format!("{prefix}configuration: [{k}]: {e}"),
            None => format!("{prefix}configuration: {e}"),
        };
        SceneError::InvalidArgument(m)
    })
}

/// Writes every key of `given` over `base`, descending into objects present
/// in both (arrays and values are replaced whole).
fn overlay(base: &mut serde_json::Value, given: serde_json::Value) {
    match (base, given) {
        (serde_json::Value::Object(b), serde_json::Value::Object(g)) => {
            for (key, value) in g {
                match b.get_mut(&key) {
                    Some(slot) => overlay(slot, value),
                    None => {
                        b.insert(key, value);
                    }
                }
            }
        }
        (slot, value) => *slot = value,
    }
}

/// The dotted key (with `[i]` for array elements) and value of the first
/// NaN or infinite float in `v`.
fn first_non_finite(v: &toml::Value, key: String) -> Option<(String, f64)> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some((key, *f)),
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| {
            let key = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            first_non_finite(v, key)
        }),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| first_non_finite(v, format!("{key}[{i}]"))),
        _ => None,
    }
}

/// `section` of `text` as `T`, `None` when the file has no such table.
/// Deserialised in place from the whole document (the other keys skipped),
/// so errors keep the line and column of the file.
fn parse_section<T: DeserializeOwned>(text: &str, path: &Path, section: &str) -> Result<Option<T>> {
    let keys: Vec<&str> = if section.is_empty() {
        Vec::new()
    } else {
        section.split('.').collect()
    };
    let seed = Section::<T> {
        keys: &keys,
        _t: PhantomData,
    };
    toml::de::Deserializer::parse(text)
        .and_then(|d| seed.deserialize(d))
        .map_err(|e| toml_error(&e, text, path, section))
}

/// Descends the table path `keys` and deserialises what it finds as `T`.
struct Section<'k, T> {
    keys: &'k [&'k str],
    _t: PhantomData<T>,
}

impl<'de, T: DeserializeOwned> DeserializeSeed<'de> for Section<'_, T> {
    type Value = Option<T>;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<Option<T>, D::Error> {
        if self.keys.is_empty() {
            return T::deserialize(d).map(Some);
        }
        d.deserialize_map(self)
    }
}

impl<'de, T: DeserializeOwned> Visitor<'de> for Section<'_, T> {
    type Value = Option<T>;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "a table holding [{}]", self.keys.join("."))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> std::result::Result<Option<T>, A::Error> {
        let mut found = None;
        while let Some(key) = map.next_key::<String>()? {
            if key == self.keys[0] {
                found = map.next_value_seed(Section::<T> {
                    keys: &self.keys[1..],
                    _t: PhantomData,
                })?;
            } else {
                map.next_value::<IgnoredAny>()?;
            }
        }
        Ok(found)
    }
}

/// A TOML error as a [`SceneError`] naming the file, the line, the column
/// and the table (the last `[header]` above the line, else `section`).
fn toml_error(e: &toml::de::Error, text: &str, path: &Path, section: &str) -> SceneError {
    let Some(span) = e.span() else {
        let m = e.message().trim();
        return match section {
            "" => SceneError::parse(path, Location::Header, m.to_string()),
            s => SceneError::parse(path, Location::Header, format!("{m} (in [{s}])")),
        };
    };
    let before = &text[..span.start.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    let table = text
        .lines()
        .take(line)
        .filter_map(header)
        .last()
        .unwrap_or_else(|| section.to_string());
    let mut m = format!("column {column}: {}", e.message().trim());
    if !table.is_empty() {
        m = format!("{m} (in [{table}])");
    }
    SceneError::parse(path, Location::Line(line), m)
}

/// The table a `[name]` or `[[name]]` header line opens.
fn header(line: &str) -> Option<String> {
    let l = line.trim();
    let inner = l.strip_prefix('[')?;
    let inner = inner.strip_prefix('[').unwrap_or(inner);
    let end = inner.find(']')?;
    let name = inner[..end].trim();
    // A line of a multi-line array (`[0.0, 1.0],`) is no header.
    let ok = |c: char| c.is_alphanumeric() || "_-.\" '".contains(c);
    (!name.is_empty() && name.chars().all(ok)).then(|| name.to_string())
}

/// Parses TOML `text` into `T`; `path` names the file in errors. Syntax,
/// type and unknown-key errors carry their line and column.
pub fn parse_toml<T: DeserializeOwned>(text: &str, path: &Path) -> Result<T> {
    toml::from_str(text).map_err(|e| toml_error(&e, text, path, ""))
}

/// Reads and parses a TOML file into `T` ([`parse_toml`]). A file that looks
/// like JSON (vpctl once took JSON parameter files) is refused with a message
/// saying so, rather than a TOML syntax error at its first brace.
pub fn load_toml<T: DeserializeOwned>(path: &Path) -> Result<T> {
    parse_toml(&read_toml_text(path)?, path)
}

/// The text of a parameter file; JSON is refused (see [`load_toml`]).
fn read_toml_text(path: &Path) -> Result<String> {
    let text = fsio::read_text(path)?;
    if text.trim_start().starts_with('{') {
        return Err(SceneError::parse(
            path,
            Location::Line(1),
            "this looks like JSON; parameter files are TOML now (`key = value` lines; \
             the `defaults` subcommand of the tool prints every key)",
        ));
    }
    Ok(text)
}

#[cfg(test)]
#[path = "config_file_tests.rs"]
mod tests;
