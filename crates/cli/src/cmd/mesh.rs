//! `vpctl mesh ...`: inspect meshes.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use vp_scene::height_field::MeshingParams;
use vp_scene::io;
use vp_scene::surface::job::{write_surface, SurfaceBuildReport, SurfaceMethod, SurfaceRequest};
use vp_scene::surface::SurfaceParams;
use vp_scene::{Material, Mesh};

/// How `vpctl mesh build` meshes the points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// 3D surface, implicit moving least squares: ground under canopies and
    /// overhangs where they were seen. Needs normals or visibility.
    Imls,
    /// 3D surface, screened Poisson: for small scenes (slow beyond ~30 m at
    /// 0.5 m cells).
    Poisson,
    /// 2.5D height field (Delaunay in x-y, highest point kept): open terrain.
    HeightField,
}

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
    /// Build a surface mesh from points: a COLMAP model's points3D (seen from
    /// the centres of the images in their tracks) and/or a point file (.ply
    /// or .obj vertices; a PLY's `nx ny nz` are used as normals, as in
    /// vp-mvs's and COLMAP's `fused.ply`).
    ///
    /// The default method (imls) builds a 3D surface: ground under a canopy
    /// is kept when it was seen. Faces farther than the trim distance from
    /// every point are dropped, so unseen gaps stay open. `--method
    /// height-field` builds the 2.5D mesh (spikes removed, faces longer than
    /// --max-edge dropped; where points stack the highest is kept). The points
    /// must be in a z-up frame (local ENU): align a COLMAP model first (e.g.
    /// `colmap model_orientation_aligner` or georegistration).
    Build {
        /// A COLMAP sparse model directory (text or binary).
        #[arg(long, required_unless_present_any = ["points", "opensfm"])]
        colmap: Option<PathBuf>,
        /// Or an OpenSfM reconstruction (an OpenDroneMap project, its
        /// `opensfm` folder or `reconstruction.json`), already in ENU.
        #[arg(long, value_name = "DIR", conflicts_with = "colmap")]
        opensfm: Option<PathBuf>,
        /// A point file (.ply or .obj; only its vertices, and a PLY's vertex
        /// normals, are used).
        #[arg(long)]
        points: Option<PathBuf>,
        /// Output mesh (.ply or .obj).
        #[arg(long)]
        out: PathBuf,
        /// Meshing method.
        #[arg(long, value_enum, default_value_t = Method::Imls)]
        method: Method,
        /// 3D methods: side of the grid cells the surface is extracted on, metres.
        #[arg(long, allow_negative_numbers = true, default_value_t = SurfaceParams::default().cell_size)]
        cell_size: f64,
        /// 3D methods: drop faces farther than this from every point, metres
        /// (default: 3 times the larger of the point spacing and the cell).
        #[arg(long, allow_negative_numbers = true)]
        trim_distance: Option<f64>,
        /// Height field: longest allowed face edge, metres.
        #[arg(long, allow_negative_numbers = true, default_value_t = MeshingParams::default().max_edge)]
        max_edge: f64,
        /// Overwrite the output file if it exists.
        #[arg(long)]
        force: bool,
    },
}

/// Prints what `mesh build` did: the numbers a user checks the surface by.
fn print_report(
    report: &SurfaceBuildReport,
    mesh: &Mesh,
    max_edge: f64,
    out: &mut dyn Write,
) -> Result<()> {
    match report {
        SurfaceBuildReport::Surface(r) => {
            writeln!(out, "points: {}", r.samples)?;
            writeln!(
                out,
                "normals: {} given, {} estimated from neighbours and cameras",
                r.samples - r.estimated_normals,
                r.estimated_normals
            )?;
            writeln!(
                out,
                "spacing: {:.3} m; cell {:.3} m; trim distance {:.3} m",
                r.spacing, r.leaf, r.trim_distance
            )?;
            writeln!(
                out,
                "faces: {} ({} far from the points and {} in small pieces dropped)",
                mesh.n_faces(),
                r.trimmed_faces,
                r.small_piece_faces
            )?;
        }
        SurfaceBuildReport::HeightField(r) => {
            writeln!(out, "points: {}", r.input_points)?;
            writeln!(
                out,
                "dropped: {} non-finite, {} stacked, {} spikes",
                r.non_finite, r.merged, r.spikes
            )?;
            writeln!(
                out,
                "faces: {} ({} longer than {max_edge} m and {} slivers dropped)",
                mesh.n_faces(),
                r.long_faces,
                r.slivers
            )?;
        }
    }
    Ok(())
}

pub fn run(cmd: MeshCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        MeshCommand::Info { file } => info(&file, out),
        MeshCommand::Build {
            colmap,
            opensfm,
            points,
            out: path,
            method,
            cell_size,
            trim_distance,
            max_edge,
            force,
        } => {
            vp_scene::fsio::check_output_file(&path, force)?;
            let mut req = SurfaceRequest::new(match method {
                Method::Imls => SurfaceMethod::Imls,
                Method::Poisson => SurfaceMethod::Poisson,
                Method::HeightField => SurfaceMethod::HeightField,
            });
            req.colmap = colmap;
            req.opensfm = opensfm;
            req.points = points;
            req.surface.cell_size = cell_size;
            req.surface.trim_distance = trim_distance;
            req.height_field.max_edge = max_edge;
            let built = write_surface(&req, &path, force)?;
            super::print_warnings(&built.warnings);
            print_report(&built.report, &built.mesh, max_edge, out)?;
            writeln!(out, "wrote {}", path.display())?;
            Ok(())
        }
    }
}

fn info(file: &std::path::Path, out: &mut dyn Write) -> Result<()> {
    let (mesh, warnings) = io::load_mesh_raw_with_warnings(file)?;
    super::print_warnings(&warnings);
    let i = mesh.inspect();
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
