//! The plane-induced homography that carries a reference pixel into a
//! source image: the warp every window sum follows (see `cost.rs`).

use crate::view::Relative;

/// The plane-induced homography from reference to source pixel
/// coordinates, `H = K_s (R - t n^T / dist) K_r^-1` for the plane with unit
/// normal `n` at distance `dist` from the reference centre, split into
/// what depends on the camera pair only, `A = K_s R K_r^-1` and
/// `b = K_s t` (computed once per pair and level), and what depends on the
/// plane only, `m = n^T K_r^-1 / dist` ([`plane_row`], once per hypothesis
/// for every source): then `H = A - b m^T`, nine multiply-adds per source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PairWarp {
    a: [f32; 9],
    b: [f32; 3],
}

impl PairWarp {
    /// The pair's part, for reference intrinsics `kr` (`[fx, fy, cx, cy]`).
    pub(crate) fn new(rel: &Relative, kr: &[f32; 4]) -> Self {
        let (r, t, ks) = (&rel.rot, &rel.trans, &rel.k);
        let f = |x: f32| f64::from(x);
        // Rows of K_s applied to a column c: (fx c0 + cx c2, fy c1 + cy c2, c2).
        let ks_col = |c: [f64; 3]| {
            [
                f(ks[0]) * c[0] + f(ks[2]) * c[2],
                f(ks[1]) * c[1] + f(ks[3]) * c[2],
                c[2],
            ]
        };
        // K_r^-1's columns: (1/fx, 0, 0), (0, 1/fy, 0), (-cx/fx, -cy/fy, 1).
        let kinv = [
            [1.0 / f(kr[0]), 0.0, 0.0],
            [0.0, 1.0 / f(kr[1]), 0.0],
            [-f(kr[2]) / f(kr[0]), -f(kr[3]) / f(kr[1]), 1.0],
        ];
        let mut a = [0.0f32; 9];
        for (j, col) in kinv.iter().enumerate() {
            let rc: [f64; 3] =
                std::array::from_fn(|i| (0..3).map(|k| f(r[i][k]) * col[k]).sum::<f64>());
            let c = ks_col(rc);
            for i in 0..3 {
                a[3 * i + j] = c[i] as f32;
            }
        }
        let b = ks_col([f(t[0]), f(t[1]), f(t[2])]).map(|x| x as f32);
        PairWarp { a, b }
    }

    /// Row-major 3x3 homography of the plane whose [`plane_row`] is `m`.
    #[inline]
    pub(crate) fn homography(&self, m: &[f32; 3]) -> [f32; 9] {
        std::array::from_fn(|k| self.a[k] - self.b[k / 3] * m[k % 3])
    }
}

/// The plane's part of the homography, `n^T K_r^-1 / dist`, for the plane
/// through `d * ray` with unit normal `n` (reference camera frame, `kr` the
/// reference intrinsics); `None` when the plane passes through (or behind)
/// the reference centre.
#[inline]
pub(crate) fn plane_row(kr: &[f32; 4], d: f32, n: &[f32; 3], ray: &[f32; 3]) -> Option<[f32; 3]> {
    let dist = -(n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2]) * d;
    if !(dist > 0.0) {
        return None;
    }
    let inv = 1.0 / dist;
    let (mx, my) = (n[0] / kr[0], n[1] / kr[1]);
    Some([mx * inv, my * inv, (n[2] - mx * kr[2] - my * kr[3]) * inv])
}
