//! Triangulation geometry of a 3D point seen by a set of cameras: the
//! triangulation angle (DESIGN.md's definition) and the first-order 3D
//! uncertainty of the point.
//!
//! Nothing here is specific to simulation: labelgen and the planner's f_unc
//! need the same quantities. It lives in vp-sim until it moves to vp-scene.

use nalgebra::{Matrix3, Point3, Vector3};
use vp_scene::Camera;

/// Triangulation angle at `p` in degrees: the largest pairwise angle between
/// the rays from `p` to the camera centres. 0 for fewer than two centres or
/// when a centre coincides with `p`.
pub fn triangulation_angle_deg(p: &Point3<f64>, centres: &[Point3<f64>]) -> f64 {
    // No allocation: this runs once per pixel in the virtual MVS.
    let mut best: f64 = 0.0;
    for (i, a) in centres.iter().enumerate() {
        let Some(ra) = (a - p).try_normalize(0.0) else {
            continue;
        };
        for b in &centres[i + 1..] {
            if let Some(rb) = (b - p).try_normalize(0.0) {
                best = best.max(ra.angle(&rb));
            }
        }
    }
    best.to_degrees()
}

/// First-order covariance (m^2) of `p` triangulated from `cameras` with
/// isotropic pixel noise `sigma_px` in each image:
/// `Sigma = (sum_i J_i^T J_i / sigma_px^2)^-1`, J_i the 2x3 projection
/// Jacobian of camera i at `p` (DESIGN.md, f_unc). `None` when the normal
/// matrix is singular (fewer than two cameras, a camera behind `p`, or all
/// centres on one line through `p`).
pub fn point_covariance(
    cameras: &[&Camera],
    p: &Point3<f64>,
    sigma_px: f64,
) -> Option<Matrix3<f64>> {
    let mut normal = Matrix3::zeros();
    for cam in cameras {
        let z = cam.world_from_cam.inverse_transform_point(p).z;
        if !(z > 0.0) {
            return None;
        }
        let j = cam.projection_jacobian(p);
        normal += j.transpose() * j;
    }
    // Rank-deficient normal matrices (no baseline) rarely have an exactly
    // zero determinant in floating point: compare it with the scale of the
    // matrix instead (for a PSD matrix, det / trace^3 is tiny exactly when the
    // smallest eigenvalue is tiny against the largest). Cheaper than an
    // eigen-decomposition per pixel.
    let trace = normal.trace();
    if !(normal.determinant() > 1e-13 * trace * trace * trace) {
        return None;
    }
    Some(normal.try_inverse()? * (sigma_px * sigma_px))
}

/// Standard deviation (m) of `cov` along the unit direction `dir`.
pub fn sigma_along(cov: &Matrix3<f64>, dir: &Vector3<f64>) -> f64 {
    (dir.dot(&(cov * dir))).max(0.0).sqrt()
}

/// Largest standard deviation of `cov` (m): the square root of its largest
/// eigenvalue, the paper's 3D uncertainty `sqrt(u)`.
pub fn sigma_max(cov: &Matrix3<f64>) -> f64 {
    cov.symmetric_eigenvalues().max().max(0.0).sqrt()
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
/// [`point_covariance`]).
pub fn point_geometry(
    cameras: &[&Camera],
    query: &Camera,
    p: &Point3<f64>,
    sigma_px: f64,
) -> Option<PointGeometry> {
    let cov = point_covariance(cameras, p, sigma_px)?;
    let centres: Vec<Point3<f64>> = cameras.iter().map(|c| c.center()).collect();
    let ray = (p - query.center()).try_normalize(0.0)?;
    let sigma_ray = sigma_along(&cov, &ray);
    Some(PointGeometry {
        angle_deg: triangulation_angle_deg(p, &centres),
        sigma_ray,
        sigma_depth: sigma_ray * ray.dot(&query.axis()).abs(),
        sigma_max: sigma_max(&cov),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use vp_scene::Intrinsics;

    fn cam_at(c: Point3<f64>) -> Camera {
        let k = Intrinsics::from_hfov(400, 300, 60.0).unwrap();
        Camera::look_at(k, c, Point3::new(0.0, 0.0, 0.0)).unwrap()
    }

    #[test]
    fn angle_is_largest_pairwise_angle() {
        let p = Point3::origin();
        let cs = [
            Point3::new(10.0, 0.0, 10.0),
            Point3::new(-10.0, 0.0, 10.0),
            Point3::new(0.0, 0.0, 10.0),
        ];
        assert!((triangulation_angle_deg(&p, &cs) - 90.0).abs() < 1e-9);
        assert!(triangulation_angle_deg(&p, &cs[..1]).abs() < 1e-12);
    }

    #[test]
    fn uncertainty_grows_with_distance_and_shrinks_with_baseline() {
        let p = Point3::new(0.0, 0.0, 0.0);
        let triplet = |d: f64, b: f64| {
            [
                cam_at(Point3::new(b, 0.1, d)),
                cam_at(Point3::new(-b, 0.2, d)),
                cam_at(Point3::new(0.0, b, d)),
            ]
        };
        let g = |d, b| {
            let t = triplet(d, b);
            let refs: Vec<&Camera> = t.iter().collect();
            point_geometry(&refs, &t[0], &p, 1.0).unwrap()
        };
        let near = g(20.0, 5.0);
        let far = g(40.0, 5.0);
        let wide = g(20.0, 10.0);
        assert!(far.sigma_ray > 3.0 * near.sigma_ray);
        assert!(wide.sigma_ray < near.sigma_ray);
        assert!(near.sigma_max >= near.sigma_ray);
        // Two cameras at the same spot cannot triangulate.
        let c = cam_at(Point3::new(0.0, 5.0, 20.0));
        assert!(point_covariance(&[&c, &c], &p, 1.0).is_none());
    }
}
