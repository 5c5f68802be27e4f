//! `vpctl colmap undistort --opensfm DIR`: an OpenSfM reconstruction with
//! distorted cameras becomes the undistorted COLMAP workspace the rest of
//! vpctl takes (`mvs run`, `plan --colmap WORKSPACE/sparse`), its frame
//! (the geodetic reference) written as `sparse/frame.json`.

use std::path::Path;

use crate::colmap::{undistort_into, UndistortOptions, UndistortReport};
use crate::error::{Result, SceneError};
use crate::outdir::OutDir;

/// Reads the OpenSfM reconstruction of `path` ([`super::read_opensfm`])
/// and writes the undistorted workspace into `out` exactly as
/// [`crate::colmap::undistort_workspace`] does for a COLMAP model, with
/// `sparse/frame.json` from the reconstruction's geodetic reference when
/// it has one. Nothing partial is written.
pub fn undistort_opensfm_workspace(
    path: &Path,
    images_dir: &Path,
    out: &Path,
    opts: &UndistortOptions,
    force: bool,
) -> Result<UndistortReport> {
    let out_dir = OutDir::check(out, "colmap undistort", &[path, images_dir], force)?;
    let model = super::read_opensfm(path)?;
    let frame = match &model.frame {
        Some(f) => Some(
            serde_json::to_string_pretty(f)
                .map_err(|e| SceneError::InvalidArgument(e.to_string()))?
                + "\n",
        ),
        None => None,
    };
    undistort_into(
        &model.reconstruction,
        &model.file,
        frame.as_deref().map(str::as_bytes),
        images_dir,
        &out_dir,
        opts,
    )
}
