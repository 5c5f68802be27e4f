//! COLMAP sparse models (text and binary) and dense depth maps.
//!
//! - [`read_model`] loads a sparse model folder (`cameras`, `images`,
//!   `points3D`, as `.bin` or `.txt`) into a [`Reconstruction`] and checks
//!   its cross-references; [`write_text`] and [`write_binary`] write one.
//! - [`Reconstruction::camera_of`] gives the posed pinhole [`Camera`] of an
//!   image, and refuses a camera with lens distortion: never a silent
//!   pinhole. [`ColmapCamera::img_from_cam`] / [`ColmapCamera::cam_from_img`]
//!   project with the full model of every [`CameraModel`];
//!   [`undistort_workspace`] writes the undistorted `PINHOLE` workspace
//!   COLMAP's `image_undistorter` writes (`vpctl colmap undistort`).
//! - [`align_to_positions`] ties a model to the world (`vpctl colmap
//!   align`), with image positions from a CSV ([`read_positions_csv`]) or
//!   from the photos' EXIF GPS tags ([`read_positions_exif`]).
//! - [`read_depth_map`] / [`write_depth_map`] handle COLMAP's dense depth
//!   maps ([`DepthMap`]).
//!
//! Every error names the file and the place: the line for text files, the
//! element and byte offset for binary files.
//!
//! [`Camera`]: crate::Camera

mod align;
mod binary;
mod depth;
mod exif_positions;
mod frame;
mod lens;
mod model;
mod reconstruction;
mod strip;
mod text;
mod undistort;

use std::path::{Path, PathBuf};

pub use align::{
    align_to_positions, transform_reconstruction, AlignParams, Alignment, PositionResidual,
    StripFit,
};
pub use binary::{
    cameras_to_bytes, images_to_bytes, parse_cameras_binary, parse_images_binary,
    parse_points3d_binary, points3d_to_bytes, read_cameras_binary, read_images_binary,
    read_points3d_binary,
};
pub use depth::{
    parse_depth_map, parse_normal_map, read_depth_map, read_normal_map, write_depth_map,
    write_normal_map, DepthMap, DepthStats, NormalMap,
};
pub use exif_positions::{read_positions_exif, ExifPositions, TAKEOFF_SPREAD_M};
pub use frame::{
    check_frame, check_frame_of, read_positions_csv, FrameCheck, ModelFrame, FRAME_FILE,
};
pub use model::{CameraModel, ColmapCamera, ColmapImage, Point2D, Point3D};
pub use reconstruction::Reconstruction;
pub use text::{
    cameras_to_string, images_to_string, parse_cameras, parse_images, parse_points3d,
    points3d_to_string, read_cameras_text, read_images_text, read_points3d_text,
};
pub use undistort::{
    first_distorted_camera, undistort_camera, undistort_image, undistort_reconstruction,
    undistort_workspace, UndistortOptions, UndistortReport,
};

use crate::error::{Location, Result, SceneError};
use reconstruction::ModelFile;
pub(crate) use undistort::undistort_into;

/// The two on-disk forms of a sparse model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelFormat {
    /// `cameras.bin`, `images.bin`, `points3D.bin`.
    Binary,
    /// `cameras.txt`, `images.txt`, `points3D.txt`.
    Text,
}

impl ModelFormat {
    fn extension(self) -> &'static str {
        match self {
            ModelFormat::Binary => "bin",
            ModelFormat::Text => "txt",
        }
    }

    /// Paths of the three files of a model in `dir`, in the order cameras,
    /// images, points.
    pub fn files(self, dir: &Path) -> [PathBuf; 3] {
        [ModelFile::Cameras, ModelFile::Images, ModelFile::Points]
            .map(|f| dir.join(format!("{}.{}", f.stem(), self.extension())))
    }
}

/// Which form of model `dir` holds. Binary wins when both are complete:
/// it is what COLMAP's mapper writes and it is lossless, while a text copy
/// beside it is usually an export made from it.
pub fn detect_format(dir: &Path) -> Result<ModelFormat> {
    let complete = |f: ModelFormat, d: &Path| f.files(d).iter().all(|p| p.is_file());
    if complete(ModelFormat::Binary, dir) {
        return Ok(ModelFormat::Binary);
    }
    if complete(ModelFormat::Text, dir) {
        return Ok(ModelFormat::Text);
    }
    if !dir.exists() {
        return Err(SceneError::io(
            dir,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such directory"),
        ));
    }
    if !dir.is_dir() {
        return Err(SceneError::parse(
            dir,
            Location::Header,
            "not a directory: a COLMAP model is a folder with cameras, images and points3D files",
        ));
    }
    let mut message = String::from(
        "no COLMAP model: expected cameras, images and points3D as .bin or .txt files",
    );
    for f in [ModelFormat::Binary, ModelFormat::Text] {
        let [cams, ims, pts] = f.files(dir);
        let present = [&cams, &ims, &pts].iter().filter(|p| p.is_file()).count();
        if present > 0 {
            let missing: Vec<String> = [cams, ims, pts]
                .iter()
                .filter(|p| !p.is_file())
                .map(|p| {
                    p.file_name()
                        .unwrap_or_default()
                        .to_string_lossy()
                        .into_owned()
                })
                .collect();
            message = format!("incomplete COLMAP model: missing {}", missing.join(", "));
        }
    }
    // The mapper writes numbered sub-models (sparse/0, sparse/1, ...).
    let sub = dir.join("0");
    if complete(ModelFormat::Binary, &sub) || complete(ModelFormat::Text, &sub) {
        message = format!("{message} (a model exists in {})", sub.display());
    }
    if crate::opensfm::find_reconstruction(dir).is_ok() {
        message = format!(
            "{message}; the folder holds an OpenSfM reconstruction (OpenDroneMap): pass it with              --opensfm {} instead",
            dir.display()
        );
    }
    Err(SceneError::parse(dir, Location::Header, message))
}

/// Reads a sparse model from `dir` (format from [`detect_format`]) and
/// checks it: unknown camera or image references, track elements pointing
/// at missing 2D points, etc. are errors naming the file at fault.
pub fn read_model(dir: &Path) -> Result<Reconstruction> {
    let format = detect_format(dir)?;
    read_model_as(dir, format)
}

/// Reads a sparse model of the given format from `dir` and checks it.
pub fn read_model_as(dir: &Path, format: ModelFormat) -> Result<Reconstruction> {
    let files = format.files(dir);
    let (rec, places) = match format {
        ModelFormat::Binary => binary::read_located(&files)?,
        ModelFormat::Text => text::read_located(&files)?,
    };
    if let Some(bad) = rec.check() {
        let k = match bad.file {
            ModelFile::Cameras => 0,
            ModelFile::Images => 1,
            ModelFile::Points => 2,
        };
        let location = places[k].get(&bad.id).cloned().unwrap_or(Location::Header);
        return Err(SceneError::parse(
            &files[k],
            location,
            format!("{}: {}", bad.element, bad.message),
        ));
    }
    Ok(rec)
}

/// Writes `rec` as `cameras.txt`, `images.txt`, `points3D.txt` into `dir`
/// (created if missing), after [`Reconstruction::validate`]. Each file is
/// written atomically (the three together are not: a failure part way can
/// leave new and old files side by side, never a partial file).
pub fn write_text(dir: &Path, rec: &Reconstruction) -> Result<()> {
    rec.validate()?;
    std::fs::create_dir_all(dir).map_err(|e| SceneError::io(dir, e))?;
    text::write_text_files(dir, rec)
}

/// Writes `rec` as `cameras.bin`, `images.bin`, `points3D.bin` into `dir`
/// (created if missing), after [`Reconstruction::validate`]. Each file is
/// written atomically.
pub fn write_binary(dir: &Path, rec: &Reconstruction) -> Result<()> {
    rec.validate()?;
    std::fs::create_dir_all(dir).map_err(|e| SceneError::io(dir, e))?;
    binary::write_binary_files(dir, rec)
}
