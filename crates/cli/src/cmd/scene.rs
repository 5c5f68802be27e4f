//! `vpctl scene ...`: procedural scenes.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::{Subcommand, ValueEnum};
use vp_scene::io::{self, MeshFormat};
use vp_scene::procedural::{generate_site, SiteParams};
use vp_scene::{fsio, Material};

/// Scene subcommands.
#[derive(Debug, Subcommand)]
pub enum SceneCommand {
    /// Generate a procedural aerial site (terrain, a large smooth rock, trees,
    /// grass tufts, markers; per-face materials) and write it as a mesh.
    ///
    /// The same seed and face count give a byte-identical file.
    Generate {
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Approximate number of faces (10k to 1M).
        #[arg(long, default_value_t = 200_000)]
        faces: usize,
        /// Output mesh (.ply or .obj).
        #[arg(long)]
        out: PathBuf,
        /// Mesh encoding; PLY keeps the materials as a face property, OBJ as
        /// `usemtl` groups.
        #[arg(long, value_enum, default_value_t = Format::PlyBinary)]
        format: Format,
        /// Overwrite the output file if it exists.
        #[arg(long)]
        force: bool,
    },
}

/// Mesh encodings offered on the command line.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Format {
    /// Binary little-endian PLY.
    PlyBinary,
    /// ASCII PLY.
    PlyAscii,
    /// Wavefront OBJ.
    Obj,
}

pub fn run(cmd: SceneCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        SceneCommand::Generate {
            seed,
            faces,
            out: path,
            format,
            force,
        } => {
            fsio::check_overwrite(&path, force)?;
            let params = SiteParams {
                seed,
                target_faces: faces,
                ..SiteParams::default()
            };
            let site = generate_site(&params)?;
            let format = match format {
                Format::PlyBinary => MeshFormat::PlyBinaryLittleEndian,
                Format::PlyAscii => MeshFormat::PlyAscii,
                Format::Obj => MeshFormat::Obj,
            };
            io::write_mesh(&path, &site.mesh, format)?;
            let s = site.summary();
            writeln!(out, "wrote {}", path.display())?;
            writeln!(out, "faces: {}", s.n_faces)?;
            writeln!(out, "vertices: {}", s.n_vertices)?;
            for (m, n) in Material::ALL.iter().zip(s.faces_per_material) {
                writeln!(out, "  {}: {n}", m.name())?;
            }
            let (r, v) = (site.rock_bounds, site.flight_volume);
            writeln!(
                out,
                "rock bounds: [{:.2}, {:.2}, {:.2}] .. [{:.2}, {:.2}, {:.2}]",
                r.min.x, r.min.y, r.min.z, r.max.x, r.max.y, r.max.z
            )?;
            writeln!(
                out,
                "flight volume: [{:.2}, {:.2}, {:.2}] .. [{:.2}, {:.2}, {:.2}]",
                v.min.x, v.min.y, v.min.z, v.max.x, v.max.y, v.max.z
            )?;
            writeln!(
                out,
                "origin: {:.6} N {:.6} E {:.1} m",
                site.origin.lat_deg, site.origin.lon_deg, site.origin.alt_m
            )?;
            Ok(())
        }
    }
}
