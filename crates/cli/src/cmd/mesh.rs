//! `vpctl mesh ...`: inspect meshes.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use vp_scene::height_field::{mesh_from_points, MeshingParams};
use vp_scene::io::{self, MeshFormat};
use vp_scene::{colmap, fsio, Material};

/// Mesh subcommands.
#[derive(Debug, Subcommand)]
pub enum MeshCommand {
    /// Print faces, vertices, bounds, materials and the problems found in a
    /// PLY or OBJ mesh (non-finite coordinates, bad indices, degenerate faces).
    ///
    /// Exits with 0 when the mesh is usable as it is, 8 when it has problems,
    /// 2 when it cannot be read.
    Info {
        /// The mesh file (.ply or .obj).
        file: PathBuf,
    },
    /// Build a 2.5D surface mesh (height field, Delaunay in x-y) from sparse
    /// points: a COLMAP model's points3D or the vertices of a PLY/OBJ file.
    ///
    /// Spikes (points far from their neighbours' heights) are removed and faces
    /// with an edge longer than --max-edge are dropped, so unseen gaps stay
    /// open. Where points stack (canopy over ground) the highest is kept.
    /// The points must be in a z-up frame (local ENU): align a COLMAP model
    /// first (e.g. `colmap model_orientation_aligner` or georegistration).
    Build {
        /// A COLMAP sparse model directory (text or binary).
        #[arg(long, conflicts_with = "points", required_unless_present = "points")]
        colmap: Option<PathBuf>,
        /// A point file (.ply or .obj; only its vertices are used).
        #[arg(long)]
        points: Option<PathBuf>,
        /// Output mesh (.ply or .obj).
        #[arg(long)]
        out: PathBuf,
        /// Longest allowed face edge, metres.
        #[arg(long, allow_negative_numbers = true, default_value_t = MeshingParams::default().max_edge)]
        max_edge: f64,
        /// Overwrite the output file if it exists.
        #[arg(long)]
        force: bool,
    },
}

pub fn run(cmd: MeshCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        MeshCommand::Info { file } => info(&file, out),
        MeshCommand::Build {
            colmap,
            points,
            out: path,
            max_edge,
            force,
        } => {
            fsio::check_overwrite(&path, force)?;
            let format = MeshFormat::for_path(&path)?;
            let pts = match (colmap, points) {
                (Some(dir), _) => colmap::read_model(&dir)?
                    .points
                    .values()
                    .map(|p| p.xyz)
                    .collect(),
                (None, Some(file)) => io::load_mesh_raw(&file)?.vertices,
                (None, None) => unreachable!("clap requires one of --colmap and --points"),
            };
            let params = MeshingParams {
                max_edge,
                ..MeshingParams::default()
            };
            let (mesh, report) = mesh_from_points(&pts, &params)?;
            if mesh.n_faces() == 0 {
                return Err(super::UsageError(format!(
                    "no surface could be built from {} points (need at least 3 spread in x-y \
                     within --max-edge {max_edge} m)",
                    report.input_points
                ))
                .into());
            }
            io::write_mesh(&path, &mesh, format)?;
            writeln!(out, "points: {}", report.input_points)?;
            writeln!(
                out,
                "dropped: {} non-finite, {} stacked, {} spikes",
                report.non_finite, report.merged, report.spikes
            )?;
            writeln!(
                out,
                "faces: {} ({} longer than {max_edge} m and {} slivers dropped)",
                mesh.n_faces(),
                report.long_faces,
                report.slivers
            )?;
            writeln!(out, "wrote {}", path.display())?;
            Ok(())
        }
    }
}

fn info(file: &std::path::Path, out: &mut dyn Write) -> Result<()> {
    let i = io::load_mesh_raw(file)?.inspect();
    writeln!(out, "file: {}", file.display())?;
    writeln!(out, "vertices: {}", i.vertices)?;
    writeln!(out, "faces: {}", i.faces)?;
    if let Some(b) = i.bounds {
        writeln!(
            out,
            "bounds min: {:.4} {:.4} {:.4}",
            b.min.x, b.min.y, b.min.z
        )?;
        writeln!(
            out,
            "bounds max: {:.4} {:.4} {:.4}",
            b.max.x, b.max.y, b.max.z
        )?;
        let e = b.extent();
        writeln!(out, "extent: {:.4} {:.4} {:.4}", e.x, e.y, e.z)?;
    }
    if let Some((area, edge)) = i.area_and_mean_edge {
        writeln!(out, "area: {area:.4}")?;
        writeln!(out, "mean edge length: {edge:.4}")?;
    }
    match i.material_counts {
        None => writeln!(out, "materials: none")?,
        Some(counts) => {
            let parts: Vec<String> = Material::ALL
                .iter()
                .zip(counts)
                .filter(|(_, n)| *n > 0)
                .map(|(m, n)| format!("{} {n}", m.name()))
                .collect();
            writeln!(out, "materials: {}", parts.join(", "))?;
        }
    }
    writeln!(out, "problems: {}", i.problems_line())?;
    if i.usable {
        Ok(())
    } else {
        Err(super::ProblemsFound(format!(
            "{}: {} (exit code {})",
            file.display(),
            i.problems_line(),
            super::EXIT_PROBLEMS_FOUND
        ))
        .into())
    }
}
