//! Reading DJI WPML missions (`.kmz`): DJI's own exports and ours, so that
//! tests compare what vpctl writes with what DJI Pilot 2 writes, and an
//! operator can check a mission file before flying it.

use std::io::Read;
use std::path::Path;

use crate::error::{MissionError, Result};
use crate::xml::{parse, Element};

/// One waypoint of an executable wayline.
#[derive(Debug, Clone, PartialEq)]
pub struct WaylinePoint {
    /// `wpml:index`.
    pub index: u32,
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// `wpml:executeHeight`, metres in the wayline's height mode.
    pub execute_height_m: f64,
    /// `wpml:waypointHeadingAngle`, degrees, when given.
    pub heading_deg: Option<f64>,
    /// The actuator functions of the point's action groups, in order.
    pub actions: Vec<String>,
    /// The pitch of the last `gimbalRotate` action, degrees.
    pub gimbal_pitch_deg: Option<f64>,
}

/// One executable route (`Folder` of `waylines.wpml`).
#[derive(Debug, Clone, PartialEq)]
pub struct Wayline {
    /// `wpml:waylineId`.
    pub id: u32,
    /// `wpml:executeHeightMode` (`WGS84`, `relativeToStartPoint`, ...).
    pub height_mode: String,
    /// `wpml:distance`, metres.
    pub distance_m: f64,
    /// `wpml:duration`, seconds.
    pub duration_s: f64,
    /// Waypoints in index order.
    pub points: Vec<WaylinePoint>,
}

/// A `.kmz` mission as read.
#[derive(Debug, Clone, PartialEq)]
pub struct Kmz {
    /// The `wpml` namespace URI of the template (its WPML version).
    pub wpml_namespace: String,
    /// `wpmz/template.kml`, parsed.
    pub template: Element,
    /// `wpmz/waylines.wpml`, parsed.
    pub waylines_doc: Element,
    /// `droneEnumValue`, `droneSubEnumValue`, `payloadEnumValue`.
    pub enums: (u32, u32, u32),
    /// `wpml:templateType` (`waypoint`, `mapping2d`, `mapping3d`, ...).
    pub template_type: String,
    /// The executable routes.
    pub waylines: Vec<Wayline>,
}

/// Reads a `.kmz` file.
pub fn read_kmz_file(path: &Path) -> Result<Kmz> {
    let bytes = vp_scene::fsio::read_file(path)?;
    read_kmz(&bytes, path)
}

/// Reads `.kmz` bytes; `path` names the file in errors.
pub fn read_kmz(bytes: &[u8], path: &Path) -> Result<Kmz> {
    let bad = |message: String| MissionError::BadFile {
        path: path.to_path_buf(),
        message,
    };
    let mut zip = zip::ZipArchive::new(std::io::Cursor::new(bytes))
        .map_err(|e| bad(format!("not a ZIP archive (a .kmz is one): {e}")))?;
    let mut entry = |name: &str| -> Result<Element> {
        let mut text = String::new();
        zip.by_name(name)
            .map_err(|e| {
                bad(format!(
                    "no {name} in the archive ({e}); DJI Pilot 2 needs it"
                ))
            })?
            .read_to_string(&mut text)
            .map_err(|e| bad(format!("{name}: cannot read as UTF-8 text: {e}")))?;
        parse(&text).map_err(|e| bad(format!("{name}: {e}")))
    };
    let template = entry("wpmz/template.kml")?;
    let waylines_doc = entry("wpmz/waylines.wpml")?;
    let wpml_namespace = template
        .attribute("xmlns:wpml")
        .ok_or_else(|| bad("wpmz/template.kml: the root has no xmlns:wpml namespace".into()))?
        .to_string();
    let doc = |root: &Element, file: &str| -> Result<Element> {
        root.child("Document")
            .cloned()
            .ok_or_else(|| bad(format!("{file}: no <Document> under <kml>")))
    };
    let tdoc = doc(&template, "wpmz/template.kml")?;
    let wdoc = doc(&waylines_doc, "wpmz/waylines.wpml")?;
    let int = |e: &Element, p: &str, file: &str| -> Result<u32> {
        e.text_at(p)
            .and_then(|t| t.trim().parse().ok())
            .ok_or_else(|| bad(format!("{file}: {p} missing or not an integer")))
    };
    let cfg = "wpml:missionConfig";
    let w = "wpmz/waylines.wpml";
    let enums = (
        int(
            &wdoc,
            &format!("{cfg}/wpml:droneInfo/wpml:droneEnumValue"),
            w,
        )?,
        int(
            &wdoc,
            &format!("{cfg}/wpml:droneInfo/wpml:droneSubEnumValue"),
            w,
        )
        .unwrap_or(0),
        int(
            &wdoc,
            &format!("{cfg}/wpml:payloadInfo/wpml:payloadEnumValue"),
            w,
        )?,
    );
    let template_type = tdoc
        .text_at("Folder/wpml:templateType")
        .ok_or_else(|| bad("wpmz/template.kml: no Folder/wpml:templateType".into()))?
        .to_string();
    let waylines = wdoc
        .children_named("Folder")
        .enumerate()
        .map(|(k, f)| read_wayline(f, k, &bad))
        .collect::<Result<Vec<_>>>()?;
    if waylines.is_empty() {
        return Err(bad(format!("{w}: no <Folder> (wayline)")));
    }
    Ok(Kmz {
        wpml_namespace,
        template,
        waylines_doc,
        enums,
        template_type,
        waylines,
    })
}

fn read_wayline(
    folder: &Element,
    k: usize,
    bad: &dyn Fn(String) -> MissionError,
) -> Result<Wayline> {
    let at = |what: &str| format!("wpmz/waylines.wpml, wayline {k}: {what}");
    let float = |e: &Element, p: &str, what: &str| -> Result<f64> {
        e.text_at(p)
            .and_then(|t| t.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(at(&format!("{what}{p} missing or not a number"))))
    };
    let mut points = Vec::new();
    for (n, pm) in folder.children_named("Placemark").enumerate() {
        let here = format!("placemark {n}: ");
        let coords = pm
            .text_at("Point/coordinates")
            .ok_or_else(|| bad(at(&format!("{here}no Point/coordinates"))))?;
        let mut parts = coords.split(',').map(|s| s.trim().parse::<f64>());
        let (Some(Ok(lon)), Some(Ok(lat))) = (parts.next(), parts.next()) else {
            return Err(bad(at(&format!(
                "{here}coordinates {coords:?} are not longitude,latitude"
            ))));
        };
        let index = pm
            .text_at("wpml:index")
            .and_then(|t| t.trim().parse().ok())
            .ok_or_else(|| bad(at(&format!("{here}wpml:index missing"))))?;
        let mut actions = Vec::new();
        let mut gimbal_pitch_deg = None;
        for group in pm.children_named("wpml:actionGroup") {
            for action in group.children_named("wpml:action") {
                let func = action.text_at("wpml:actionActuatorFunc").unwrap_or("");
                if func == "gimbalRotate" {
                    gimbal_pitch_deg = action
                        .text_at("wpml:actionActuatorFuncParam/wpml:gimbalPitchRotateAngle")
                        .and_then(|t| t.parse().ok());
                }
                actions.push(func.to_string());
            }
        }
        points.push(WaylinePoint {
            index,
            lat_deg: lat,
            lon_deg: lon,
            execute_height_m: float(pm, "wpml:executeHeight", &here)?,
            heading_deg: pm
                .text_at("wpml:waypointHeadingParam/wpml:waypointHeadingAngle")
                .and_then(|t| t.parse().ok()),
            actions,
            gimbal_pitch_deg,
        });
    }
    Ok(Wayline {
        id: folder
            .text_at("wpml:waylineId")
            .and_then(|t| t.parse().ok())
            .ok_or_else(|| bad(at("wpml:waylineId missing")))?,
        height_mode: folder
            .text_at("wpml:executeHeightMode")
            .ok_or_else(|| bad(at("wpml:executeHeightMode missing")))?
            .to_string(),
        distance_m: float(folder, "wpml:distance", "")?,
        duration_s: float(folder, "wpml:duration", "")?,
        points,
    })
}
