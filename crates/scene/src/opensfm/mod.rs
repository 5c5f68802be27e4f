//! OpenSfM reconstructions, as OpenDroneMap (WebODM, NodeODM) leaves them
//! in a project folder: `opensfm/reconstruction.json` and
//! `opensfm/reference_lla.json`.
//!
//! - [`read_opensfm`] reads `reconstruction.json` (found by
//!   [`find_reconstruction`] in a project, an `opensfm` folder or given as
//!   the file) into the same [`Reconstruction`] a COLMAP model becomes:
//!   cameras with the COLMAP model of the same projection
//!   ([`OpenSfmCamera::to_colmap`], distortion kept, never a silent
//!   pinhole), shots as images with OpenSfM's world-to-camera pose, points
//!   with their tracks from `tracks.csv` beside it, where it is.
//! - The geodetic reference (`reference_lla` in the reconstruction, else
//!   `reference_lla.json` beside it or one folder up) becomes the
//!   [`ModelFrame`] `vpctl colmap align` would have written: OpenSfM's
//!   world *is* the local ENU tangent frame at that reference (its
//!   `TopocentricConverter`, vpctl's [`LocalFrame`](crate::geodesy::LocalFrame)),
//!   so the transform is the identity and no alignment is needed.
//! - [`ModelSource`] is the one door `vpctl plan` and Python's `plan`
//!   (through vp-planner's `plan_from_model`) go through for a model of
//!   either kind. `labelgen` takes the undistorted COLMAP workspace (its
//!   depth maps come from `mvs run` on it), so it stays COLMAP-only.
//!
//! OpenSfM invents its reference at altitude 0 and takes the photos' GPS
//! altitudes as they are (`invent_reference_from_gps_and_gcp`), so world
//! heights are in the datum of the photos' altitude tags: above mean sea
//! level (EGM96) on DJI and most drones, the datum `colmap align --exif`
//! assumes too; the frame records it so.

mod camera;
mod json;
mod source;
mod tracks;
mod undistort;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use camera::{OpenSfmCamera, SUPPORTED};
pub use source::{ModelSource, PosedModel};
pub use tracks::TRACKS_FILE;
pub use undistort::undistort_opensfm_workspace;

use crate::colmap::{
    check_frame_of, ColmapImage, FrameCheck, ModelFrame, PositionResidual, Reconstruction,
};
use crate::datum::VerticalDatum;
use crate::error::{Location, Result, SceneError};
use crate::plan::GeodeticOrigin;

/// The file OpenSfM writes its reconstructions to.
pub const RECONSTRUCTION_FILE: &str = "reconstruction.json";
/// The file OpenSfM (and OpenDroneMap) write the geodetic reference to.
pub const REFERENCE_FILE: &str = "reference_lla.json";

/// A reconstruction read from `reconstruction.json`.
#[derive(Debug, Clone)]
pub struct OpenSfmModel {
    /// The file read.
    pub file: PathBuf,
    /// Cameras (COLMAP models of the same projection), images, points.
    pub reconstruction: Reconstruction,
    /// The cameras as OpenSfM wrote them, by the ids of `reconstruction`.
    pub cameras: BTreeMap<u32, OpenSfmCamera>,
    /// The frame of the geodetic reference, when there is one.
    pub frame: Option<ModelFrame>,
    /// Where the reference was read (`file` itself, or `reference_lla.json`).
    pub reference_file: Option<PathBuf>,
    /// Index of the reconstruction read in the file's list.
    pub index: usize,
    /// Shot counts of the file's other (partial) reconstructions, not read.
    pub others: Vec<usize>,
    /// Observations read from `tracks.csv` (0 without the file).
    pub observations: usize,
}

/// `reconstruction.json` for `path`: the file itself, `path/reconstruction.json`
/// (an OpenSfM dataset or its `undistorted` folder) or
/// `path/opensfm/reconstruction.json` (an OpenDroneMap project).
pub fn find_reconstruction(path: &Path) -> Result<PathBuf> {
    if path.is_file() {
        return Ok(path.to_path_buf());
    }
    if !path.exists() {
        return Err(SceneError::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or directory"),
        ));
    }
    for candidate in [
        path.join(RECONSTRUCTION_FILE),
        path.join("opensfm").join(RECONSTRUCTION_FILE),
    ] {
        if candidate.is_file() {
            return Ok(candidate);
        }
    }
    Err(SceneError::parse(
        path,
        Location::Header,
        format!(
            "no OpenSfM reconstruction: neither {RECONSTRUCTION_FILE} nor \
             opensfm/{RECONSTRUCTION_FILE} is here; pass an OpenDroneMap project folder, its \
             opensfm folder, or the reconstruction.json file (a COLMAP model goes to --colmap)"
        ),
    ))
}

/// Reads the reconstruction with the most shots of `path`
/// ([`find_reconstruction`]) and its geodetic reference (module doc).
/// Errors name the file, the reconstruction and the JSON path at fault.
pub fn read_opensfm(path: &Path) -> Result<OpenSfmModel> {
    let file = find_reconstruction(path)?;
    let text = crate::fsio::read_text(&file)?;
    let root = json::parse_json(&text, &file)?;
    let mut parsed = json::parse_reconstructions(&root, &file)?;
    let tracks = file.with_file_name(TRACKS_FILE);
    let observations = if tracks.is_file() {
        tracks::add_tracks(&tracks, &mut parsed.rec, &parsed.point_ids)?
    } else {
        0
    };
    let (reference, reference_file) = match parsed.reference {
        Some(r) => (Some(r), Some(file.clone())),
        None => match reference_beside(&file)? {
            Some((r, f)) => (Some(r), Some(f)),
            None => (None, None),
        },
    };
    let frame = reference.map(|origin| frame_of(origin, &parsed));
    Ok(OpenSfmModel {
        file,
        reconstruction: parsed.rec,
        cameras: parsed.cameras,
        frame,
        reference_file,
        index: parsed.index,
        others: parsed.others,
        observations,
    })
}

/// `reference_lla.json` beside `file`, else one folder up (OpenSfM's
/// `undistorted` dataset lies inside the one that holds the reference).
fn reference_beside(file: &Path) -> Result<Option<(GeodeticOrigin, PathBuf)>> {
    let Some(dir) = file.parent() else {
        return Ok(None);
    };
    for d in [Some(dir), dir.parent()].into_iter().flatten() {
        let f = d.join(REFERENCE_FILE);
        if f.is_file() {
            let text = crate::fsio::read_text(&f)?;
            let v = json::parse_json(&text, &f)?;
            return Ok(Some((
                json::reference_of(&v, &f, &Location::Header, "")?,
                f,
            )));
        }
    }
    Ok(None)
}

/// The identity frame at the reference, with each shot's distance to its
/// own GPS position (OpenSfM keeps it, in the same topocentric frame) as
/// the residuals `colmap align` would report.
fn frame_of(origin: GeodeticOrigin, parsed: &json::Parsed) -> ModelFrame {
    let mut frame = ModelFrame::identity(origin);
    frame.vertical_datum = Some(VerticalDatum::Egm96);
    let centre = |name: &str| {
        parsed
            .rec
            .images
            .values()
            .find(|im| im.name == name)
            .map(ColmapImage::center)
    };
    frame.residuals = parsed
        .gps
        .iter()
        .filter_map(|(name, g)| {
            centre(name).map(|c| PositionResidual {
                name: name.clone(),
                residual_m: (c - g).norm(),
                inlier: true,
            })
        })
        .collect();
    let n = frame.residuals.len().max(1) as f64;
    frame.rms_m = (frame
        .residuals
        .iter()
        .map(|r| r.residual_m.powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    frame
}

impl OpenSfmModel {
    /// The checks `vpctl plan` makes of an aligned COLMAP model (metric
    /// spacing, cameras above the ground, not looking up) on the frame of
    /// the reference; refused when the reconstruction has no reference.
    pub fn check_frame(&self) -> Result<FrameCheck> {
        let fix = "OpenSfM georeferences a reconstruction from the photos' GPS tags or ground \
                   control points: re-run it with them (OpenDroneMap does so by default), or \
                   pass --frame-unchecked if the reconstruction is already in metric, \
                   gravity-aligned local ENU";
        let Some(frame) = &self.frame else {
            return Err(SceneError::parse(
                &self.file,
                Location::Header,
                format!(
                    "no geodetic reference: no \"reference_lla\" in the reconstruction and no \
                     {REFERENCE_FILE} beside it or one folder up; {fix}"
                ),
            ));
        };
        let source = self.reference_file.as_deref().unwrap_or(&self.file);
        check_frame_of(frame.clone(), source, &self.reconstruction, fix)
    }

    /// Refuses a camera with lens distortion, as `camera_of` does for a
    /// COLMAP model, with the OpenSfM names and the two ways out.
    pub fn check_undistorted(&self) -> Result<()> {
        let Some((id, cam)) = self
            .reconstruction
            .cameras
            .iter()
            .find(|(_, c)| c.is_distorted())
        else {
            return Ok(());
        };
        let key = self.cameras.get(id).map_or("?", |c| c.key.as_str());
        let projection = self.cameras.get(id).map_or("?", |c| c.projection.as_str());
        Err(SceneError::parse(
            &self.file,
            Location::Element {
                kind: "reconstruction".into(),
                index: self.index,
                byte: None,
            },
            format!(
                "cameras.{key:?}: a {projection} camera with lens distortion ({} {:?}): vpctl \
                 plans, labels and predicts with pinhole cameras and does not approximate a \
                 distorted one silently; undistort first: vpctl colmap undistort --opensfm \
                 {} --images IMAGES --out WORKSPACE (then --colmap WORKSPACE/sparse), or pass \
                 OpenSfM's own undistorted dataset (opensfm/undistorted of an OpenDroneMap \
                 project)",
                cam.model,
                cam.params,
                self.file.display()
            ),
        ))
    }
}
