//! `frame.json`: how a COLMAP model is tied to the world ([`ModelFrame`],
//! written by `vpctl colmap align`), the check that a model is in metric,
//! gravity-aligned local ENU before planning on it ([`check_frame`]), and
//! image positions from a CSV ([`read_positions_csv`]).

use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

use super::align::{PositionResidual, StripFit};
use super::reconstruction::Reconstruction;
use super::ColmapImage;
use crate::datum::{Home, VerticalDatum};
use crate::error::{Location, Result, SceneError};
use crate::plan::GeodeticOrigin;
use crate::sim3::Sim3;

/// Name of the frame file written beside an aligned model's files.
pub const FRAME_FILE: &str = "frame.json";
/// `frame.json`: how a model was tied to the world.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelFrame {
    /// WGS84 position of the local ENU origin of the model's frame.
    pub origin: GeodeticOrigin,
    /// The transform applied to the original model (original -> ENU metres).
    pub sim3: Sim3,
    /// Root mean square residual of the inliers (m).
    pub rms_m: f64,
    /// Per-image residuals.
    pub residuals: Vec<PositionResidual>,
    /// Present when the cameras lay on a line and the rotation about it was
    /// taken from their viewing directions (`colmap align
    /// --gravity-from-views`): an assumption, not a measurement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strip: Option<StripFit>,
    /// The datum of the positions' altitudes, so of `origin.alt_m`: EXIF
    /// GPS altitude is above mean sea level on most drones (`egm96`); a CSV
    /// says nothing unless `colmap align --datum` does. Absent in frames
    /// from before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertical_datum: Option<VerticalDatum>,
    /// Altitude of the take-off point in `vertical_datum`, where the photos
    /// carry their height above it too (DJI's XMP `RelativeAltitude`): the
    /// median over the photos of absolute minus relative altitude.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub takeoff_alt_m: Option<f64>,
    /// The take-off point, where it is known (the simulator's flights):
    /// `vpctl plan` uses it when no home is given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub home: Option<Home>,
    /// The GNSS class of the positions the model was aligned to, where it
    /// is known (`vpctl sim fly` records its simulated vehicle's): the
    /// planner's position margin uses it unless its config names a class.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gnss: Option<crate::gnss::GnssClass>,
}

impl ModelFrame {
    /// The frame of a model built in the local ENU frame of `origin` (the
    /// simulator's): identity transform, no residuals.
    pub fn identity(origin: GeodeticOrigin) -> ModelFrame {
        ModelFrame {
            origin,
            sim3: Sim3 {
                scale: 1.0,
                rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
                translation: [0.0; 3],
            },
            rms_m: 0.0,
            residuals: Vec::new(),
            strip: None,
            vertical_datum: None,
            takeoff_alt_m: None,
            home: None,
            gnss: None,
        }
    }

    /// Reads `dir/frame.json`.
    pub fn load(dir: &Path) -> Result<ModelFrame> {
        let path = dir.join(FRAME_FILE);
        let text = crate::fsio::read_text(&path)?;
        serde_json::from_str(&text)
            .map_err(|e| SceneError::parse(&path, Location::Line(e.line()), e.to_string()))
    }

    /// Writes `dir/frame.json` atomically.
    pub fn save(&self, dir: &Path) -> Result<()> {
        let json = serde_json::to_string_pretty(self)
            .map_err(|e| SceneError::InvalidArgument(e.to_string()))?;
        crate::fsio::write_file_atomic(&dir.join(FRAME_FILE), format!("{json}\n").as_bytes())
    }
}

/// What [`check_frame`] found.
#[derive(Debug, Clone)]
pub struct FrameCheck {
    /// The frame file read.
    pub frame: ModelFrame,
    /// Median distance between an image and its nearest neighbour (m).
    pub median_spacing_m: f64,
}

/// Checks that the model in `dir` is in a metric, gravity-aligned local
/// ENU frame, as planning assumes: `frame.json` present (written by `vpctl
/// colmap align`), neighbouring cameras 1 cm to 1 km apart, the cameras
/// above the median of the sparse points, and no camera looking steeply up.
/// The error says which check failed and how to fix it.
pub fn check_frame(dir: &Path, rec: &Reconstruction) -> Result<FrameCheck> {
    let frame_path: PathBuf = dir.join(FRAME_FILE);
    let fix = "align it with `vpctl colmap align --colmap DIR --positions positions.csv --out \
               ALIGNED` (or `--exif PHOTOS` for the photos' GPS tags; or pass \
               --frame-unchecked if the model is already in metric, gravity-aligned local ENU)";
    if !frame_path.is_file() {
        return Err(SceneError::parse(
            &frame_path,
            Location::Header,
            format!(
                "missing: the model in {} has no geodetic frame; a COLMAP model from SfM has \
                 arbitrary scale and orientation, so safety distances, gimbal limits and the \
                 free-space \"down\" would mean nothing; {fix}",
                dir.display()
            ),
        ));
    }
    let frame = ModelFrame::load(dir)?;
    check_frame_of(frame, &frame_path, rec, fix)
}

/// The checks of [`check_frame`] on a frame from elsewhere (an OpenSfM
/// reconstruction's geodetic reference): errors name `source` and end with
/// `fix`, the next step.
pub fn check_frame_of(
    frame: ModelFrame,
    source: &Path,
    rec: &Reconstruction,
    fix: &str,
) -> Result<FrameCheck> {
    frame.origin.validate()?;
    let bad = |m: String| SceneError::parse(source, Location::Header, format!("{m}; {fix}"));
    let centers: Vec<Point3<f64>> = rec.images.values().map(ColmapImage::center).collect();
    let mut spacing: Vec<f64> = centers
        .iter()
        .enumerate()
        .map(|(i, c)| {
            centers
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, d)| (c - d).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .filter(|d| d.is_finite())
        .collect();
    spacing.sort_by(f64::total_cmp);
    let median_spacing_m = spacing.get(spacing.len() / 2).copied().unwrap_or(0.0);
    if !spacing.is_empty() && !(0.01..=1000.0).contains(&median_spacing_m) {
        return Err(bad(format!(
            "implausible scale: neighbouring cameras are {median_spacing_m:.4} m apart (median); \
             a metric model of a UAV flight has 1 cm to 1 km"
        )));
    }
    let mut zs: Vec<f64> = rec.points.values().map(|p| p.xyz.z).collect();
    if !zs.is_empty() && !centers.is_empty() {
        zs.sort_by(f64::total_cmp);
        let ground = zs[zs.len() / 2];
        let below = centers.iter().filter(|c| c.z < ground).count();
        if 2 * below > centers.len() {
            return Err(bad(format!(
                "gravity implausible: {below} of {} cameras are below the median height of the \
                 sparse points (z up expected)",
                centers.len()
            )));
        }
    }
    let up = rec
        .images
        .values()
        .filter(|im| {
            let axis = im.cam_from_world.rotation.inverse() * Vector3::z();
            axis.z > 0.5
        })
        .count();
    if 2 * up > rec.images.len() {
        return Err(bad(format!(
            "gravity implausible: {up} of {} cameras look more than 30 deg above the horizon",
            rec.images.len()
        )));
    }
    Ok(FrameCheck {
        frame,
        median_spacing_m,
    })
}

/// Reads image positions from a CSV file: `name,lat,lon,alt` per line
/// (degrees WGS84, metres), `#` comments and an optional header line
/// allowed. Errors name the file and the line.
pub fn read_positions_csv(path: &Path) -> Result<Vec<(String, GeodeticOrigin)>> {
    let text = crate::fsio::read_text(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let bad = |m: String| SceneError::parse(path, Location::Line(i + 1), m);
        if fields.len() != 4 {
            return Err(bad(format!(
                "expected 4 fields name,lat,lon,alt, found {}",
                fields.len()
            )));
        }
        let nums: std::result::Result<Vec<f64>, _> =
            fields[1..].iter().map(|f| f.parse::<f64>()).collect();
        let Ok(nums) = nums else {
            if out.is_empty() && fields[1].parse::<f64>().is_err() && i == 0 {
                continue; // header line
            }
            return Err(bad(format!("not a number in {line:?}")));
        };
        let g = GeodeticOrigin::new(nums[0], nums[1], nums[2]).map_err(|e| bad(e.to_string()))?;
        out.push((fields[0].to_string(), g));
    }
    if out.is_empty() {
        return Err(SceneError::parse(path, Location::Header, "no positions"));
    }
    Ok(out)
}
