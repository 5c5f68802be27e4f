//! The per-triplet quality terms of M1 (f_res, f_unc, angle) on precomputed
//! per-camera data, shared by M1 (exact f(t)) and M3 (gains).

use nalgebra::{Matrix3, Point3, Vector3};
use vp_scene::raster::AngleBins;
use vp_scene::Camera;

/// What one camera contributes to a triangle's quality, precomputed once.
#[derive(Debug, Clone, Copy)]
pub struct CamTerm {
    /// r_i: pixels per square metre of surface (f_res).
    pub r: f64,
    /// J_i^T J_i / sigma^2: Fisher information of the point from this camera.
    pub info: Matrix3<f64>,
    /// Largest eigenvalue of `info` (for pruning bounds).
    pub info_max: f64,
    /// Unit direction from the point to the camera centre.
    pub dir: Vector3<f64>,
}

impl CamTerm {
    /// Terms of a real camera at point `p` with unit normal `n`.
    pub fn new(cam: &Camera, p: &Point3<f64>, n: &Vector3<f64>, sigma_px: f64) -> Self {
        let j = cam.projection_jacobian(p);
        let info = j.transpose() * j / (sigma_px * sigma_px);
        Self::from_info(cam.resolution_at(p, n), info, &(cam.center() - p))
    }

    fn from_info(r: f64, info: Matrix3<f64>, to_cam: &Vector3<f64>) -> Self {
        // J^T J has rank 2; its largest eigenvalue is at most its trace,
        // and for a pinhole camera close to it: the trace is a valid bound.
        let info_max = info.trace();
        CamTerm {
            r,
            info,
            info_max,
            dir: to_cam.normalize(),
        }
    }

    /// Terms of a hypothetical camera at `c` with focal length `f` px looking
    /// straight at `p` (M3 potential gains): on the optical axis the
    /// information is `(f / d)^2 (I - u u^T) / sigma^2`.
    pub fn looking_at(
        c: &Point3<f64>,
        f: f64,
        p: &Point3<f64>,
        n: &Vector3<f64>,
        sigma_px: f64,
    ) -> Self {
        let to = c - p;
        let d2 = to.norm_squared();
        let u = to / d2.sqrt();
        let cos = n.dot(&u);
        let r = if cos > 0.0 { f * f * cos / d2 } else { 0.0 };
        let info = (Matrix3::identity() - u * u.transpose()) * (f * f / d2 / (sigma_px * sigma_px));
        Self::from_info(r, info, &to)
    }
}

/// Quality requirements and bins needed to score triplets.
#[derive(Debug, Clone)]
pub struct Requirements {
    /// r_d = 1 / gsd_d^2, px/m^2.
    pub r_desired: f64,
    /// a_d, metres.
    pub accuracy: f64,
    /// alpha.
    pub alpha: f64,
    /// The angle bins of the confidence curves.
    pub bins: AngleBins,
}

impl Requirements {
    /// f_res of a set of cameras: the coarsest one decides.
    pub fn f_res(&self, r_min: f64) -> f64 {
        (r_min / self.r_desired).min(1.0)
    }

    /// f_unc from the summed information: `min(1, a_d / sqrt(u))`, u the
    /// largest eigenvalue of the covariance = 1 / smallest eigenvalue of the
    /// information matrix.
    pub fn f_unc(&self, info: &Matrix3<f64>) -> f64 {
        let lmin = smallest_eigenvalue(info);
        if !(lmin > 0.0) {
            return 0.0;
        }
        (self.accuracy * lmin.sqrt()).min(1.0)
    }

    /// Upper bound of f_unc for a summed information whose smallest
    /// eigenvalue is at most `lmin_bound` (Weyl's inequality).
    pub fn f_unc_bound(&self, lmin_bound: f64) -> f64 {
        (self.accuracy * lmin_bound.max(0.0).sqrt()).min(1.0)
    }

    /// `alpha f_res + (1 - alpha) f_unc` of a triplet, and its triangulation
    /// angle (deg): the largest pairwise angle between the camera rays.
    pub fn score(&self, a: &CamTerm, b: &CamTerm, c: &CamTerm) -> (f64, f64) {
        let r_min = a.r.min(b.r).min(c.r);
        let q = self.alpha * self.f_res(r_min)
            + (1.0 - self.alpha) * self.f_unc(&(a.info + b.info + c.info));
        (q, triplet_angle_deg(&a.dir, &b.dir, &c.dir))
    }
}

/// Smallest eigenvalue of a symmetric 3x3 matrix, in closed form
/// (trigonometric solution of the characteristic cubic; O. K. Smith 1961).
///
/// # Performance
/// About ten times faster than an iterative decomposition; f_unc calls it
/// for every triplet M1 and M3 score.
pub fn smallest_eigenvalue(a: &Matrix3<f64>) -> f64 {
    let p1 = a[(0, 1)].powi(2) + a[(0, 2)].powi(2) + a[(1, 2)].powi(2);
    if p1 == 0.0 {
        return a[(0, 0)].min(a[(1, 1)]).min(a[(2, 2)]);
    }
    let q = a.trace() / 3.0;
    let p2 = (a[(0, 0)] - q).powi(2) + (a[(1, 1)] - q).powi(2) + (a[(2, 2)] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let b = (a - Matrix3::identity() * q) / p;
    let r = (0.5 * b.determinant()).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos()
}

/// Largest pairwise angle between three unit directions, degrees.
pub fn triplet_angle_deg(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> f64 {
    let min_dot = a.dot(b).min(a.dot(c)).min(b.dot(c));
    min_dot.clamp(-1.0, 1.0).acos().to_degrees()
}

/// A triangle's confidence as a function of the triangulation angle: b
/// per-bin values at the triangle's pixel, interpolated linearly between bin
/// centres (the same as `ConfidenceImage::sample`, whose bilinear pixel and
/// linear angle interpolations commute).
#[derive(Debug, Clone, PartialEq)]
pub struct ConfCurve(pub Vec<f32>);

impl ConfCurve {
    /// Confidence 1 at every angle (no prediction, the paper's NP).
    pub fn one(bins: &AngleBins) -> Self {
        ConfCurve(vec![1.0; bins.len()])
    }

    /// Sampled at `px` of a confidence image, one value per bin centre.
    pub fn sample(
        image: &vp_scene::raster::ConfidenceImage,
        px: (f64, f64),
        bins: &AngleBins,
    ) -> Self {
        ConfCurve(
            (0..bins.len())
                .map(|i| image.sample(px, f64::from(bins.centre(i))).clamp(0.0, 1.0))
                .collect(),
        )
    }

    /// Confidence at `angle_deg`.
    pub fn at(&self, bins: &AngleBins, angle_deg: f64) -> f64 {
        f64::from(bins.interpolate(&self.0, angle_deg))
    }

    /// Largest value: an upper bound of the confidence at any angle.
    pub fn max(&self) -> f64 {
        f64::from(self.0.iter().copied().fold(0.0f32, f32::max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_eigenvalue_matches_decomposition() {
        let mats = [
            Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 1.0),
            Matrix3::new(2.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 1.5),
            // Rank 2 plus a little, like a sum of camera informations.
            Matrix3::new(1e8, 2e7, 0.0, 2e7, 5e7, 1e3, 0.0, 1e3, 1e4),
        ];
        for m in mats {
            let want = m
                .symmetric_eigenvalues()
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min);
            let got = smallest_eigenvalue(&m);
            assert!((got - want).abs() <= 1e-9 * m.norm(), "{got} vs {want}");
        }
    }
}
