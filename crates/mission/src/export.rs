//! Mission export formats and the one rule that picks them from an output
//! path, shared by `vpctl mission export` and Python `vpctl.mission.export`
//! so that both accept and refuse the same files.

use std::path::Path;

use vp_scene::plan::Plan;

use crate::error::{MissionError, Result};
use crate::items::{build_mission, MissionOptions};
use crate::qgc::{export_qgc, QgcOptions};
use crate::wpl::export_wpl;

/// A text format a mission is exported in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// QGroundControl `.plan` JSON (SimpleItems only).
    Qgc,
    /// `QGC WPL 110` waypoint text.
    Wpl,
}

impl ExportFormat {
    /// Every format.
    pub const ALL: [ExportFormat; 2] = [ExportFormat::Qgc, ExportFormat::Wpl];

    /// The name on command lines and in Python: `qgc` or `wpl`.
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::Qgc => "qgc",
            ExportFormat::Wpl => "wpl",
        }
    }

    /// The file extensions of the format (lower case, no dot).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            ExportFormat::Qgc => &["plan"],
            ExportFormat::Wpl => &["waypoints", "txt"],
        }
    }

    /// The format named `name` (`qgc` or `wpl`, any case).
    pub fn from_name(name: &str) -> Result<ExportFormat> {
        ExportFormat::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                MissionError::InvalidInput(format!("format {name:?}: expected \"qgc\" or \"wpl\""))
            })
    }

    /// The format to write: `format` if given, else from the extension of
    /// `out` (`.plan`: QGroundControl, `.waypoints` or `.txt`: WPL), else
    /// (no file: standard output or a string) QGroundControl. An extension
    /// that is not the format's, or no known extension, is refused naming
    /// the file.
    pub fn for_output(out: Option<&Path>, format: Option<ExportFormat>) -> Result<ExportFormat> {
        let Some(path) = out else {
            return Ok(format.unwrap_or(ExportFormat::Qgc));
        };
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        let by_ext = ExportFormat::ALL
            .into_iter()
            .find(|f| f.extensions().contains(&ext.as_str()));
        match (format, by_ext) {
            (Some(f), Some(e)) if f == e => Ok(f),
            (None, Some(e)) => Ok(e),
            _ => {
                let candidates = match format {
                    Some(f) => vec![f],
                    None => ExportFormat::ALL.to_vec(),
                };
                let allowed: Vec<String> = candidates
                    .iter()
                    .flat_map(|f| f.extensions())
                    .map(|e| format!(".{e}"))
                    .collect();
                let found = if ext.is_empty() {
                    "no extension".to_string()
                } else {
                    format!("the extension '.{ext}'")
                };
                Err(MissionError::InvalidInput(format!(
                    "{}: {found} is not a file type this output writes (expected {})",
                    path.display(),
                    allowed.join(" or ")
                )))
            }
        }
    }
}

/// The plan's mission as export text in `format`.
pub fn export_text(plan: &Plan, format: ExportFormat, opts: &MissionOptions) -> Result<String> {
    match format {
        ExportFormat::Qgc => export_qgc(plan, opts, &QgcOptions::default()),
        ExportFormat::Wpl => export_wpl(&build_mission(plan, opts)?),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_extension_picks_the_format_and_a_contradiction_is_refused() {
        let f = |p: Option<&str>, fmt| ExportFormat::for_output(p.map(Path::new), fmt);
        assert_eq!(f(None, None).unwrap(), ExportFormat::Qgc);
        assert_eq!(f(Some("m.PLAN"), None).unwrap(), ExportFormat::Qgc);
        assert_eq!(f(Some("m.txt"), None).unwrap(), ExportFormat::Wpl);
        assert_eq!(
            f(Some("m.waypoints"), Some(ExportFormat::Wpl)).unwrap(),
            ExportFormat::Wpl
        );
        let e = f(Some("m.plan"), Some(ExportFormat::Wpl))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.plan") && e.contains(".waypoints or .txt"),
            "{e}"
        );
        let e = f(Some("m.json"), None).unwrap_err().to_string();
        assert!(e.contains("'.json'") && e.contains(".plan or"), "{e}");
        assert!(f(Some("m"), None)
            .unwrap_err()
            .to_string()
            .contains("no extension"));
        assert_eq!(ExportFormat::from_name("WPL").unwrap(), ExportFormat::Wpl);
        assert!(ExportFormat::from_name("kml")
            .unwrap_err()
            .to_string()
            .contains("format"));
    }
}
