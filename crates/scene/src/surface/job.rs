//! The front door of points-to-surface: the one library entry `vpctl mesh
//! build` calls (and any binding can), taking points from a COLMAP model
//! (with the cameras that saw them) and/or a point cloud (with its normals,
//! when the file has them) and writing the mesh.
//!
//! The request is `#[non_exhaustive]` with a constructor: a new option is a
//! new field with a default, and no caller breaks.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::{reconstruct_surface_with_report, samples_from_model, SurfaceParams, SurfaceReport};
use super::{SurfaceSample, SurfaceSolver};
use crate::error::{Result, SceneError};
use crate::height_field::{mesh_from_points, MeshingParams, MeshingReport};
use crate::io::{self, MeshFormat, ReadWarning};
use crate::mesh::Mesh;
use crate::{colmap, fsio};

/// How the surface is built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SurfaceMethod {
    /// 3D, implicit moving least squares (the default).
    Imls,
    /// 3D, screened Poisson.
    Poisson,
    /// 2.5D: one height per (x, y), Delaunay in the plane.
    HeightField,
}

/// A points-to-surface job, as `vpctl mesh build` takes it.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct SurfaceRequest {
    /// A COLMAP model: its 3D points, seen from their tracks' cameras.
    pub colmap: Option<PathBuf>,
    /// An OpenSfM reconstruction (OpenDroneMap project): the same, its
    /// tracks from `tracks.csv`.
    pub opensfm: Option<PathBuf>,
    /// A point cloud (PLY, with normals if it has `nx ny nz`).
    pub points: Option<PathBuf>,
    /// The method.
    pub method: SurfaceMethod,
    /// 3D methods: the parameters (the solver is set from `method`).
    pub surface: SurfaceParams,
    /// Height field: the parameters.
    pub height_field: MeshingParams,
}

impl SurfaceRequest {
    /// `method` with default parameters; no input yet (set `colmap`
    /// and/or `points`).
    pub fn new(method: SurfaceMethod) -> Self {
        SurfaceRequest {
            colmap: None,
            opensfm: None,
            points: None,
            method,
            surface: SurfaceParams::default(),
            height_field: MeshingParams::default(),
        }
    }
}

/// What building the surface did, by method.
#[derive(Debug, Clone)]
pub enum SurfaceBuildReport {
    /// A 3D surface ([`SurfaceMethod::Imls`], [`SurfaceMethod::Poisson`]).
    Surface(SurfaceReport),
    /// A height field.
    HeightField(MeshingReport),
}

/// A surface built by [`build_surface`] or [`write_surface`].
#[derive(Debug, Clone)]
pub struct SurfaceBuild {
    /// The surface.
    pub mesh: Mesh,
    /// What building it did.
    pub report: SurfaceBuildReport,
    /// What the point file was read with a warning, for the caller to tell.
    pub warnings: Vec<ReadWarning>,
}

/// The surface samples of `req`: the model's points, then the cloud's;
/// with what the point file was read with a warning.
pub fn load_samples(req: &SurfaceRequest) -> Result<(Vec<SurfaceSample>, Vec<ReadWarning>)> {
    let mut samples = Vec::new();
    let mut warnings = Vec::new();
    if let Some(dir) = &req.colmap {
        samples.extend(samples_from_model(&colmap::read_model(dir)?));
    }
    if let Some(p) = &req.opensfm {
        samples.extend(samples_from_model(
            &crate::opensfm::read_opensfm(p)?.reconstruction,
        ));
    }
    if let Some(file) = &req.points {
        let cloud = io::load_points_with_normals(file)?;
        warnings = cloud.warnings;
        let pts = cloud.points;
        let normals: Vec<Option<Vector3<f64>>> = match cloud.normals {
            Some(n) => n.into_iter().map(Some).collect(),
            None => vec![None; pts.len()],
        };
        samples.extend(
            pts.into_iter()
                .zip(normals)
                .map(|(position, normal)| SurfaceSample {
                    position,
                    normal,
                    seen_from: Vec::new(),
                }),
        );
    }
    Ok((samples, warnings))
}

/// Builds the surface of `req`. A 3D method refuses a cloud point with
/// neither a normal nor a camera; a height field refuses points that give
/// no face.
pub fn build_surface(req: &SurfaceRequest) -> Result<SurfaceBuild> {
    let (samples, warnings) = load_samples(req)?;
    let (mesh, report) = surface_of(req, &samples)?;
    Ok(SurfaceBuild {
        mesh,
        report,
        warnings,
    })
}

/// The surface of `samples` by the method of `req`.
fn surface_of(
    req: &SurfaceRequest,
    samples: &[SurfaceSample],
) -> Result<(Mesh, SurfaceBuildReport)> {
    let solver = match req.method {
        SurfaceMethod::HeightField => return build_height_field(samples, &req.height_field),
        SurfaceMethod::Imls => SurfaceSolver::Imls,
        SurfaceMethod::Poisson => SurfaceSolver::Poisson,
    };
    if let (Some(file), Some(i)) = (
        &req.points,
        samples
            .iter()
            .position(|s| s.normal.is_none() && s.seen_from.is_empty()),
    ) {
        return Err(SceneError::InvalidArgument(format!(
            "{}: point {i} has no normal (no 'nx ny nz' vertex properties?) and no camera saw \
             it: a 3D surface needs one or the other; give a fused.ply with normals, a COLMAP \
             model (--colmap), or use --method height-field",
            file.display()
        )));
    }
    let params = SurfaceParams {
        solver,
        ..req.surface.clone()
    };
    let (mesh, report) = reconstruct_surface_with_report(samples, &params)?;
    Ok((mesh, SurfaceBuildReport::Surface(report)))
}

fn build_height_field(
    samples: &[SurfaceSample],
    params: &MeshingParams,
) -> Result<(Mesh, SurfaceBuildReport)> {
    let pts: Vec<_> = samples.iter().map(|s| s.position).collect();
    let (mesh, report) = mesh_from_points(&pts, params)?;
    if mesh.n_faces() == 0 {
        return Err(SceneError::InvalidArgument(format!(
            "no surface could be built from {} points (need at least 3 spread in x-y within \
             --max-edge {} m)",
            report.input_points, params.max_edge
        )));
    }
    Ok((mesh, SurfaceBuildReport::HeightField(report)))
}

/// Builds the surface of `req` and writes it to `out` (PLY or OBJ by its
/// extension), refusing an existing file unless `force`: checked before
/// any work.
pub fn write_surface(req: &SurfaceRequest, out: &Path, force: bool) -> Result<SurfaceBuild> {
    fsio::check_overwrite(out, force)?;
    let format = MeshFormat::for_path(out)?;
    let built = build_surface(req)?;
    io::write_mesh(out, &built.mesh, format)?;
    Ok(built)
}
