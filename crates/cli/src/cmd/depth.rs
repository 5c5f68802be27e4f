//! `vpctl depth ...`: inspect COLMAP dense depth maps.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use vp_scene::colmap;

/// Depth map subcommands.
#[derive(Debug, Subcommand)]
pub enum DepthCommand {
    /// Print size, share of valid pixels and depth range of a COLMAP depth
    /// map (`*.geometric.bin`, `*.photometric.bin`).
    Info {
        /// The depth map file.
        file: PathBuf,
    },
}

pub fn run(cmd: DepthCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        DepthCommand::Info { file } => {
            let depth = colmap::read_depth_map(&file)?;
            let s = depth.stats();
            writeln!(out, "file: {}", file.display())?;
            writeln!(out, "size: {}x{}", depth.width, depth.height)?;
            writeln!(out, "valid: {:.2}%", 100.0 * s.valid_share)?;
            writeln!(out, "valid pixels: {} of {}", s.valid, s.total)?;
            if let (Some(min), Some(max), Some(mean)) = (s.min, s.max, s.mean) {
                writeln!(out, "min: {min:.4}")?;
                writeln!(out, "max: {max:.4}")?;
                writeln!(out, "mean: {mean:.4}")?;
            }
            Ok(())
        }
    }
}
