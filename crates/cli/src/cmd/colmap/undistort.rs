//! `vpctl colmap undistort`: a COLMAP or OpenSfM model and its photos into
//! a dense workspace.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use vp_scene::colmap;

/// Arguments of `vpctl colmap undistort`.
#[derive(Debug, clap::Args)]
pub struct UndistortArgs {
    /// The sparse model (e.g. `sparse/0`), with distorted cameras.
    #[arg(
        long = "colmap",
        alias = "model",
        value_name = "DIR",
        required_unless_present = "opensfm"
    )]
    pub model: Option<PathBuf>,
    /// Or an OpenSfM reconstruction (an OpenDroneMap project, its `opensfm`
    /// folder or `reconstruction.json`); its geodetic reference becomes
    /// `sparse/frame.json`.
    #[arg(long, value_name = "DIR", conflicts_with = "model")]
    pub opensfm: Option<PathBuf>,
    /// The folder of the photos the model names.
    #[arg(long)]
    pub images: PathBuf,
    /// The workspace folder to write (a new or empty folder, or an earlier
    /// `colmap undistort` output with --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Replace an earlier workspace in --out (only the files vpctl wrote
    /// there; other files stay).
    #[arg(long)]
    pub force: bool,
    /// 0: crop to the pixels every ray covers (no black border, COLMAP's
    /// default); 1: keep every input pixel (black corners).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub blank_pixels: f64,
    /// Longest side of the undistorted images, pixels, as COLMAP's
    /// `--max_image_size` (cameras and features scaled with them): e.g. 2000
    /// runs dense stereo, prediction and planning on a 4000-pixel drone photo
    /// at half resolution. Default: full size
    #[arg(long, value_name = "PIXELS")]
    pub max_image_size: Option<u32>,
}

pub(super) fn undistort(a: &UndistortArgs, out: &mut dyn Write) -> Result<()> {
    if !(0.0..=1.0).contains(&a.blank_pixels) {
        return Err(crate::cmd::UsageError(format!(
            "--blank-pixels must lie in [0, 1], got {}",
            a.blank_pixels
        ))
        .into());
    }
    if a.max_image_size == Some(0) {
        return Err(crate::cmd::UsageError(
            "--max-image-size must be at least 1 pixel (leave it out for full size)".into(),
        )
        .into());
    }
    let opts = colmap::UndistortOptions {
        blank_pixels: a.blank_pixels,
        max_image_size: a.max_image_size,
        ..colmap::UndistortOptions::default()
    };
    let report = match (&a.model, &a.opensfm) {
        (_, Some(p)) => {
            vp_scene::opensfm::undistort_opensfm_workspace(p, &a.images, &a.out, &opts, a.force)?
        }
        (Some(dir), None) => colmap::undistort_workspace(dir, &a.images, &a.out, &opts, a.force)?,
        (None, None) => anyhow::bail!("--colmap or --opensfm is required"),
    };
    for (d, u) in &report.cameras {
        writeln!(
            out,
            "camera {}: {} {}x{} -> {} {}x{} params {:?}",
            d.id, d.model, d.width, d.height, u.model, u.width, u.height, u.params
        )?;
    }
    writeln!(
        out,
        "wrote {} undistorted images, sparse/ and stereo/ to {}",
        report.n_images,
        report.out.display()
    )?;
    Ok(())
}
