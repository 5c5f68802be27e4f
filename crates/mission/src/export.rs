//! Mission export formats and the one rule that picks them from an output
//! path, shared by `vpctl mission export` and Python `vpctl.mission.export`
//! so that both accept and refuse the same files.

use std::path::{Path, PathBuf};

use vp_scene::plan::Plan;

use crate::error::{MissionError, Result};
use crate::fly::Flight;
use crate::items::{build_mission, MissionOptions};
use crate::qgc::{export_qgc, QgcOptions};
use crate::wpl::export_wpl;
use crate::wpml::{Drone, WpmlHeights, WpmlOptions};

/// A text format a mission is exported in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExportFormat {
    /// QGroundControl `.plan` JSON (SimpleItems only).
    Qgc,
    /// `QGC WPL 110` waypoint text.
    Wpl,
    /// DJI WPML mission (`.kmz`) for DJI Pilot 2 and FlightHub 2.
    Wpml,
    /// Litchi waypoint CSV.
    Litchi,
    /// KML preview for Google Earth (not a mission).
    Kml,
}

impl ExportFormat {
    /// Every format.
    pub const ALL: [ExportFormat; 5] = [
        ExportFormat::Qgc,
        ExportFormat::Wpl,
        ExportFormat::Wpml,
        ExportFormat::Litchi,
        ExportFormat::Kml,
    ];

    /// The name on command lines and in Python.
    pub fn name(self) -> &'static str {
        match self {
            ExportFormat::Qgc => "qgc",
            ExportFormat::Wpl => "wpl",
            ExportFormat::Wpml => "wpml",
            ExportFormat::Litchi => "litchi",
            ExportFormat::Kml => "kml",
        }
    }

    /// The file extensions of the format (lower case, no dot).
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            ExportFormat::Qgc => &["plan"],
            ExportFormat::Wpl => &["waypoints", "txt"],
            ExportFormat::Wpml => &["kmz"],
            ExportFormat::Litchi => &["csv"],
            ExportFormat::Kml => &["kml"],
        }
    }

    /// True for the formats [`export_text`] writes (one text, printable).
    pub fn is_text(self) -> bool {
        matches!(self, ExportFormat::Qgc | ExportFormat::Wpl)
    }

    /// The format named `name` (any case).
    pub fn from_name(name: &str) -> Result<ExportFormat> {
        ExportFormat::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                let names: Vec<&str> = ExportFormat::ALL.iter().map(|f| f.name()).collect();
                MissionError::InvalidInput(format!(
                    "format {name:?}: expected one of {}",
                    names.join(", ")
                ))
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

/// The plan's mission as export text in `format` (QGroundControl or WPL;
/// the other formats are files: [`export_files`]).
pub fn export_text(plan: &Plan, format: ExportFormat, opts: &MissionOptions) -> Result<String> {
    match format {
        ExportFormat::Qgc => export_qgc(plan, opts, &QgcOptions::default()),
        ExportFormat::Wpl => export_wpl(&build_mission(plan, opts)?),
        other => Err(MissionError::InvalidInput(format!(
            "the {} format is written to a file, not printed: give one with --out (e.g. \
             --out mission.{})",
            other.name(),
            other.extensions()[0]
        ))),
    }
}

/// What the DJI and Litchi formats need beyond [`MissionOptions`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DjiOptions {
    /// The aircraft of a WPML mission (required for `.kmz`).
    pub drone: Option<Drone>,
    /// WPML height reference.
    pub heights: WpmlHeights,
    /// Split a Litchi mission over 99 waypoints into several files.
    pub split: bool,
    /// WPML `createTime`, milliseconds since 1970.
    pub time_ms: u64,
}

impl Default for DjiOptions {
    fn default() -> Self {
        DjiOptions {
            drone: None,
            heights: WpmlHeights::RelativeToStartPoint,
            split: false,
            time_ms: 0,
        }
    }
}

/// The files of the plan's mission in `format` for the output path `out`:
/// (path, bytes) pairs, all computed before anything is written so that a
/// refused mission writes nothing. Litchi missions split with
/// [`DjiOptions::split`] go to `NAME-1.csv`, `NAME-2.csv`, ... beside `out`.
pub fn export_files(
    plan: &Plan,
    format: ExportFormat,
    opts: &MissionOptions,
    dji: &DjiOptions,
    out: &Path,
) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    let one = |bytes: Vec<u8>| Ok(vec![(out.to_path_buf(), bytes)]);
    match format {
        ExportFormat::Qgc | ExportFormat::Wpl => one(export_text(plan, format, opts)?.into_bytes()),
        ExportFormat::Wpml => {
            let drone = dji.drone.ok_or_else(|| {
                let names: Vec<&str> = Drone::ALL.iter().map(|d| d.name()).collect();
                MissionError::InvalidInput(format!(
                    "a DJI WPML mission is written for one aircraft: give --drone ({})",
                    names.join(", ")
                ))
            })?;
            let flight = Flight::of_plan(plan, opts)?;
            let wpml = WpmlOptions {
                drone,
                heights: dji.heights,
                time_ms: dji.time_ms,
            };
            one(crate::wpml::kmz_bytes(&flight, &wpml)?)
        }
        ExportFormat::Litchi => {
            let flight = Flight::of_plan(plan, opts)?;
            let csvs = crate::litchi::litchi_csvs(&flight, dji.split)?;
            if csvs.len() == 1 {
                return one(csvs.into_iter().next().unwrap_or_default().into_bytes());
            }
            let stem = out
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            Ok(csvs
                .into_iter()
                .enumerate()
                .map(|(i, csv)| {
                    (
                        out.with_file_name(format!("{stem}-{}.csv", i + 1)),
                        csv.into_bytes(),
                    )
                })
                .collect())
        }
        ExportFormat::Kml => {
            let flight = Flight::of_plan(plan, opts)?;
            let title = out
                .file_stem()
                .map_or_else(|| "vpctl plan".into(), |s| s.to_string_lossy().into_owned());
            one(crate::preview::preview_kml(&flight, &title)?.into_bytes())
        }
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
        assert_eq!(f(Some("m.KMZ"), None).unwrap(), ExportFormat::Wpml);
        assert_eq!(f(Some("m.csv"), None).unwrap(), ExportFormat::Litchi);
        assert!(ExportFormat::from_name("shp")
            .unwrap_err()
            .to_string()
            .contains("format"));
    }
}
