//! Triangulation geometry of a 3D point seen by a set of cameras: the
//! triangulation angle (defined in docs/design.md#shared-geometry) and the
//! first-order 3D uncertainty of the point. The one home of these
//! quantities: the simulator, labelgen (per-pixel measurements), the planner
//! (f_unc, the triplet angle) and the MVS (minimum-angle filter) all call
//! these.
//!
//! Two edge cases are decided here, once:
//! - **A camera that does not have the point in front** (depth <= 0) did not
//!   observe it and contributes no information: [`camera_information`] is
//!   zero for it. The point is still fixed if the other cameras fix it.
//! - **A singular information matrix** (fewer than two observing cameras, or
//!   all observing centres on one line through the point) gives no
//!   covariance: [`covariance`] returns `None`. "Singular" is judged relative
//!   to the matrix's scale, since a rank-deficient sum of floating-point
//!   outer products is rarely exactly singular.

use nalgebra::{Matrix3, Point3, Vector3};

use crate::Camera;

/// Largest pairwise angle, in degrees, between unit directions. 0 for fewer
/// than two directions.
///
/// # Performance
/// One `acos` however many pairs: the smallest dot product of unit vectors
/// is the largest angle. The planner calls this for every triplet it scores.
pub fn largest_pairwise_angle_deg(units: &[Vector3<f64>]) -> f64 {
    let mut min_dot = 1.0f64;
    for (i, a) in units.iter().enumerate() {
        for b in &units[i + 1..] {
            min_dot = min_dot.min(a.dot(b));
        }
    }
    min_dot.clamp(-1.0, 1.0).acos().to_degrees()
}

/// Triangulation angle at `p` in degrees: the largest pairwise angle between
/// the rays from `p` to the camera centres. Centres that coincide with `p`
/// are skipped; 0 for fewer than two usable centres.
pub fn triangulation_angle_deg(p: &Point3<f64>, centres: &[Point3<f64>]) -> f64 {
    // No allocation: this runs once per pixel in labelgen and the MVS.
    let mut min_dot = 1.0f64;
    for (i, a) in centres.iter().enumerate() {
        let Some(ra) = (a - p).try_normalize(0.0) else {
            continue;
        };
        for b in &centres[i + 1..] {
            if let Some(rb) = (b - p).try_normalize(0.0) {
                min_dot = min_dot.min(ra.dot(&rb));
            }
        }
    }
    min_dot.clamp(-1.0, 1.0).acos().to_degrees()
}

/// Fisher information (1/m^2) of `p` from one camera with isotropic pixel
/// noise `sigma_px`: `J^T J / sigma_px^2`, J the 2x3 projection Jacobian at
/// `p`. Zero when `p` is not in front of the camera (see the module doc).
pub fn camera_information(camera: &Camera, p: &Point3<f64>, sigma_px: f64) -> Matrix3<f64> {
    if !(camera.world_from_cam.inverse_transform_point(p).z > 0.0) {
        return Matrix3::zeros();
    }
    let j = camera.projection_jacobian(p);
    j.transpose() * j / (sigma_px * sigma_px)
}

/// Summed information of `p` from all `cameras` ([`camera_information`]).
pub fn information<'a>(
    cameras: impl IntoIterator<Item = &'a Camera>,
    p: &Point3<f64>,
    sigma_px: f64,
) -> Matrix3<f64> {
    cameras
        .into_iter()
        .map(|c| camera_information(c, p, sigma_px))
        .sum()
}

/// Covariance (m^2) from a summed information matrix:
/// `Sigma = (sum_i J_i^T J_i / sigma_px^2)^-1` (f_unc;
/// docs/design.md#shared-geometry). `None` when the information is singular
/// (see the module doc).
pub fn covariance(info: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    // For a PSD matrix, det / trace^3 is tiny exactly when the smallest
    // eigenvalue is tiny against the largest. Cheaper than an
    // eigen-decomposition per pixel.
    let trace = info.trace();
    if !(info.determinant() > 1e-13 * trace * trace * trace) {
        return None;
    }
    info.try_inverse()
}

/// First-order covariance (m^2) of `p` triangulated from `cameras`:
/// [`covariance`] of [`information`].
pub fn point_covariance<'a>(
    cameras: impl IntoIterator<Item = &'a Camera>,
    p: &Point3<f64>,
    sigma_px: f64,
) -> Option<Matrix3<f64>> {
    covariance(&information(cameras, p, sigma_px))
}

/// Standard deviation (m) of `cov` along the unit direction `dir`.
pub fn sigma_along(cov: &Matrix3<f64>, dir: &Vector3<f64>) -> f64 {
    dir.dot(&(cov * dir)).max(0.0).sqrt()
}

/// Largest standard deviation of `cov` (m): the square root of its largest
/// eigenvalue, the paper's 3D uncertainty `sqrt(u)`.
pub fn sigma_max(cov: &Matrix3<f64>) -> f64 {
    largest_eigenvalue(cov).max(0.0).sqrt()
}

/// Smallest eigenvalue of a symmetric 3x3 matrix, in closed form.
///
/// # Performance
/// About ten times faster than an iterative decomposition; the planner's
/// f_unc calls it for every triplet M1 and M3 score. It takes only the
/// cosine of its own root (the same operations as [`largest_eigenvalue`]
/// takes for its root, so each is the value of the joint solution).
pub fn smallest_eigenvalue(a: &Matrix3<f64>) -> f64 {
    match characteristic(a) {
        Roots::Diagonal(d) => d[0].min(d[1]).min(d[2]),
        Roots::Trigonometric { q, p, phi } => {
            q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos()
        }
    }
}

/// Largest eigenvalue of a symmetric 3x3 matrix, in closed form.
pub fn largest_eigenvalue(a: &Matrix3<f64>) -> f64 {
    match characteristic(a) {
        Roots::Diagonal(d) => d[0].max(d[1]).max(d[2]),
        Roots::Trigonometric { q, p, phi } => q + 2.0 * p * phi.cos(),
    }
}

/// The eigenvalues of a symmetric 3x3 matrix before the last cosine.
enum Roots {
    /// A diagonal matrix: its diagonal.
    Diagonal([f64; 3]),
    /// Root k is `q + 2 p cos(phi + 2 k pi / 3)`.
    Trigonometric { q: f64, p: f64, phi: f64 },
}

/// The trigonometric solution of the characteristic cubic (O. K. Smith 1961).
#[inline]
fn characteristic(a: &Matrix3<f64>) -> Roots {
    let p1 = a[(0, 1)].powi(2) + a[(0, 2)].powi(2) + a[(1, 2)].powi(2);
    if p1 == 0.0 {
        return Roots::Diagonal([a[(0, 0)], a[(1, 1)], a[(2, 2)]]);
    }
    let q = a.trace() / 3.0;
    let p2 = (a[(0, 0)] - q).powi(2) + (a[(1, 1)] - q).powi(2) + (a[(2, 2)] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let b = (a - Matrix3::identity() * q) / p;
    let r = (0.5 * b.determinant()).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    Roots::Trigonometric { q, p, phi }
}

/// Triangulation angle and uncertainty of one surface point for one camera
/// of a set (the query camera, whose depth map holds the point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointGeometry {
    /// Triangulation angle, degrees.
    pub angle_deg: f64,
    /// Standard deviation of the point along the query camera's viewing ray, metres.
    pub sigma_ray: f64,
    /// Standard deviation of the query camera's depth (along its optical
    /// axis), metres: `sigma_ray` times the cosine between ray and axis.
    pub sigma_depth: f64,
    /// Largest standard deviation of the point in any direction, metres.
    pub sigma_max: f64,
}

/// [`PointGeometry`] of `p` as seen by `query` (one of `cameras`), with pixel
/// noise `sigma_px`. `None` when the covariance is undefined (see
/// [`covariance`]) or `p` is the query camera's centre.
pub fn point_geometry(
    cameras: &[&Camera],
    query: &Camera,
    p: &Point3<f64>,
    sigma_px: f64,
) -> Option<PointGeometry> {
    let cov = point_covariance(cameras.iter().copied(), p, sigma_px)?;
    let ray = (p - query.center()).try_normalize(0.0)?;
    let sigma_ray = sigma_along(&cov, &ray);
    let centres: Vec<Point3<f64>> = cameras.iter().map(|c| c.center()).collect();
    let angle_deg = triangulation_angle_deg(p, &centres);
    Some(PointGeometry {
        angle_deg,
        sigma_ray,
        sigma_depth: sigma_ray * ray.dot(&query.axis()).abs(),
        sigma_max: sigma_max(&cov),
    })
}

#[cfg(test)]
#[path = "triangulation_tests.rs"]
mod tests;
