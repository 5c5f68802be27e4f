//! Parameter and configuration files: TOML everywhere, with errors that name
//! the file, the line and the column.

use std::path::Path;

use serde::de::DeserializeOwned;

use crate::error::{Location, Result, SceneError};
use crate::fsio;

/// Parses TOML `text` into `T`; `path` names the file in errors. Syntax,
/// type and unknown-key errors carry their line and column.
pub fn parse_toml<T: DeserializeOwned>(text: &str, path: &Path) -> Result<T> {
    toml::from_str(text).map_err(|e| {
        let (location, column) = match e.span() {
            Some(span) => {
                let before = &text[..span.start.min(text.len())];
                let line = before.matches('\n').count() + 1;
                let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                (Location::Line(line), format!("column {column}: "))
            }
            None => (Location::Header, String::new()),
        };
        SceneError::parse(path, location, format!("{column}{}", e.message().trim()))
    })
}

/// Reads and parses a TOML file into `T` ([`parse_toml`]). A file that looks
/// like JSON (vpctl once took JSON parameter files) is refused with a message
/// saying so, rather than a TOML syntax error at its first brace.
pub fn load_toml<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let text = fsio::read_text(path)?;
    if text.trim_start().starts_with('{') {
        return Err(SceneError::parse(
            path,
            Location::Line(1),
            "this looks like JSON; parameter files are TOML now (`key = value` lines; \
             the `defaults` subcommand of the tool prints every key)",
        ));
    }
    parse_toml(&text, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct P {
        #[allow(dead_code)]
        a: f64,
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse_toml::<P>("a = 1.0\nb = 2\n", Path::new("p.toml")).unwrap_err();
        let m = e.to_string();
        assert!(
            m.starts_with("p.toml: line 2: column 1: unknown field `b`"),
            "{m}"
        );
        let e = parse_toml::<P>("a = \"x\"\n", Path::new("p.toml")).unwrap_err();
        assert!(e.to_string().contains("p.toml: line 1: column 5:"), "{e}");
    }

    #[test]
    fn json_parameter_files_are_named_as_such() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("params.json");
        std::fs::write(&path, "{\"a\": 1.0}").unwrap();
        let m = load_toml::<P>(&path).unwrap_err().to_string();
        assert!(
            m.contains("params.json: line 1: this looks like JSON"),
            "{m}"
        );
    }
}
