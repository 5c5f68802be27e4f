//! `vpctl scene ...`: procedural scenes.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::Subcommand;
use vp_scene::io::{self, MeshFormat};
use vp_scene::procedural::{generate_site, SiteParams};
use vp_scene::{fsio, Material};

use super::UsageError;

/// Scene subcommands.
#[derive(Debug, Subcommand)]
pub enum SceneCommand {
    /// Generate a procedural aerial site (terrain, a large smooth rock, trees,
    /// grass tufts, markers; per-face materials) and write it as a mesh.
    ///
    /// The same seed and face count give a byte-identical file.
    Generate {
        /// Random seed (default: the config's `site.seed`, else 1).
        #[arg(long)]
        seed: Option<u64>,
        /// Approximate number of faces, 5k to 20M (default: the config's
        /// `site.target_faces`, else 200000).
        #[arg(long)]
        faces: Option<usize>,
        /// Campaign config (TOML): the site is its `[site]` section
        /// (`vpctl sim config > site.toml`), the world `vpctl sim fly --site`
        /// flies in; missing keys take the site's defaults.
        /// `--seed` and `--faces` override it.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Output mesh; the extension picks the file type (.ply or .obj).
        #[arg(long)]
        out: PathBuf,
        /// Mesh encoding (default from the extension: binary PLY for .ply,
        /// OBJ for .obj): ply-binary-le, ply-ascii, ply-binary-be or obj, the
        /// names Python's `write_mesh(format=)` takes. PLY keeps the
        /// materials as a face property, OBJ as `usemtl` groups.
        #[arg(long, value_parser = parse_mesh_format)]
        format: Option<MeshFormat>,
        /// Overwrite the output file if it exists.
        #[arg(long)]
        force: bool,
    },
}

/// A mesh encoding by its vp-scene name; `ply-binary` (the old spelling)
/// is binary little-endian PLY.
fn parse_mesh_format(s: &str) -> std::result::Result<MeshFormat, String> {
    if s.eq_ignore_ascii_case("ply-binary") {
        return Ok(MeshFormat::PlyBinaryLittleEndian);
    }
    s.parse::<MeshFormat>().map_err(|e| e.to_string())
}

/// The encoding of `path`: `format` if given (it must fit the extension),
/// else the extension's usual one. The error names the extension.
pub fn output_mesh_format(path: &Path, format: Option<MeshFormat>) -> Result<MeshFormat> {
    let by_ext = MeshFormat::for_path(path)?;
    match format {
        None => Ok(by_ext),
        Some(f) if f.file_type() == by_ext.file_type() => Ok(f),
        Some(f) => Err(UsageError(format!(
            "--format {f} does not fit the extension of {} (.{}): name the file .{} or drop \
             --format",
            path.display(),
            by_ext.file_type().extension(),
            f.file_type().extension()
        ))
        .into()),
    }
}

pub fn run(cmd: SceneCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        SceneCommand::Generate {
            seed,
            faces,
            config,
            out: path,
            format,
            force,
        } => {
            let format = output_mesh_format(&path, format)?;
            fsio::check_output_file(&path, force)?;
            let mut params = match &config {
                // The `[site]` section with the site's own defaults; the
                // rest of the campaign file is checked for typos only.
                Some(c) => {
                    let text = fsio::read_text(c)?;
                    vp_sim::campaign::CampaignConfig::check_keys(&text, c)?;
                    vp_scene::config_file::read_section::<SiteParams>(&text, c, "site")?
                }
                None => SiteParams {
                    seed: 1,
                    ..SiteParams::default()
                },
            };
            if let Some(s) = seed {
                params.seed = s;
            }
            if let Some(f) = faces {
                params.target_faces = f;
            }
            let site = generate_site(&params)?;
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
