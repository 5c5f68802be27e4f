//! [`ModelSource`]: a sparse model of either kind, COLMAP or OpenSfM, so
//! that every job that takes a model folder (`vpctl plan --colmap DIR` or
//! `--opensfm DIR`, Python's `plan(mesh, DIR)`) reads and checks it in one
//! place and plans the same way from either.

use std::path::{Path, PathBuf};

use crate::colmap::{self, FrameCheck, Reconstruction};
use crate::error::Result;

/// Where a sparse model comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ModelSource {
    /// A COLMAP sparse model folder (`cameras`, `images`, `points3D`), with
    /// `frame.json` from `vpctl colmap align`.
    Colmap(PathBuf),
    /// An OpenSfM reconstruction: an OpenDroneMap project, its `opensfm`
    /// folder, or `reconstruction.json` (see [`super::find_reconstruction`]).
    OpenSfm(PathBuf),
}

/// A model read and checked for posing views: what the planner takes.
#[derive(Debug, Clone)]
pub struct PosedModel {
    /// Cameras, images and points.
    pub reconstruction: Reconstruction,
    /// The frame check, unless skipped.
    pub frame: Option<FrameCheck>,
    /// The file the frame came from: `frame.json`, `reconstruction.json`
    /// or `reference_lla.json`.
    pub frame_file: PathBuf,
    /// What the reader wants the user to know (partial reconstructions
    /// left out).
    pub notes: Vec<String>,
}

impl ModelSource {
    /// The kind of model in `dir`: a complete COLMAP model wins, then an
    /// OpenSfM reconstruction; anything else is taken as COLMAP, whose
    /// reader then says what is missing.
    pub fn detect(dir: &Path) -> ModelSource {
        if colmap::detect_format(dir).is_err() && super::find_reconstruction(dir).is_ok() {
            ModelSource::OpenSfm(dir.to_path_buf())
        } else {
            ModelSource::Colmap(dir.to_path_buf())
        }
    }

    /// The folder or file given.
    pub fn path(&self) -> &Path {
        match self {
            ModelSource::Colmap(p) | ModelSource::OpenSfm(p) => p,
        }
    }

    /// The model's cameras, images and points, as read (distorted cameras
    /// kept with their full model).
    pub fn read(&self) -> Result<Reconstruction> {
        match self {
            ModelSource::Colmap(dir) => colmap::read_model(dir),
            ModelSource::OpenSfm(p) => Ok(super::read_opensfm(p)?.reconstruction),
        }
    }

    /// Reads the model and checks that it is in metric, gravity-aligned
    /// local ENU (unless `frame_unchecked`): COLMAP's by its `frame.json`
    /// ([`colmap::check_frame`]), OpenSfM's by its geodetic reference.
    /// An OpenSfM camera with distortion is refused here, naming the
    /// undistort step; a COLMAP one when its camera is asked for.
    pub fn read_posed(&self, frame_unchecked: bool) -> Result<PosedModel> {
        match self {
            ModelSource::Colmap(dir) => {
                let reconstruction = colmap::read_model(dir)?;
                let frame = if frame_unchecked {
                    None
                } else {
                    Some(colmap::check_frame(dir, &reconstruction)?)
                };
                Ok(PosedModel {
                    reconstruction,
                    frame,
                    frame_file: dir.join(colmap::FRAME_FILE),
                    notes: Vec::new(),
                })
            }
            ModelSource::OpenSfm(p) => {
                let m = super::read_opensfm(p)?;
                m.check_undistorted()?;
                let frame = if frame_unchecked {
                    None
                } else {
                    Some(m.check_frame()?)
                };
                let notes = if m.others.is_empty() {
                    Vec::new()
                } else {
                    vec![format!(
                        "{}: read reconstruction {} ({} images); left out {} partial \
                         reconstruction(s) of {:?} images",
                        m.file.display(),
                        m.index,
                        m.reconstruction.images.len(),
                        m.others.len(),
                        m.others
                    )]
                };
                Ok(PosedModel {
                    frame_file: m.reference_file.clone().unwrap_or_else(|| m.file.clone()),
                    reconstruction: m.reconstruction,
                    frame,
                    notes,
                })
            }
        }
    }
}
