//! The per-triplet quality terms of M1 (f_res, f_unc, angle) on precomputed
//! per-camera data, shared by M1 (exact f(t)) and M3 (gains).

use nalgebra::{Matrix3, Point3, Vector3};
use vp_scene::raster::AngleBins;
use vp_scene::triangulation::{
    camera_information, largest_pairwise_angle_deg, smallest_eigenvalue,
};
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
        let info = camera_information(cam, p, sigma_px);
        CamTerm {
            r: cam.resolution_at(p, n),
            info,
            // J^T J has rank 2; its largest eigenvalue is at most its trace,
            // and for a pinhole camera close to it: the trace is a valid bound.
            info_max: info.trace(),
            dir: (cam.center() - p).normalize(),
        }
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

    /// Upper bound of `f_unc` of the triplet (a, b, c), tighter than the
    /// Weyl bound of [`Requirements::f_unc_bound`] where it matters.
    ///
    /// The smallest eigenvalue of the summed information is at most its
    /// Rayleigh quotient at any unit v; at the mean viewing direction that
    /// quotient is small exactly when the rays are close to parallel (small
    /// baselines, weak depth), where the Weyl bound is far too loose to
    /// prune. [`smallest_eigenvalue_bound`] tightens it further. A margin
    /// of 1e-9 of the trace covers the round-off of the closed-form
    /// eigenvalue, so the bound never prunes the true maximum.
    pub fn f_unc_bound_triplet(&self, a: &CamTerm, b: &CamTerm, c: &CamTerm) -> f64 {
        let Some(v) = (a.dir + b.dir + c.dir).try_normalize(1e-12) else {
            return 1.0;
        };
        let m = a.info + b.info + c.info;
        let bound = smallest_eigenvalue_bound(&m, v.dot(&(m * v)));
        self.f_unc_bound(bound + 1e-9 * m.trace().abs())
    }

    /// `alpha f_res + (1 - alpha) f_unc` of a triplet, and its triangulation
    /// angle (deg): the largest pairwise angle between the camera rays.
    pub fn score(&self, a: &CamTerm, b: &CamTerm, c: &CamTerm) -> (f64, f64) {
        (
            self.quality(a, b, c),
            largest_pairwise_angle_deg(&[a.dir, b.dir, c.dir]),
        )
    }

    /// `alpha f_res + (1 - alpha) f_unc` of a triplet: the first value of
    /// [`Requirements::score`], without the angle.
    pub fn quality(&self, a: &CamTerm, b: &CamTerm, c: &CamTerm) -> f64 {
        let r_min = a.r.min(b.r).min(c.r);
        self.alpha * self.f_res(r_min)
            + (1.0 - self.alpha) * self.f_unc(&(a.info + b.info + c.info))
    }

    /// `(q * f_conf(angle), q, f_conf(angle))` of a triplet with the
    /// confidence `curve`: the fulfillment f(t, c3) without f_cov, and its
    /// two factors.
    ///
    /// # Performance
    /// Without prediction every curve is constant, and the angle (an
    /// arccosine per triplet) is not computed: [`ConfCurve::at`] would
    /// return the constant bit for bit at any angle of cameras that see the
    /// point (a NaN angle needs a camera at the point itself).
    pub fn fulfillment(
        &self,
        a: &CamTerm,
        b: &CamTerm,
        c: &CamTerm,
        curve: &ConfCurve,
    ) -> (f64, f64, f64) {
        if let Some(conf) = curve.constant() {
            let q = self.quality(a, b, c);
            (q * conf, q, conf)
        } else {
            let (q, angle) = self.score(a, b, c);
            let conf = curve.at(&self.bins, angle);
            (q * conf, q, conf)
        }
    }
}

/// An upper bound of the smallest eigenvalue of the symmetric positive
/// semi-definite `m`, given one, `u` (a Rayleigh quotient): the zero of
/// the chord of the characteristic polynomial `p(x) = det(x I - m)` between
/// 0 and `u`, or `u` where that does not apply. Within the margin of
/// 1e-9 of the trace that its callers add, it is never below the closed-form
/// [`smallest_eigenvalue`] (tested).
///
/// `p` is negative below the smallest root and concave below `trace / 3`;
/// for `u` in `[lambda_1, trace / 3]` the chord lies below `p`, so where
/// it crosses zero `p` is not negative: at or above `lambda_1`. It is
/// `det / (u^2 - e1 u + e2)` (e1, e2 the first two invariants), and close
/// to `lambda_1` when the other two eigenvalues are much larger, which a
/// Rayleigh quotient alone is not (it carries their share of the
/// direction's error).
///
/// # Performance
/// About 30 multiplications: much cheaper than the arccosine and cosine of
/// the closed form, and tight enough that M1's triplet searches evaluate
/// little more than the triplets that raise the best value.
pub fn smallest_eigenvalue_bound(m: &Matrix3<f64>, u: f64) -> f64 {
    let e1 = m.trace();
    if !(u > 0.0 && 3.0 * u <= e1) {
        return u;
    }
    let e2 = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)] + m[(0, 0)] * m[(2, 2)]
        - m[(0, 2)] * m[(2, 0)]
        + m[(1, 1)] * m[(2, 2)]
        - m[(1, 2)] * m[(2, 1)];
    // (p(u) + det) / u. When it is tiny against e1^2 (two small
    // eigenvalues) the round-off of det / q could exceed the callers'
    // margin: keep u.
    let q = u * u - e1 * u + e2;
    if !(q > 1e-4 * e1 * e1) {
        return u;
    }
    (m.determinant() / q).min(u)
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

    /// The value at every angle when the curve is constant (no prediction,
    /// or a flat one), as [`ConfCurve::at`] returns it: `a + t (a - a)` is
    /// `a` bit for bit, except for `a = -0`, which is left out.
    pub fn constant(&self) -> Option<f64> {
        let first = *self.0.first()?;
        let flat = self.0.iter().all(|v| v.to_bits() == first.to_bits());
        (flat && first.to_bits() != (-0.0f32).to_bits()).then_some(f64::from(first))
    }

    /// Largest value: an upper bound of the confidence at any angle.
    pub fn max(&self) -> f64 {
        f64::from(self.0.iter().copied().fold(0.0f32, f32::max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use vp_scene::Intrinsics;

    /// The chord bound is a bound (with the callers' margin) of the
    /// closed-form smallest eigenvalue and never looser than the Rayleigh
    /// quotient it starts from: triplets from wide to nearly parallel
    /// rays, quotients at the mean ray and at random directions.
    #[test]
    fn chord_bound_is_between_the_eigenvalue_and_the_rayleigh_quotient() {
        let k = Intrinsics::new(1200, 800, 1800.0, 1800.0, 600.0, 400.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let mut tighter = 0;
        for trial in 0..3000 {
            let spread = [60.0, 10.0, 1.0, 0.05][trial % 4];
            let (az0, el0) = (rng.random_range(0f64..360.0), rng.random_range(20f64..85.0));
            let p = Point3::new(
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                0.0,
            );
            let terms: Vec<CamTerm> = (0..3)
                .map(|_| {
                    let az = (az0 + rng.random_range(-spread..=spread)).to_radians();
                    let el = (el0 + rng.random_range(-spread..=spread)).clamp(5.0, 89.0);
                    let el = el.to_radians();
                    let d: f64 = rng.random_range(10.0..120.0);
                    let c =
                        p + Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin()) * d;
                    let cam = Camera::look_at(k, c, p).unwrap();
                    CamTerm::new(&cam, &p, &Vector3::z(), 1.0)
                })
                .collect();
            let m = terms[0].info + terms[1].info + terms[2].info;
            let lmin = smallest_eigenvalue(&m);
            let mean = (terms[0].dir + terms[1].dir + terms[2].dir).normalize();
            let random = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            for v in [mean, random] {
                let u = v.dot(&(m * v));
                let b = smallest_eigenvalue_bound(&m, u);
                assert!(b <= u, "trial {trial}: {b} > {u}");
                assert!(
                    b + 1e-9 * m.trace() >= lmin,
                    "trial {trial}: {b} < {lmin} (u {u})"
                );
                tighter += usize::from(b < 0.5 * u);
            }
        }
        assert!(tighter > 500, "only {tighter} bounds tighter than u/2");
    }
}
