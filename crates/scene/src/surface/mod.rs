//! 3D surface reconstruction from observed points: an implicit surface
//! (IMLS by default, or screened Poisson) on oriented samples, trimmed to
//! where the data is.
//!
//! Unlike the 2.5D [`height_field`](crate::height_field), this represents
//! two surfaces above one another (ground under a canopy, an overhang), as
//! long as both were seen. Input: [`SurfaceSample`]s, each a point with its
//! normal when the source knows it (vp-mvs fused points) and the centres of
//! the cameras that observed it (COLMAP tracks).
//!
//! Steps of [`reconstruct_surface`]:
//! 1. check the samples (count, finite values, a normal or a viewpoint each,
//!    not all on one line);
//! 2. normals: the sample's own, else the least-variance axis of its
//!    [`SurfaceParams::normal_neighbours`] nearest samples, signed towards
//!    the mean direction to its observing cameras;
//! 3. the implicit function of [`SurfaceParams::solver`]: IMLS (default) or
//!    screened Poisson (the `poisson_reconstruction` crate, slow beyond a
//!    ~30 m extent: see [`SurfaceSolver::Poisson`]);
//! 4. marching cubes of our own on a [`SurfaceParams::cell_size`] grid, over
//!    the cells near samples only, in a fixed order, so the result is the
//!    same bytes for the same input;
//! 5. trim: faces whose centroid is farther than the trim distance from every
//!    sample are dropped (Poisson closes the surface and invents faces far
//!    from the data), then connected pieces smaller than
//!    [`SurfaceParams::min_component_faces`] faces.
//!
//! # Performance
//! With IMLS, near-linear in the samples; rayon parallelises normals, the
//! implicit function's evaluation and trimming. 5-12 s for 60k samples over
//! a 60 m site at 0.5 m cells on a loaded 2-core machine (see
//! `docs/surface-reconstruction.md`).

mod extract;
mod grid;
pub mod job;
mod normals;

use nalgebra::{Matrix3, Point3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{Result, SceneError};
use crate::mesh::Mesh;

pub use grid::PointGrid;

/// Fewer samples than this are refused: PCA normals and the Poisson solve
/// need neighbours.
pub const MIN_SURFACE_SAMPLES: usize = 20;

/// One surface sample: a 3D point, its normal if known (vp-mvs fused points
/// have one), and the centres of the cameras that observed it (COLMAP tracks).
#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceSample {
    /// The point, world frame (metres).
    pub position: Point3<f64>,
    /// Its outward normal (towards the observers), any length but non-zero.
    pub normal: Option<Vector3<f64>>,
    /// Centres of the cameras that observed the point.
    pub seen_from: Vec<Point3<f64>>,
}

/// The implicit function whose zero set becomes the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceSolver {
    /// Implicit moving least squares (Kolluri 2008; Öztireli et al. 2009
    /// without the robust refits): at each point, the Gaussian-weighted mean
    /// of the signed distances to the tangent planes of the nearest samples.
    /// Local, linear in the samples: the default.
    Imls,
    /// Screened Poisson (Kazhdan & Hoppe 2013) by the `poisson_reconstruction`
    /// crate. Global and watertight before trimming, but the crate's
    /// right-hand side costs O(8^depth) per coarse node: beyond depth 6 (a
    /// 30 m extent at 0.5 m cells) it takes minutes. For small objects.
    Poisson,
}

/// Parameters of [`reconstruct_surface`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SurfaceParams {
    /// The implicit function meshed: `imls` (default) or `poisson`.
    pub solver: SurfaceSolver,
    /// Side of the marching-cubes cell, metres (Poisson: an upper bound, the
    /// octree depth is the smallest whose leaf is at most this). Smaller:
    /// more detail, needs denser samples, costs more.
    pub cell_size: f64,
    /// Poisson: cap on the octree depth (the leaf is the samples' extent /
    /// 2^depth).
    pub max_depth: usize,
    /// Poisson: sample density is estimated this many levels above the finest: more
    /// levels smooth over holes and uneven sampling.
    pub density_levels: usize,
    /// Poisson: screening weight of the samples' positions (0 = plain Poisson, the
    /// default: the crate's screened solve visits every point of the 27
    /// cells around each of 125 neighbours of each node, so on coarse levels,
    /// where a cell holds thousands of points, it takes minutes).
    pub screening: f64,
    /// Poisson: conjugate-gradient iterations per octree level.
    pub solver_iterations: usize,
    /// IMLS: samples weighed at each point of space.
    pub field_neighbours: usize,
    /// IMLS: Gaussian bandwidth in median sample spacings (at least half a
    /// cell). Larger: smoother, bridges wider gaps, rounds corners.
    pub smoothing: f64,
    /// Neighbours for the PCA normal of a sample without one (the sample
    /// included).
    pub normal_neighbours: usize,
    /// Faces whose centroid is farther than this from every sample are
    /// dropped (metres). `None`: `trim_spacing_factor` times the larger of the
    /// median sample spacing and the cell.
    pub trim_distance: Option<f64>,
    /// See `trim_distance`.
    pub trim_spacing_factor: f64,
    /// Connected pieces with fewer faces are dropped after trimming.
    pub min_component_faces: usize,
}

impl Default for SurfaceParams {
    fn default() -> Self {
        SurfaceParams {
            solver: SurfaceSolver::Imls,
            cell_size: 0.5,
            max_depth: 10,
            density_levels: 2,
            screening: 0.0,
            solver_iterations: 10,
            field_neighbours: 16,
            smoothing: 2.0,
            normal_neighbours: 12,
            trim_distance: None,
            trim_spacing_factor: 3.0,
            min_component_faces: 20,
        }
    }
}

impl SurfaceParams {
    /// Checks the ranges; the error names the parameter and its value.
    pub fn validate(&self) -> Result<()> {
        let bad = |msg: String| Err(SceneError::InvalidArgument(msg));
        if !(self.cell_size.is_finite() && self.cell_size > 0.0) {
            return bad(format!(
                "cell_size = {} m must be positive and finite",
                self.cell_size
            ));
        }
        if !(1..=14).contains(&self.max_depth) {
            return bad(format!("max_depth = {} is outside 1..=14", self.max_depth));
        }
        if self.density_levels >= self.max_depth {
            return bad(format!(
                "density_levels = {} must be below max_depth = {}",
                self.density_levels, self.max_depth
            ));
        }
        if !(self.screening.is_finite() && self.screening >= 0.0) {
            return bad(format!(
                "screening = {} must be >= 0 and finite",
                self.screening
            ));
        }
        if self.solver_iterations == 0 {
            return bad("solver_iterations must be at least 1".into());
        }
        if !(1..=256).contains(&self.field_neighbours) {
            return bad(format!(
                "field_neighbours = {} is outside 1..=256",
                self.field_neighbours
            ));
        }
        if !(self.smoothing.is_finite() && self.smoothing > 0.0) {
            return bad(format!(
                "smoothing = {} must be positive and finite",
                self.smoothing
            ));
        }
        if !(3..=256).contains(&self.normal_neighbours) {
            return bad(format!(
                "normal_neighbours = {} is outside 3..=256",
                self.normal_neighbours
            ));
        }
        if let Some(t) = self.trim_distance {
            if !(t.is_finite() && t > 0.0) {
                return bad(format!("trim_distance = {t} m must be positive and finite"));
            }
        }
        if !(self.trim_spacing_factor.is_finite() && self.trim_spacing_factor > 0.0) {
            return bad(format!(
                "trim_spacing_factor = {} must be positive and finite",
                self.trim_spacing_factor
            ));
        }
        Ok(())
    }
}

/// What [`reconstruct_surface_with_report`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SurfaceReport {
    /// Samples given.
    pub samples: usize,
    /// Samples whose normal came from PCA and visibility.
    pub estimated_normals: usize,
    /// Median distance from a sample to its nearest other sample, metres.
    pub spacing: f64,
    /// Octree depth used (Poisson; 0 for IMLS).
    pub depth: usize,
    /// Side of the marching-cubes cell, metres.
    pub leaf: f64,
    /// Trim distance used, metres.
    pub trim_distance: f64,
    /// Faces extracted near the samples, before trimming.
    pub extracted_faces: usize,
    /// Faces dropped for being far from every sample.
    pub trimmed_faces: usize,
    /// Faces dropped in pieces below `min_component_faces`.
    pub small_piece_faces: usize,
}

/// Reconstructs a triangle mesh (vp_scene::Mesh) of the observed surface.
///
/// Faces are oriented outwards (towards the observers); the mesh has no
/// materials. Deterministic: the same samples and parameters give the same
/// mesh, vertex and face order included. A flat (coplanar) sample set is a
/// valid surface; identical or collinear ones are refused.
pub fn reconstruct_surface(samples: &[SurfaceSample], params: &SurfaceParams) -> Result<Mesh> {
    reconstruct_surface_with_report(samples, params).map(|(mesh, _)| mesh)
}

/// [`reconstruct_surface`], with what it did.
pub fn reconstruct_surface_with_report(
    samples: &[SurfaceSample],
    params: &SurfaceParams,
) -> Result<(Mesh, SurfaceReport)> {
    params.validate()?;
    check_samples(samples)?;
    let positions: Vec<Point3<f64>> = samples.iter().map(|s| s.position).collect();
    let grid = PointGrid::new(&positions);
    let spacing = grid.median_spacing();
    let (normals, estimated) = normals::orient(samples, &grid, params.normal_neighbours)?;
    let field = extract::solve(&positions, &normals, &grid, spacing, params)?;
    let trim = params
        .trim_distance
        .unwrap_or(params.trim_spacing_factor * spacing.max(field.leaf));
    let raw = extract::extract(&field, &positions, trim);
    let extracted_faces = raw.faces.len();
    let kept = extract::trim(&raw, &grid, &normals, trim);
    let trimmed_faces = extracted_faces - kept.faces.len();
    let before_pieces = kept.faces.len();
    let mesh = extract::drop_small_pieces(kept, params.min_component_faces);
    if mesh.faces.is_empty() {
        return Err(SceneError::Surface(format!(
            "no surface within {trim:.3} m of the {} samples (Poisson found no \
             isosurface there; are the normals consistent?)",
            samples.len()
        )));
    }
    let report = SurfaceReport {
        samples: samples.len(),
        estimated_normals: estimated,
        spacing,
        depth: field.depth,
        leaf: field.leaf,
        trim_distance: trim,
        extracted_faces,
        trimmed_faces,
        small_piece_faces: before_pieces - mesh.faces.len(),
    };
    Ok((mesh, report))
}

/// Samples from a COLMAP model's points: each seen from the centres of the
/// images in its track (an image id the model lacks is skipped; a point left
/// with no image keeps an empty `seen_from`, which [`reconstruct_surface`]
/// refuses by name).
pub fn samples_from_model(model: &crate::colmap::Reconstruction) -> Vec<SurfaceSample> {
    model
        .points
        .values()
        .map(|p| {
            let mut ids: Vec<u32> = p.track.iter().map(|&(image, _)| image).collect();
            ids.sort_unstable();
            ids.dedup();
            SurfaceSample {
                position: p.xyz,
                normal: None,
                seen_from: ids
                    .iter()
                    .filter_map(|id| model.images.get(id).map(crate::colmap::ColmapImage::center))
                    .collect(),
            }
        })
        .collect()
}

/// Refuses what no method could mesh, naming the first sample at fault.
fn check_samples(samples: &[SurfaceSample]) -> Result<()> {
    let err = |msg: String| Err(SceneError::Surface(msg));
    if samples.len() < MIN_SURFACE_SAMPLES {
        return err(format!(
            "{} samples given, at least {MIN_SURFACE_SAMPLES} are needed",
            samples.len()
        ));
    }
    let finite = |v: &Vector3<f64>| v.iter().all(|c| c.is_finite());
    for (i, s) in samples.iter().enumerate() {
        if !finite(&s.position.coords) {
            return err(format!(
                "sample {i} has a non-finite position {:?}",
                s.position.coords.as_slice()
            ));
        }
        if let Some(n) = &s.normal {
            if !finite(n) || n.norm() == 0.0 {
                return err(format!(
                    "sample {i} has an unusable normal {:?} (zero or non-finite)",
                    n.as_slice()
                ));
            }
        }
        if let Some(c) = s.seen_from.iter().find(|c| !finite(&c.coords)) {
            return err(format!(
                "sample {i} is seen from a non-finite camera centre {:?}",
                c.coords.as_slice()
            ));
        }
        if s.normal.is_none() && s.seen_from.is_empty() {
            return err(format!(
                "sample {i} at {:?} has neither a normal nor a camera that saw it: \
                 its side of the surface is unknown",
                s.position.coords.as_slice()
            ));
        }
    }
    // Spread: the covariance's two largest axes must both be non-trivial
    // relative to the extent (identical points: none; a line: one).
    let n = samples.len() as f64;
    let mean = samples
        .iter()
        .fold(Vector3::zeros(), |a, s| a + s.position.coords)
        / n;
    let cov = samples.iter().fold(Matrix3::zeros(), |a, s| {
        let d = s.position.coords - mean;
        a + d * d.transpose()
    }) / n;
    let mut ev: Vec<f64> = cov.symmetric_eigenvalues().iter().copied().collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    if ev[0] <= 1e-18 {
        return err(format!(
            "all {} samples are at one point: no surface to build",
            samples.len()
        ));
    }
    if ev[1] <= 1e-10 * ev[0] {
        return err(format!(
            "all {} samples lie on one line: no surface to build",
            samples.len()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod site_tests;
#[cfg(test)]
mod tests;
