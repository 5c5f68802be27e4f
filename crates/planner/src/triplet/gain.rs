//! M3's gain g(c3) of a candidate triplet, and the cheap upper bound that
//! skips triangles (and occlusion rays) the triplet cannot improve.

use nalgebra::{Matrix3, Point3};
use vp_scene::raycast::FACE_VISIBILITY_EPSILON;
use vp_scene::Camera;

use super::Search;
use crate::fulfillment::Fulfillment;
use crate::quality::CamTerm;

impl Search<'_> {
    /// g(c3) = sum over T seen by all three cameras of max(f(t, c3) - f(t), 0).
    ///
    /// # Performance
    /// Visibility is the M1 rule (in frustum, front-facing, unoccluded), but
    /// the occlusion rays, the only costly part, are cast last and only for
    /// triangles that would add a positive gain: most triangles fail the
    /// frustum test of some camera or are already as fulfilled as this
    /// triplet can make them. The sum is the same as testing every triangle.
    /// A triangle whose f(t, c3) provably cannot exceed f(t) is left out
    /// before its terms are computed ([`Search::cannot_gain`]).
    pub fn gain(&self, cams: &[Camera; 3]) -> f64 {
        self.gain_above(cams, f64::NEG_INFINITY).unwrap_or(0.0)
    }

    /// [`Search::gain`] when it may exceed `floor`: `None` only when
    /// g(c3) <= `floor`, found without casting the occlusion rays.
    ///
    /// The positive gains before the occlusion test, summed in the same
    /// order, bound g(c3) from above (a sum of a superset of non-negative
    /// terms rounds no lower), so a triplet whose bound is at most `floor`
    /// needs no ray. M3 passes the best gain found so far: on the first
    /// iteration most triplets of the later visits are below it.
    pub fn gain_above(&self, cams: &[Camera; 3], floor: f64) -> Option<f64> {
        let ful = self.ful;
        let centres = cams.map(|c| c.center());
        let bound_cams = BoundCams::new(cams, ful);
        let mut positive: Vec<(usize, f64)> = Vec::new();
        let mut upper = 0.0;
        for (i, &t) in self.selected.iter().enumerate() {
            if ful.observers[t].len() + 3 < ful.min_cameras {
                continue;
            }
            let p = self.selected_mesh.face_centroid(i);
            let n = self.selected_mesh.face_normal(i);
            let seen = |k: usize| cams[k].in_frustum(&p) && n.dot(&(p - centres[k])) < 0.0;
            if !(seen(0) && seen(1) && seen(2)) {
                continue;
            }
            let tri = &ful.tris[t];
            let f_t = ful.f(t);
            if self.cannot_gain(&bound_cams, t, f_t) {
                continue;
            }
            let terms = cams.map(|c| CamTerm::new(&c, &tri.centroid, &tri.normal, ful.sigma_px));
            let (f, _, _) = ful
                .req
                .fulfillment(&terms[0], &terms[1], &terms[2], &ful.curve[t]);
            let gain = f - f_t;
            if !(gain > 0.0) {
                continue;
            }
            upper += gain;
            positive.push((i, gain));
        }
        if upper <= floor {
            return None;
        }
        let mut g = 0.0;
        for (i, gain) in positive {
            let p = self.selected_mesh.face_centroid(i);
            let n = self.selected_mesh.face_normal(i);
            let target = p + n * FACE_VISIBILITY_EPSILON;
            if centres.iter().all(|c| !self.caster.occluded(c, &target)) {
                g += gain;
            }
        }
        Some(g)
    }

    /// True when f(t, c3) <= `f_t` for sampled triangle `t` seen by the
    /// triplet `cams`, from an upper bound that needs neither the
    /// information matrices nor their eigenvalue: f_res (all three
    /// resolutions, as [`CamTerm::new`] takes them), and f_unc bounded by
    /// the Rayleigh quotient of the summed information at the direction
    /// from t to the cameras' mean centre, `sum_i |J_i v|^2 / sigma^2`,
    /// plus a margin of 1e-9 of its trace (as
    /// [`Requirements::f_unc_bound_triplet`]). The relative slack of 1e-6
    /// covers the round-off of these terms against the exact ones and the
    /// f32 rounding of an interpolated confidence.
    ///
    /// # Performance
    /// After the first iterations most triangles a triplet sees are already
    /// better fulfilled than it can make them: this skips their three
    /// Jacobians and the closed-form eigenvalue (an arccosine and a cosine).
    ///
    /// [`Requirements::f_unc_bound_triplet`]: crate::quality::Requirements::f_unc_bound_triplet
    fn cannot_gain(&self, cams: &BoundCams, t: usize, f_t: f64) -> bool {
        const SLACK: f64 = 1.0 + 1e-6;
        let ful = self.ful;
        let req = &ful.req;
        if !(f_t > 0.0) || !cams.usable {
            return false;
        }
        let tri = &ful.tris[t];
        let (p, n) = (tri.centroid, tri.normal);
        let to_cam = cams.centres.map(|c| c - p);
        let mut r_min = f64::INFINITY;
        for (k, d) in to_cam.iter().enumerate() {
            let (d2, nd) = (d.norm_squared(), n.dot(d));
            let r = if nd > 0.0 && d2 > 0.0 {
                cams.f2[k] * nd / (d2 * d2.sqrt())
            } else {
                0.0
            };
            r_min = r_min.min(r);
        }
        let conf_max = ful.curve[t].max();
        let f_res = req.f_res(r_min);
        let bound = |f_unc: f64| (req.alpha * f_res + (1.0 - req.alpha) * f_unc) * conf_max;
        if bound(1.0) * SLACK <= f_t {
            return true;
        }
        let Some(v) = (cams.mean_centre - p).try_normalize(1e-12) else {
            return false;
        };
        let (mut quotient, mut trace) = (0.0, 0.0);
        for (k, d) in to_cam.iter().enumerate() {
            let pc = -(cams.cam_from_world[k] * d);
            if !(pc.z > 0.0) {
                return false;
            }
            let w = cams.cam_from_world[k] * v;
            let (fx, fy) = cams.fxy[k];
            let iz = 1.0 / pc.z;
            // J = D R with D the 2x3 derivative of the pinhole projection
            // in the camera frame; R is a rotation, so |J|_F = |D|_F.
            let (dxx, dxz) = (fx * iz, -fx * pc.x * iz * iz);
            let (dyy, dyz) = (fy * iz, -fy * pc.y * iz * iz);
            let (jx, jy) = (dxx * w.x + dxz * w.z, dyy * w.y + dyz * w.z);
            quotient += jx * jx + jy * jy;
            trace += dxx * dxx + dxz * dxz + dyy * dyy + dyz * dyz;
        }
        let (quotient, trace) = (quotient * cams.inv_s2, trace * cams.inv_s2);
        bound(req.f_unc_bound(quotient + 1e-9 * trace)) * SLACK <= f_t
    }
}

/// What [`Search::cannot_gain`] reads of a triplet, computed once per
/// [`Search::gain_above`].
struct BoundCams {
    centres: [Point3<f64>; 3],
    mean_centre: Point3<f64>,
    /// Rotation of each camera, world to camera frame, as a matrix.
    cam_from_world: [Matrix3<f64>; 3],
    /// `(fx, fy)` of each camera.
    fxy: [(f64, f64); 3],
    /// Square of each camera's focal length, as `Camera::resolution_at` takes it.
    f2: [f64; 3],
    /// `1 / sigma^2`.
    inv_s2: f64,
    /// False when the requirements are outside the ranges the bound
    /// assumes (alpha in [0, 1], a non-negative accuracy).
    usable: bool,
}

impl BoundCams {
    fn new(cams: &[Camera; 3], ful: &Fulfillment) -> Self {
        let centres = cams.map(|c| c.center());
        let req = &ful.req;
        BoundCams {
            centres,
            mean_centre: Point3::from(
                (centres[0].coords + centres[1].coords + centres[2].coords) / 3.0,
            ),
            cam_from_world: cams.map(|c| {
                *c.world_from_cam
                    .rotation
                    .inverse()
                    .to_rotation_matrix()
                    .matrix()
            }),
            fxy: cams.map(|c| (c.intrinsics.fx, c.intrinsics.fy)),
            f2: cams.map(|c| c.intrinsics.focal() * c.intrinsics.focal()),
            inv_s2: 1.0 / (ful.sigma_px * ful.sigma_px),
            usable: (0.0..=1.0).contains(&req.alpha) && req.accuracy >= 0.0,
        }
    }
}
