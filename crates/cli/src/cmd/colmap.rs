//! `vpctl colmap ...`: inspect COLMAP sparse models.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use vp_scene::colmap;

/// COLMAP subcommands.
#[derive(Debug, Subcommand)]
pub enum ColmapCommand {
    /// Print cameras, images, points and track statistics of a COLMAP sparse
    /// model directory (cameras/images/points3D as .txt or .bin).
    Info {
        /// The model directory (e.g. `sparse/0`).
        dir: PathBuf,
    },
}

pub fn run(cmd: ColmapCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
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
