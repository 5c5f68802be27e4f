//! Photo-consistency: bilaterally weighted NCC over a sparse window, warped
//! into each source through the plane-induced homography, aggregated over
//! the sources with a best-k view selection.

use crate::params::MvsParams;
use crate::view::{GreyImage, Relative};

/// Cost of a hypothesis that cannot be scored (out of the source image,
/// behind a camera, textureless): the worst NCC cost, 1 - (-1).
pub(crate) const MAX_COST: f32 = 2.0;

/// Smallest weighted variance (grey levels in [0, 1], times the weight sum)
/// that counts as texture.
const MIN_VARIANCE: f32 = 1e-6;

/// The reference side of the NCC at one pixel: the window samples that fall
/// inside the image, their bilateral weights and their weighted-mean-free
/// intensities. Built once per pixel and iteration, shared by every
/// hypothesis scored there.
#[derive(Debug, Default)]
pub(crate) struct RefPatch {
    pub dx: Vec<f32>,
    pub dy: Vec<f32>,
    pub w: Vec<f32>,
    /// Intensity minus the weighted mean.
    pub r: Vec<f32>,
    pub sum_w: f32,
    /// Sum of w * r^2.
    pub var: f32,
}

impl RefPatch {
    /// Fills the patch of pixel (x, y) of `image`.
    pub fn build(
        &mut self,
        image: &GreyImage,
        x: usize,
        y: usize,
        offsets: &[i32],
        params: &MvsParams,
    ) {
        self.dx.clear();
        self.dy.clear();
        self.w.clear();
        self.r.clear();
        let (xi, yi) = (x as i32, y as i32);
        let Some(centre) = image.at(xi, yi) else {
            self.sum_w = 0.0;
            self.var = 0.0;
            return;
        };
        let inv_s = 1.0 / (2.0 * params.sigma_spatial * params.sigma_spatial);
        let inv_c = 1.0 / (2.0 * params.sigma_color * params.sigma_color);
        let (mut sw, mut swr) = (0.0f32, 0.0f32);
        for &oy in offsets {
            for &ox in offsets {
                let Some(v) = image.at(xi + ox, yi + oy) else {
                    continue;
                };
                let dist2 = (ox * ox + oy * oy) as f32;
                let dc = v - centre;
                let w = (-dist2 * inv_s - dc * dc * inv_c).exp();
                self.dx.push(ox as f32);
                self.dy.push(oy as f32);
                self.w.push(w);
                self.r.push(v);
                sw += w;
                swr += w * v;
            }
        }
        let mean = swr / sw;
        let mut var = 0.0;
        for (r, &w) in self.r.iter_mut().zip(&self.w) {
            *r -= mean;
            var += w * *r * *r;
        }
        self.sum_w = sw;
        self.var = var;
    }

    /// Whether the patch has texture enough to score anything.
    pub fn textured(&self) -> bool {
        self.var > MIN_VARIANCE * self.sum_w
    }
}

/// Row-major 3x3 homography from reference to source pixel coordinates
/// induced by the plane through `d * ray` with unit normal `n` (reference
/// camera frame): `H = K_s (R - t n^T / dist) K_r^-1`, dist the plane's
/// distance from the reference centre. `None` when the plane passes through
/// (or behind) the reference centre.
#[inline]
pub(crate) fn homography(
    rel: &Relative,
    kr: &[f32; 4],
    d: f32,
    n: &[f32; 3],
    ray: &[f32; 3],
) -> Option<[f32; 9]> {
    let dist = -(n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2]) * d;
    if !(dist > 0.0) {
        return None;
    }
    let inv = 1.0 / dist;
    let (r, t, ks) = (&rel.rot, &rel.trans, &rel.k);
    // M = R - t n^T / dist
    let mut m = [[0.0f32; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = r[i][j] - t[i] * n[j] * inv;
        }
    }
    // K_s M
    let a: [[f32; 3]; 3] = [
        std::array::from_fn(|j| ks[0] * m[0][j] + ks[2] * m[2][j]),
        std::array::from_fn(|j| ks[1] * m[1][j] + ks[3] * m[2][j]),
        m[2],
    ];
    // (K_s M) K_r^-1
    let (ifx, ify) = (1.0 / kr[0], 1.0 / kr[1]);
    let mut h = [0.0f32; 9];
    for i in 0..3 {
        h[3 * i] = a[i][0] * ifx;
        h[3 * i + 1] = a[i][1] * ify;
        h[3 * i + 2] = a[i][2] - a[i][0] * kr[2] * ifx - a[i][1] * kr[3] * ify;
    }
    Some(h)
}

/// 1 - weighted NCC between the reference patch at continuous pixel
/// (u, v) and the source image warped by `h`; [`MAX_COST`] when a sample
/// leaves the source image or the source patch is flat.
///
/// # Performance
/// The hot loop of the whole MVS: per sample one homography step (the
/// projective division included), one bilinear tap and three weighted sums.
#[inline]
pub(crate) fn source_cost(patch: &RefPatch, u: f32, v: f32, h: &[f32; 9], src: &GreyImage) -> f32 {
    let hp = [
        h[0] * u + h[1] * v + h[2],
        h[3] * u + h[4] * v + h[5],
        h[6] * u + h[7] * v + h[8],
    ];
    let (mut s1, mut s2, mut sr) = (0.0f32, 0.0f32, 0.0f32);
    for i in 0..patch.w.len() {
        let (dx, dy) = (patch.dx[i], patch.dy[i]);
        let z = hp[2] + h[6] * dx + h[7] * dy;
        if !(z > 0.0) {
            return MAX_COST;
        }
        let iz = 1.0 / z;
        let x = (hp[0] + h[0] * dx + h[1] * dy) * iz;
        let y = (hp[1] + h[3] * dx + h[4] * dy) * iz;
        let Some(s) = src.sample(x, y) else {
            return MAX_COST;
        };
        let w = patch.w[i];
        let ws = w * s;
        s1 += ws;
        s2 += ws * s;
        sr += patch.r[i] * ws;
    }
    let var_s = s2 - s1 * s1 / patch.sum_w;
    if !(var_s > MIN_VARIANCE * patch.sum_w) {
        return MAX_COST;
    }
    let ncc = sr / (patch.var * var_s).sqrt();
    (1.0 - ncc).clamp(0.0, MAX_COST)
}

/// View selection: the means of the `k` smallest costs (all of them when
/// fewer), ranked by the first of each pair; returns (mean of the firsts,
/// mean of the seconds). Sorts `costs` in place.
#[inline]
pub(crate) fn aggregate(costs: &mut [(f32, f32)], k: usize) -> (f32, f32) {
    costs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let k = k.min(costs.len()).max(1);
    let (a, b) = costs[..k]
        .iter()
        .fold((0.0, 0.0), |s, c| (s.0 + c.0, s.1 + c.1));
    (a / k as f32, b / k as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
    use vp_scene::{Camera, Intrinsics};

    #[test]
    fn homography_maps_plane_points_like_projection() {
        let k = Intrinsics {
            width: 100,
            height: 80,
            fx: 90.0,
            fy: 95.0,
            cx: 50.0,
            cy: 40.0,
        };
        let reference = Camera::new(k, Isometry3::identity());
        let source = Camera::new(
            k,
            Isometry3::from_parts(
                Translation3::new(1.0, -0.3, 0.2),
                UnitQuaternion::from_euler_angles(0.05, -0.1, 0.02),
            ),
        );
        let rel = Relative::new(&reference, &source);
        let kr = crate::view::k_of(&reference);
        // Plane through depth 10 at pixel (30, 20), tilted.
        let n = nalgebra::Vector3::new(0.2, -0.3, -1.0).normalize();
        let nf = [n.x as f32, n.y as f32, n.z as f32];
        let ray = crate::view::pixel_ray(&kr, 30, 20);
        let h = homography(&rel, &kr, 10.0, &nf, &ray).unwrap();
        let x0 = nalgebra::Vector3::new(f64::from(ray[0]), f64::from(ray[1]), 1.0) * 10.0;
        // Another pixel: intersect its ray with the plane, project it.
        let (u, v) = (70.5f64, 60.5f64);
        let r2 = nalgebra::Vector3::new((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
        let t = n.dot(&x0) / n.dot(&r2);
        let p = Point3::from(r2 * t);
        let expected = source.project(&p).unwrap();
        let z = h[6] * u as f32 + h[7] * v as f32 + h[8];
        let got = (
            (h[0] * u as f32 + h[1] * v as f32 + h[2]) / z,
            (h[3] * u as f32 + h[4] * v as f32 + h[5]) / z,
        );
        assert!(
            (f64::from(got.0) - expected.x).abs() < 1e-2,
            "{got:?} {expected}"
        );
        assert!(
            (f64::from(got.1) - expected.y).abs() < 1e-2,
            "{got:?} {expected}"
        );
    }

    #[test]
    fn aggregate_averages_the_best_k() {
        assert_eq!(
            aggregate(&mut [(0.5, 0.5), (0.1, 0.0), (2.0, 1.0)], 2),
            (0.3, 0.25)
        );
        assert_eq!(aggregate(&mut [(0.5, 0.2)], 3), (0.5, 0.2));
    }
}
