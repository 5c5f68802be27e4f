//! `vpctl colmap ...`: inspect COLMAP sparse models, undistort them into a
//! dense workspace.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use vp_scene::colmap;

mod align;
mod undistort;

pub use align::AlignArgs;
pub use undistort::UndistortArgs;

/// COLMAP subcommands.
#[derive(Debug, Subcommand)]
pub enum ColmapCommand {
    /// Print cameras, images, points and track statistics of a COLMAP sparse
    /// model directory (cameras/images/points3D as .txt or .bin).
    Info {
        /// The model directory (e.g. `sparse/0`).
        dir: PathBuf,
    },
    /// Undistort a model and its images into a dense workspace, as COLMAP's
    /// `image_undistorter --output_type COLMAP` writes it: `images/`
    /// (resampled into PINHOLE cameras), `sparse/` (binary model), `stereo/`
    /// (patch-match.cfg, fusion.cfg). The layout `vpctl mvs run` reads; its
    /// `sparse/` and `images/` are what `vpctl plan` and `labelgen` need.
    /// Every COLMAP camera model but EQUIRECTANGULAR. Nothing is written
    /// unless every image was undistorted.
    Undistort(UndistortArgs),
    /// Georegister a model: the similarity transform (scale, rotation,
    /// translation) from its camera centres to known image positions in the
    /// local ENU frame at the first position, robust to a few bad positions
    /// (RANSAC, then least squares on the inliers), as COLMAP's
    /// `model_aligner` does. The positions come from a CSV (--positions) or
    /// from the photos' EXIF GPS tags (--exif). Writes the moved model and `frame.json` (the
    /// geodetic origin, the transform, the residuals) to --out; prints the
    /// residuals. `vpctl plan` and `labelgen` need that frame. Cameras on a
    /// line (a single strip) need --gravity-from-views.
    Align(AlignArgs),
}

pub fn run(cmd: ColmapCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        ColmapCommand::Undistort(a) => undistort::undistort(&a, out),
        ColmapCommand::Align(a) => align::align(&a, out),
        ColmapCommand::Info { dir } => {
            let format = colmap::detect_format(&dir)?;
            let rec = colmap::read_model_as(&dir, format)?;
            writeln!(out, "model: {} ({format:?})", dir.display())?;
            writeln!(out, "cameras: {}", rec.cameras.len())?;
            for cam in rec.cameras.values() {
                writeln!(
                    out,
                    "  camera {}: {} {}x{} params {:?}",
                    cam.id,
                    cam.model.name(),
                    cam.width,
                    cam.height,
                    cam.params
                )?;
            }
            writeln!(out, "images: {}", rec.images.len())?;
            writeln!(out, "points: {}", rec.points.len())?;
            writeln!(out, "mean track length: {:.4}", rec.mean_track_length())?;
            writeln!(
                out,
                "mean observations per image: {:.4}",
                rec.mean_observations_per_image()
            )?;
            if let Some(e) = rec.mean_reprojection_error() {
                writeln!(out, "mean reprojection error: {e:.4} px")?;
            }
            Ok(())
        }
    }
}
