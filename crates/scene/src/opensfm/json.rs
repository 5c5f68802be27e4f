//! Parsing `reconstruction.json` and `reference_lla.json`: every value
//! checked, every error naming the reconstruction and the JSON path of the
//! value at fault (`shots."DJI_0001.JPG".rotation`), since OpenDroneMap
//! writes the file minified on one line, where a line number says nothing.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use serde_json::{Map, Value};

use super::camera::OpenSfmCamera;
use crate::colmap::{ColmapImage, Point3D, Reconstruction};
use crate::error::{Location, Result, SceneError};
use crate::plan::GeodeticOrigin;

/// One reconstruction of the file, converted.
#[derive(Debug, Clone)]
pub(crate) struct Parsed {
    /// Cameras, images (ids by sorted key and name) and points.
    pub rec: Reconstruction,
    /// The cameras as OpenSfM wrote them, by COLMAP id.
    pub cameras: BTreeMap<u32, OpenSfmCamera>,
    /// `reference_lla`, when the reconstruction carries it.
    pub reference: Option<GeodeticOrigin>,
    /// Each shot's `gps_position` (topocentric metres), where present.
    pub gps: Vec<(String, Point3<f64>)>,
    /// Index of the reconstruction read in the file's list.
    pub index: usize,
    /// Shot counts of the file's other (partial) reconstructions.
    pub others: Vec<usize>,
    /// Point ids by OpenSfM track id.
    pub point_ids: BTreeMap<String, u64>,
}

/// A value's place: the reconstruction's index and a JSON path.
struct At<'p> {
    path: &'p Path,
    index: usize,
}

impl At<'_> {
    fn err(&self, place: &str, message: impl std::fmt::Display) -> SceneError {
        SceneError::parse(
            self.path,
            Location::Element {
                kind: "reconstruction".into(),
                index: self.index,
                byte: None,
            },
            format!("{place}: {message}"),
        )
    }

    fn object<'v>(&self, v: &'v Value, place: &str) -> Result<&'v Map<String, Value>> {
        v.as_object()
            .ok_or_else(|| self.err(place, format!("expected an object, found {}", kind(v))))
    }

    fn number(&self, v: &Value, place: &str) -> Result<f64> {
        match v.as_f64() {
            Some(x) if x.is_finite() => Ok(x),
            _ => Err(self.err(
                place,
                format!("expected a finite number, found {}", kind(v)),
            )),
        }
    }

    fn vec3(&self, v: &Value, place: &str) -> Result<[f64; 3]> {
        let arr = v.as_array().filter(|a| a.len() == 3).ok_or_else(|| {
            self.err(
                place,
                format!("expected 3 numbers [x, y, z], found {}", kind(v)),
            )
        })?;
        let mut out = [0.0; 3];
        for (i, x) in arr.iter().enumerate() {
            out[i] = self.number(x, &format!("{place}[{i}]"))?;
        }
        Ok(out)
    }
}

/// A map's entries in key order.
fn sorted(m: &Map<String, Value>) -> impl Iterator<Item = (&String, &Value)> {
    let mut v: Vec<_> = m.iter().collect();
    v.sort_by(|a, b| a.0.cmp(b.0));
    v.into_iter()
}

fn kind(v: &Value) -> String {
    match v {
        Value::Null => "null".into(),
        Value::Bool(b) => format!("{b}"),
        Value::Number(n) => format!("the number {n}"),
        Value::String(s) => format!("the string {s:?}"),
        Value::Array(a) => format!("a list of {}", a.len()),
        Value::Object(_) => "an object".into(),
    }
}

/// Reads the JSON text of `path` (syntax errors with their line and column).
pub(crate) fn parse_json(text: &str, path: &Path) -> Result<Value> {
    serde_json::from_str(text).map_err(|e| {
        SceneError::parse(
            path,
            Location::Line(e.line()),
            format!("column {}: not valid JSON: {e}", e.column()),
        )
    })
}

/// `{"latitude": .., "longitude": .., "altitude": ..}` (OpenSfM's
/// `reference_lla`, in the reconstruction or in `reference_lla.json`).
pub(crate) fn reference_of(
    v: &Value,
    path: &Path,
    location: &Location,
    place: &str,
) -> Result<GeodeticOrigin> {
    let bad = |m: String| SceneError::parse(path, location.clone(), format!("{place}{m}"));
    let obj = v
        .as_object()
        .ok_or_else(|| bad(format!("expected an object, found {}", kind(v))))?;
    let mut lla = [0.0; 3];
    for (i, key) in ["latitude", "longitude", "altitude"].iter().enumerate() {
        let x = obj
            .get(*key)
            .ok_or_else(|| bad(format!("missing {key:?}")))?;
        lla[i] = x.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
            bad(format!(
                "{key}: expected a finite number, found {}",
                kind(x)
            ))
        })?;
    }
    GeodeticOrigin::new(lla[0], lla[1], lla[2]).map_err(|e| bad(e.to_string()))
}

/// Parses the file's list of reconstructions and converts the one with the
/// most shots (OpenSfM writes them largest first; OpenDroneMap uses that
/// one).
pub(crate) fn parse_reconstructions(root: &Value, path: &Path) -> Result<Parsed> {
    let list = root.as_array().ok_or_else(|| {
        SceneError::parse(
            path,
            Location::Header,
            format!(
                "expected a list of reconstructions ([{{\"cameras\": .., \"shots\": ..}}]), \
                 found {}",
                kind(root)
            ),
        )
    })?;
    let shots = |r: &Value| {
        r.get("shots")
            .and_then(Value::as_object)
            .map_or(0, Map::len)
    };
    let index = (0..list.len())
        .max_by_key(|&i| (shots(&list[i]), std::cmp::Reverse(i)))
        .filter(|&i| shots(&list[i]) > 0)
        .ok_or_else(|| {
            SceneError::parse(
                path,
                Location::Header,
                format!(
                    "no reconstruction with a registered image ({} reconstructions): OpenSfM \
                     could not tie the photos together; check their overlap and re-run the \
                     reconstruction (OpenDroneMap: more photos, or --feature-quality high)",
                    list.len()
                ),
            )
        })?;
    let others = (0..list.len())
        .filter(|&i| i != index)
        .map(|i| shots(&list[i]))
        .collect();
    let mut parsed = parse_one(&list[index], &At { path, index })?;
    parsed.others = others;
    Ok(parsed)
}

fn parse_one(v: &Value, at: &At) -> Result<Parsed> {
    let obj = at.object(v, "reconstruction")?;
    let get = |key: &str| {
        obj.get(key)
            .ok_or_else(|| at.err(key, "missing (OpenSfM writes it in every reconstruction)"))
    };
    let mut rec = Reconstruction::default();
    let mut cameras = BTreeMap::new();
    let mut camera_ids = BTreeMap::new();
    // Ids follow the keys' order, whatever order the file lists them in.
    for (i, (key, c)) in sorted(at.object(get("cameras")?, "cameras")?).enumerate() {
        let id = u32::try_from(i + 1).map_err(|_| at.err("cameras", "too many cameras"))?;
        let place = format!("cameras.{key:?}");
        let cam = camera_of(key, c, at, &place)?;
        let colmap = cam.to_colmap(id).map_err(|m| at.err(&place, m))?;
        rec.cameras.insert(id, colmap);
        camera_ids.insert(key.clone(), id);
        cameras.insert(id, cam);
    }
    let mut gps = Vec::new();
    for (i, (name, s)) in sorted(at.object(get("shots")?, "shots")?).enumerate() {
        let id = u32::try_from(i + 1).map_err(|_| at.err("shots", "too many shots"))?;
        let place = format!("shots.{name:?}");
        let shot = at.object(s, &place)?;
        let field = |k: &str| {
            shot.get(k)
                .ok_or_else(|| at.err(&place, format!("missing {k:?}")))
        };
        let key = field("camera")?
            .as_str()
            .ok_or_else(|| at.err(&format!("{place}.camera"), "expected the key of a camera"))?;
        let camera_id = *camera_ids.get(key).ok_or_else(|| {
            at.err(
                &format!("{place}.camera"),
                format!("refers to camera {key:?}, which `cameras` does not hold"),
            )
        })?;
        let r = at.vec3(field("rotation")?, &format!("{place}.rotation"))?;
        // OpenSfM's default translation is zero (io.pose_from_json).
        let t = match shot.get("translation") {
            Some(t) => at.vec3(t, &format!("{place}.translation"))?,
            None => [0.0; 3],
        };
        if let Some(g) = shot.get("gps_position") {
            let g = at.vec3(g, &format!("{place}.gps_position"))?;
            gps.push((name.clone(), Point3::from(g)));
        }
        rec.images.insert(
            id,
            ColmapImage {
                id,
                camera_id,
                name: name.clone(),
                cam_from_world: cam_from_world(r, t),
                points2d: Vec::new(),
            },
        );
    }
    let point_ids = match obj.get("points") {
        Some(points) => read_points(at.object(points, "points")?, at, &mut rec)?,
        None => BTreeMap::new(),
    };
    let reference = match obj.get("reference_lla") {
        Some(r) => Some(reference_of(
            r,
            at.path,
            &Location::Element {
                kind: "reconstruction".into(),
                index: at.index,
                byte: None,
            },
            "reference_lla: ",
        )?),
        None => None,
    };
    Ok(Parsed {
        rec,
        cameras,
        reference,
        gps,
        index: at.index,
        others: Vec::new(),
        point_ids,
    })
}

/// OpenSfM's pose: `rotation` is the axis-angle vector (Rodrigues) of the
/// world-to-camera rotation `R`, `translation` its `t`: `x_cam = R x_world
/// + t`, so the camera centre is `-R^T t` (`Pose.get_origin`). That is
/// COLMAP's `cam_from_world` as it is.
pub(crate) fn cam_from_world(rotation: [f64; 3], translation: [f64; 3]) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(Vector3::from(translation)),
        UnitQuaternion::from_scaled_axis(Vector3::from(rotation)),
    )
}

fn camera_of(key: &str, c: &Value, at: &At, place: &str) -> Result<OpenSfmCamera> {
    let obj = at.object(c, place)?;
    let projection = match obj.get("projection_type") {
        None => "perspective".to_string(),
        Some(Value::String(s)) => s.clone(),
        Some(v) => {
            return Err(at.err(
                &format!("{place}.projection_type"),
                format!("expected a string, found {}", kind(v)),
            ))
        }
    };
    let mut size = [0u64; 2];
    for (i, k) in ["width", "height"].iter().enumerate() {
        if let Some(v) = obj.get(*k) {
            let x = at.number(v, &format!("{place}.{k}"))?;
            if x < 0.0 || x.fract() != 0.0 || x > u32::MAX as f64 {
                return Err(at.err(&format!("{place}.{k}"), format!("{x} is not a pixel count")));
            }
            size[i] = x as u64;
        }
    }
    let mut params = Vec::new();
    for (name, v) in obj {
        let numeric = name.starts_with("focal")
            || name.starts_with("c_")
            || (name.len() == 2 && matches!(&name[..1], "k" | "p" | "s"))
            || name == "transition";
        if numeric {
            params.push((name.clone(), at.number(v, &format!("{place}.{name}"))?));
        }
    }
    Ok(OpenSfmCamera {
        key: key.to_string(),
        projection,
        width: size[0],
        height: size[1],
        params,
    })
}

/// Points keep OpenSfM's track id as their id when every id is a number
/// (OpenSfM's own are), else they are numbered in key order.
fn read_points(
    points: &Map<String, Value>,
    at: &At,
    rec: &mut Reconstruction,
) -> Result<BTreeMap<String, u64>> {
    let mut ids = BTreeMap::new();
    let numeric: Option<Vec<u64>> = sorted(points).map(|(k, _)| k.parse::<u64>().ok()).collect();
    for (i, (key, p)) in sorted(points).enumerate() {
        let place = format!("points.{key:?}");
        let obj = at.object(p, &place)?;
        let xyz = at.vec3(
            obj.get("coordinates")
                .ok_or_else(|| at.err(&place, "missing \"coordinates\""))?,
            &format!("{place}.coordinates"),
        )?;
        let rgb = match obj.get("color") {
            Some(c) => at
                .vec3(c, &format!("{place}.color"))?
                .map(|x| x.round().clamp(0.0, 255.0) as u8),
            None => [128; 3],
        };
        let id = numeric.as_ref().map_or(i as u64 + 1, |n| n[i]);
        ids.insert(key.clone(), id);
        rec.points.insert(
            id,
            Point3D {
                id,
                xyz: Point3::from(xyz),
                rgb,
                // reconstruction.json keeps no reprojection error.
                error: -1.0,
                track: Vec::new(),
            },
        );
    }
    Ok(ids)
}
