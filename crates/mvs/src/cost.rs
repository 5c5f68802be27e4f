//! Photo-consistency: bilaterally weighted NCC over a sparse window, warped
//! into each source through the plane-induced homography, aggregated over
//! the sources with a best-k view selection.

use crate::params::MvsParams;
use crate::simd::{Avx2, FullWindow};
use crate::view::{GreyImage, Relative};

/// Cost of a hypothesis that cannot be scored (out of the source image,
/// behind a camera, textureless): the worst NCC cost, 1 - (-1).
pub(crate) const MAX_COST: f32 = 2.0;

/// Smallest weighted variance (grey levels in [0, 1], times the weight sum)
/// that counts as texture.
const MIN_VARIANCE: f32 = 1e-6;

/// Distance (pixels) the corners of a warped window keep from the source
/// image's border in the fast path, so that rounding between the corner
/// test and the interior samples cannot step outside.
const EDGE_MARGIN: f32 = 1e-3;

/// Source images this wide or high are scored by the reference loop: the
/// fast one's [`floor_small`] needs coordinates below 2^22.
const FLOOR_SMALL_LIMIT: u32 = 1 << 22;

/// Samples of a window row whose coordinates are computed together.
pub(crate) const CHUNK: usize = 8;

/// The sparse matching window, fixed for a run: the sample offsets along
/// one axis and the spatial half of the bilateral weights, computed once
/// instead of once per pixel.
#[derive(Debug, Clone)]
pub(crate) struct Window {
    /// Offsets along one axis: `-r, -r + step, ..., <= r`.
    pub offsets: Vec<i32>,
    /// `exp(-(dx^2 + dy^2) / (2 sigma_s^2))`, row-major over the grid.
    spatial: Vec<f32>,
    /// `1 / (2 sigma_c^2)`.
    inv_color: f32,
    /// Offset of each lane of a padded window row from the row's first
    /// sample, `i * step` for `i` in `0..stride`.
    lanes: Vec<f32>,
    /// The AVX2 sums, when the CPU has AVX2 (detected once per run).
    avx2: Option<Avx2>,
}

impl Window {
    pub fn new(params: &MvsParams) -> Self {
        let offsets = params.window_offsets();
        let inv_s = 1.0 / (2.0 * params.sigma_spatial * params.sigma_spatial);
        let spatial = offsets
            .iter()
            .flat_map(|&oy| {
                offsets
                    .iter()
                    .map(move |&ox| (-((ox * ox + oy * oy) as f32) * inv_s).exp())
            })
            .collect();
        let step = offsets.get(1).map_or(1, |&o| o - offsets[0]) as f32;
        let stride = offsets.len().div_ceil(CHUNK) * CHUNK;
        Window {
            offsets,
            spatial,
            inv_color: 1.0 / (2.0 * params.sigma_color * params.sigma_color),
            lanes: (0..stride).map(|i| i as f32 * step).collect(),
            avx2: Avx2::detect(),
        }
    }

    /// Samples along one axis.
    #[inline]
    pub fn n(&self) -> usize {
        self.offsets.len()
    }

    /// Samples stored per window row in a full patch: the row padded to
    /// whole chunks of [`CHUNK`] with zero weights.
    #[inline]
    pub fn stride(&self) -> usize {
        self.n().div_ceil(CHUNK) * CHUNK
    }

    fn first(&self) -> i32 {
        self.offsets[0]
    }

    fn last(&self) -> i32 {
        self.offsets[self.offsets.len() - 1]
    }

    fn step(&self) -> f32 {
        self.offsets
            .get(1)
            .map_or(1.0, |&o| (o - self.offsets[0]) as f32)
    }
}

/// The reference side of the NCC at one pixel: the window samples that fall
/// inside the image, their bilateral weights and their weighted-mean-free
/// intensities (times the weight). Built once per pixel and iteration,
/// shared by every hypothesis and source scored there; the vectors are
/// reused from pixel to pixel, so the hot loop allocates nothing.
#[derive(Debug, Default)]
pub(crate) struct RefPatch {
    /// Sample offsets; filled only for a window cut by the image border.
    dx: Vec<f32>,
    dy: Vec<f32>,
    /// Bilateral weight of each sample.
    w: Vec<f32>,
    /// Weight times (intensity minus the weighted mean).
    wr: Vec<f32>,
    sum_w: f32,
    /// Sum of w * (intensity - mean)^2.
    var: f32,
    /// Whether every sample of the window lies inside the image: then the
    /// samples are the full grid, row-major, each row padded to
    /// [`Window::stride`] with zero weights, and a source is scored by the
    /// incremental fast path ([`source_cost`]).
    full: bool,
}

impl RefPatch {
    /// Fills the patch of pixel (x, y) of `image`.
    pub fn build(&mut self, image: &GreyImage, x: usize, y: usize, win: &Window) {
        self.dx.clear();
        self.dy.clear();
        self.w.clear();
        self.wr.clear();
        self.sum_w = 0.0;
        self.var = 0.0;
        let (xi, yi) = (x as i32, y as i32);
        let Some(centre) = image.at(xi, yi) else {
            self.full = false;
            return;
        };
        let (iw, ih) = (image.width as i32, image.height as i32);
        self.full = xi + win.first() >= 0
            && yi + win.first() >= 0
            && xi + win.last() < iw
            && yi + win.last() < ih;
        let mut sw = 0.0f32;
        let mut swv = 0.0f32;
        if self.full {
            let w = image.width as usize;
            let pad = win.stride() - win.n();
            let mut k = 0;
            for &oy in &win.offsets {
                let row = &image.data[(yi + oy) as usize * w..][..w];
                for &ox in &win.offsets {
                    let v = row[(xi + ox) as usize];
                    let dc = v - centre;
                    let wt = win.spatial[k] * (-dc * dc * win.inv_color).exp();
                    // `wr` holds the intensity until the mean is known.
                    self.w.push(wt);
                    self.wr.push(v);
                    sw += wt;
                    swv += wt * v;
                    k += 1;
                }
                for _ in 0..pad {
                    self.w.push(0.0);
                    self.wr.push(0.0);
                }
            }
        } else {
            let mut k = 0;
            for &oy in &win.offsets {
                for &ox in &win.offsets {
                    k += 1;
                    let Some(v) = image.at(xi + ox, yi + oy) else {
                        continue;
                    };
                    let dc = v - centre;
                    let wt = win.spatial[k - 1] * (-dc * dc * win.inv_color).exp();
                    self.dx.push(ox as f32);
                    self.dy.push(oy as f32);
                    self.w.push(wt);
                    self.wr.push(v);
                    sw += wt;
                    swv += wt * v;
                }
            }
        }
        let mean = swv / sw;
        let mut var = 0.0;
        for (wr, &wt) in self.wr.iter_mut().zip(&self.w) {
            let r = *wr - mean;
            var += wt * r * r;
            *wr = wt * r;
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
/// The hot loop of the whole MVS: per sample one projective division, one
/// bilinear tap and three weighted sums. For a window inside the reference
/// image (nearly every pixel) the warped window is tested once, at its four
/// corners (the homography maps the square grid into the convex hull of the
/// corners' images when the plane is in front of both cameras there), and
/// the homography is evaluated row by row from the first sample, without a
/// per-sample bounds test.
#[inline]
pub(crate) fn source_cost(
    patch: &RefPatch,
    win: &Window,
    u: f32,
    v: f32,
    h: &[f32; 9],
    src: &GreyImage,
) -> f32 {
    let sums = if patch.full {
        sums_full(patch, win, u, v, h, src)
    } else {
        sums_partial(patch, u, v, h, src)
    };
    let Some((s1, s2, sr)) = sums else {
        return MAX_COST;
    };
    let var_s = s2 - s1 * s1 / patch.sum_w;
    if !(var_s > MIN_VARIANCE * patch.sum_w) {
        return MAX_COST;
    }
    let ncc = sr / (patch.var * var_s).sqrt();
    (1.0 - ncc).clamp(0.0, MAX_COST)
}

/// The homogeneous source coordinates of the window's first sample, if
/// all four warped corners of the window land inside `src` (then, the
/// homography being projective and the window convex, every sample does);
/// `None` if a corner falls outside or behind the source camera.
#[inline]
fn warped_origin(win: &Window, u: f32, v: f32, h: &[f32; 9], src: &GreyImage) -> Option<[f32; 3]> {
    let o0 = win.first() as f32;
    let (u0, v0) = (u + o0, v + o0);
    let a0 = h[0] * u0 + h[1] * v0 + h[2];
    let b0 = h[3] * u0 + h[4] * v0 + h[5];
    let c0 = h[6] * u0 + h[7] * v0 + h[8];
    let span = (win.last() - win.first()) as f32;
    let x_max = src.width as f32 - 0.5 - EDGE_MARGIN;
    let y_max = src.height as f32 - 0.5 - EDGE_MARGIN;
    for (cx, cy) in [(0.0, 0.0), (span, 0.0), (0.0, span), (span, span)] {
        let z = c0 + h[6] * cx + h[7] * cy;
        if !(z > 0.0) {
            return None;
        }
        let x = (a0 + h[0] * cx + h[1] * cy) / z;
        let y = (b0 + h[3] * cx + h[4] * cy) / z;
        if !(x >= 0.5 + EDGE_MARGIN && y >= 0.5 + EDGE_MARGIN && x < x_max && y < y_max) {
            return None;
        }
    }
    Some([a0, b0, c0])
}

/// Weighted sums (w s, w s^2, w r s) over the full window grid.
///
/// Bit for bit the sums of the straightforward loop
/// ([`sums_full_reference`]): every sample goes through the same operations
/// in the same order, and each lane adds up the same samples. What changed is the
/// machine code around them: the lanes' offsets come from the window
/// instead of being recomputed, the window rows are walked with fixed-size
/// arrays (no run-time chunking, whose iterator set-up with two integer
/// divisions ran once per row), and the float-to-integer casts are done
/// for the whole chunk at once, with float and integer arithmetic, so that
/// they vectorise.
#[inline]
fn sums_full(
    patch: &RefPatch,
    win: &Window,
    u: f32,
    v: f32,
    h: &[f32; 9],
    src: &GreyImage,
) -> Option<(f32, f32, f32)> {
    let (n, step) = (win.n(), win.step());
    let [a0, b0, c0] = warped_origin(win, u, v, h, src)?;
    if src.width >= FLOOR_SMALL_LIMIT || src.height >= FLOOR_SMALL_LIMIT {
        return sums_full_reference(patch, win, u, v, h, src);
    }
    if let Some(avx2) = win.avx2 {
        let lanes = avx2.sums_full(&FullWindow {
            w: &patch.w,
            wr: &patch.wr,
            lanes: &win.lanes,
            n,
            stride: win.stride(),
            step,
            origin: [a0, b0, c0],
            h,
            data: &src.data,
            width: src.width as usize,
        });
        if let Some([s1, s2, sr]) = lanes {
            return Some((lane_total(s1), lane_total(s2), lane_total(sr)));
        }
    }
    let sw = src.width as usize;
    let data = &src.data[..];
    // One partial sum per lane: the adds of neighbouring samples do not
    // wait on each other, and the lane loops vectorise.
    let (mut s1, mut s2, mut sr) = ([0.0f32; CHUNK], [0.0f32; CHUNK], [0.0f32; CHUNK]);
    let chunks = win.stride() / CHUNK;
    for j in 0..n {
        let fj = j as f32 * step;
        let (ra, rb, rc) = (a0 + h[1] * fj, b0 + h[4] * fj, c0 + h[7] * fj);
        for c in 0..chunks {
            let first = c * CHUNK;
            let at = j * win.stride() + first;
            let (Ok(w), Ok(wr), Ok(fi)) = (
                <&[f32; CHUNK]>::try_from(&patch.w[at..at + CHUNK]),
                <&[f32; CHUNK]>::try_from(&patch.wr[at..at + CHUNK]),
                <&[f32; CHUNK]>::try_from(&win.lanes[first..first + CHUNK]),
            ) else {
                unreachable!("slices of CHUNK elements")
            };
            // Coordinates, cells and fractions of the whole chunk
            // (branch-free, so that they vectorise); lanes past the row's
            // end are computed but unused.
            let (mut x0, mut y0) = ([0i32; CHUNK], [0i32; CHUNK]);
            let mut ax = [0.0f32; CHUNK];
            let mut ay = [0.0f32; CHUNK];
            for i in 0..CHUNK {
                let iz = 1.0 / (rc + h[6] * fi[i]);
                let fx = (ra + h[0] * fi[i]) * iz - 0.5;
                let fy = (rb + h[3] * fi[i]) * iz - 0.5;
                let (xf, xi) = floor_small(fx);
                let (yf, yi) = floor_small(fy);
                (x0[i], y0[i]) = (xi, yi);
                ax[i] = fx - xf;
                ay[i] = fy - yf;
            }
            // Padding lanes keep s = 0 (and have weight 0).
            let mut sv = [0.0f32; CHUNK];
            for i in 0..CHUNK.min(n - first) {
                // In range by the corner test: the casts are exact.
                let i0 = y0[i] as usize * sw + x0[i] as usize;
                let cell = &data[i0..i0 + sw + 2];
                let t = cell[0] + ax[i] * (cell[1] - cell[0]);
                let b = cell[sw] + ax[i] * (cell[sw + 1] - cell[sw]);
                sv[i] = t + ay[i] * (b - t);
            }
            for i in 0..CHUNK {
                let ws = w[i] * sv[i];
                s1[i] += ws;
                s2[i] += ws * sv[i];
                sr[i] += wr[i] * sv[i];
            }
        }
    }
    Some((lane_total(s1), lane_total(s2), lane_total(sr)))
}

/// Floor of `x`, as a float and as an integer, for `0 <= x < 2^22`
/// (anything for other `x`): adding 1.5 * 2^23 rounds `x` to an integer,
/// read from the sum's mantissa bits; one less when it rounded up. Unlike
/// a float-to-int cast, which Rust saturates, this is plain float and
/// integer arithmetic that vectorises.
#[inline]
fn floor_small(x: f32) -> (f32, i32) {
    const MAGIC: f32 = 12_582_912.0;
    let t = x + MAGIC;
    let r = t - MAGIC;
    let up = r > x;
    let i = (t.to_bits() as i32).wrapping_sub(MAGIC.to_bits() as i32) - i32::from(up);
    (if up { r - 1.0 } else { r }, i)
}

/// Sum of the lanes, in the order every full-window sum uses.
#[inline]
fn lane_total(a: [f32; CHUNK]) -> f32 {
    let q = [a[0] + a[4], a[1] + a[5], a[2] + a[6], a[3] + a[7]];
    (q[0] + q[2]) + (q[1] + q[3])
}

/// Weighted sums over the samples of a window cut by the reference image's
/// border, each tested against the source image.
fn sums_partial(
    patch: &RefPatch,
    u: f32,
    v: f32,
    h: &[f32; 9],
    src: &GreyImage,
) -> Option<(f32, f32, f32)> {
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
            return None;
        }
        let iz = 1.0 / z;
        let x = (hp[0] + h[0] * dx + h[1] * dy) * iz;
        let y = (hp[1] + h[3] * dx + h[4] * dy) * iz;
        let s = src.sample(x, y)?;
        let ws = patch.w[i] * s;
        s1 += ws;
        s2 += ws * s;
        sr += patch.wr[i] * s;
    }
    Some((s1, s2, sr))
}

/// The straightforward loop [`sums_full`] replaced: the reference that the
/// fast one must equal bit for bit, and the path for images too wide for
/// [`floor_small`].
#[cold]
fn sums_full_reference(
    patch: &RefPatch,
    win: &Window,
    u: f32,
    v: f32,
    h: &[f32; 9],
    src: &GreyImage,
) -> Option<(f32, f32, f32)> {
    let (n, step) = (win.n(), win.step());
    let [a0, b0, c0] = warped_origin(win, u, v, h, src)?;
    let sw = src.width as usize;
    let data = &src.data[..];
    // One partial sum per lane: the adds of neighbouring samples do not
    // wait on each other, and the lane loops vectorise.
    let (mut s1, mut s2, mut sr) = ([0.0f32; CHUNK], [0.0f32; CHUNK], [0.0f32; CHUNK]);
    let stride = win.stride();
    let rows = patch
        .w
        .chunks_exact(stride)
        .zip(patch.wr.chunks_exact(stride));
    for (j, (w_row, wr_row)) in rows.enumerate() {
        let fj = j as f32 * step;
        let (ra, rb, rc) = (a0 + h[1] * fj, b0 + h[4] * fj, c0 + h[7] * fj);
        let chunks = w_row.chunks_exact(CHUNK).zip(wr_row.chunks_exact(CHUNK));
        for (c, (w, wr)) in chunks.enumerate() {
            // Coordinates of the whole chunk first (branch-free, so the
            // divisions vectorise); lanes past the row's end stay unused.
            let first = c * CHUNK;
            let mut fx = [0.0f32; CHUNK];
            let mut fy = [0.0f32; CHUNK];
            for i in 0..CHUNK {
                let fi = (first + i) as f32 * step;
                let iz = 1.0 / (rc + h[6] * fi);
                fx[i] = (ra + h[0] * fi) * iz - 0.5;
                fy[i] = (rb + h[3] * fi) * iz - 0.5;
            }
            // Padding lanes keep s = 0 (and have weight 0).
            let mut sv = [0.0f32; CHUNK];
            for i in 0..CHUNK.min(n - first) {
                // In range by the corner test: the casts cannot saturate.
                let (x0, y0) = (fx[i] as usize, fy[i] as usize);
                let (ax, ay) = (fx[i] - x0 as f32, fy[i] - y0 as f32);
                let i0 = y0 * sw + x0;
                let top = &data[i0..i0 + 2];
                let bottom = &data[i0 + sw..i0 + sw + 2];
                let t = top[0] + ax * (top[1] - top[0]);
                let b = bottom[0] + ax * (bottom[1] - bottom[0]);
                sv[i] = t + ay * (b - t);
            }
            for i in 0..CHUNK {
                let ws = w[i] * sv[i];
                s1[i] += ws;
                s2[i] += ws * sv[i];
                sr[i] += wr[i] * sv[i];
            }
        }
    }
    Some((lane_total(s1), lane_total(s2), lane_total(sr)))
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

/// A lower bound of [`aggregate`]'s first mean when only `costs` (ranking
/// costs, each >= 0) of `m` sources are known: the unscored sources may
/// cost 0, so only the smallest `k - (m - scored)` known costs are certain
/// to count. Lets a hypothesis stop as soon as it cannot beat the current
/// best.
#[inline]
pub(crate) fn aggregate_lower_bound(costs: &mut [(f32, f32)], m: usize, k: usize) -> f32 {
    let k = k.min(m).max(1);
    let unknown = m - costs.len();
    if unknown >= k {
        return 0.0;
    }
    costs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    costs[..k - unknown].iter().map(|c| c.0).sum::<f32>() / k as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
    use vp_scene::{Camera, Intrinsics};

    /// A reference camera at the origin and a source camera moved by `t`
    /// and turned by the Euler angles `r`.
    fn pair(k: Intrinsics, t: [f64; 3], r: [f64; 3]) -> (Camera, Camera) {
        let pose = Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_euler_angles(r[0], r[1], r[2]),
        );
        (Camera::new(k, Isometry3::identity()), Camera::new(k, pose))
    }

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
        let (reference, source) = pair(k, [1.0, -0.3, 0.2], [0.05, -0.1, 0.02]);
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

    /// A textured image: smooth random-looking intensities.
    fn texture(w: u32, h: u32) -> GreyImage {
        let data = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                0.5 + 0.2 * (0.37 * x + 0.11 * y).sin()
                    + 0.2 * (0.05 * x * y).cos() * (0.23 * y).sin()
            })
            .collect();
        GreyImage {
            width: w,
            height: h,
            data,
        }
    }

    #[test]
    fn fast_path_scores_like_the_per_sample_path() {
        // Same window, one scored by the corner test + row-wise homography,
        // one by the per-sample path: the costs agree to rounding, and both
        // refuse a window that leaves the source.
        let img = texture(64, 48);
        let hs = [
            [1.02f32, 0.03, -1.5, -0.02, 0.98, 2.0, 1e-4, -2e-4, 1.0],
            [0.9, -0.1, 4.0, 0.05, 1.1, -3.0, -3e-4, 1e-4, 1.01],
            [1.0, 0.0, 30.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], // leaves the image
        ];
        // The default window (6 samples a row) and one wider than a chunk.
        for (radius, step) in [(5, 2), (9, 1)] {
            let params = MvsParams {
                window_radius: radius,
                window_step: step,
                ..MvsParams::default()
            };
            let win = Window::new(&params);
            let mut patch = RefPatch::default();
            patch.build(&img, 30, 20, &win);
            assert!(patch.full && patch.textured());
            let mut slow = RefPatch::default();
            patch_clone_partial(&patch, &win, &mut slow);
            for h in hs {
                let fast = source_cost(&patch, &win, 30.5, 20.5, &h, &img);
                let reference = source_cost(&slow, &win, 30.5, 20.5, &h, &img);
                assert!((fast - reference).abs() < 1e-4, "{fast} vs {reference}");
            }
            assert!(source_cost(&patch, &win, 30.5, 20.5, &hs[2], &img) >= MAX_COST);
            assert!(source_cost(&patch, &win, 30.5, 20.5, &hs[0], &img) < 1.0);
        }
    }

    #[test]
    fn floor_small_is_the_truncating_cast_below_its_limit() {
        // Every 61st float of [0, 2^22), and the integers with their
        // neighbours and halves, where rounding to nearest goes up.
        let limit = (FLOOR_SMALL_LIMIT as f32).to_bits();
        let spread = (0..limit).step_by(61).map(f32::from_bits);
        let near = (0..FLOOR_SMALL_LIMIT).step_by(997).flat_map(|i| {
            let f = i as f32;
            [
                f,
                f + 0.5,
                f - 0.5,
                f * (1.0 + f32::EPSILON),
                f * (1.0 - f32::EPSILON),
            ]
        });
        for x in spread
            .chain(near)
            .filter(|x| (0.0..FLOOR_SMALL_LIMIT as f32).contains(x))
        {
            let (f, i) = floor_small(x);
            assert_eq!(
                (f.to_bits(), i),
                (((x as usize) as f32).to_bits(), x as i32),
                "{x}"
            );
        }
    }

    #[test]
    fn fast_full_window_sums_equal_the_reference_bit_for_bit() {
        // The AVX2 sums (where the CPU has AVX2) and the scalar fast sums
        // against the reference loop. Plane hypotheses of a real camera pair (random depths and
        // normals, as PatchMatch draws them) at every 3rd pixel: the fast
        // sums must be the reference loop's bits, or PatchMatch would pick
        // other winners. Windows of one chunk a row (the default) and of
        // several.
        let (w, h) = (96u32, 80u32);
        let img = texture(w, h);
        let src = GreyImage {
            data: img.data.iter().map(|v| 0.9 * v + 0.05).collect(),
            ..img.clone()
        };
        let k = Intrinsics {
            width: w,
            height: h,
            fx: 80.0,
            fy: 80.0,
            cx: 48.0,
            cy: 40.0,
        };
        let (reference, source) = pair(k, [0.8, -0.2, 0.1], [0.02, -0.06, 0.01]);
        let rel = Relative::new(&reference, &source);
        let kr = crate::view::k_of(&reference);
        let mut rng = crate::rng::PixelRng::new(7, 0, 0, 0);
        let (mut scored, mut refused) = (0, 0);
        for (radius, step) in [(5, 2), (9, 1), (4, 1)] {
            let win = Window::new(&MvsParams {
                window_radius: radius,
                window_step: step,
                ..MvsParams::default()
            });
            // The same window without the AVX2 sums (the fallback path).
            let scalar_win = Window {
                avx2: None,
                ..win.clone()
            };
            let mut patch = RefPatch::default();
            for y in (0..h as usize).step_by(3) {
                for x in (0..w as usize).step_by(3) {
                    patch.build(&img, x, y, &win);
                    if !patch.full {
                        continue;
                    }
                    let ray = crate::view::pixel_ray(&kr, x, y);
                    let d = 4.0 + 20.0 * rng.next_f32();
                    let n = [0.4 * rng.symmetric(), 0.4 * rng.symmetric(), -1.0];
                    let Some(hm) = homography(&rel, &kr, d, &n, &ray) else {
                        continue;
                    };
                    let (u, v) = (x as f32 + 0.5, y as f32 + 0.5);
                    let fast = sums_full(&patch, &win, u, v, &hm, &src);
                    let scalar = sums_full(&patch, &scalar_win, u, v, &hm, &src);
                    let slow = sums_full_reference(&patch, &win, u, v, &hm, &src);
                    let bits = |s: Option<(f32, f32, f32)>| {
                        s.map(|(a, b, c)| [a.to_bits(), b.to_bits(), c.to_bits()])
                    };
                    assert_eq!(
                        bits(fast),
                        bits(slow),
                        "pixel ({x}, {y}), window {radius}/{step}"
                    );
                    assert_eq!(
                        bits(scalar),
                        bits(slow),
                        "scalar path: pixel ({x}, {y}), window {radius}/{step}"
                    );
                    if fast.is_some() {
                        scored += 1;
                    } else {
                        refused += 1;
                    }
                }
            }
        }
        // Both outcomes were exercised, and the AVX2 sums where the CPU
        // has AVX2.
        assert!(
            scored > 500 && refused > 20,
            "{scored} scored, {refused} refused"
        );
        #[cfg(target_arch = "x86_64")]
        assert_eq!(
            Avx2::detect().is_some(),
            std::arch::is_x86_feature_detected!("avx2")
        );
    }

    fn patch_clone_partial(full: &RefPatch, win: &Window, out: &mut RefPatch) {
        for &oy in &win.offsets {
            for &ox in &win.offsets {
                out.dx.push(ox as f32);
                out.dy.push(oy as f32);
            }
        }
        for (w, wr) in full
            .w
            .chunks_exact(win.stride())
            .zip(full.wr.chunks_exact(win.stride()))
        {
            out.w.extend_from_slice(&w[..win.n()]);
            out.wr.extend_from_slice(&wr[..win.n()]);
        }
        out.sum_w = full.sum_w;
        out.var = full.var;
        out.full = false;
    }

    #[test]
    fn lower_bound_never_exceeds_the_aggregate() {
        let all = [(0.7f32, 0.7f32), (0.2, 0.2), (1.5, 1.5), (0.4, 0.4)];
        for k in 1..=4 {
            let want = aggregate(&mut all.clone(), k).0;
            for scored in 1..=4 {
                let mut part = all[..scored].to_vec();
                let lb = aggregate_lower_bound(&mut part, all.len(), k);
                assert!(lb <= want + 1e-6, "k {k}, {scored} scored: {lb} > {want}");
                if scored == all.len() {
                    assert!((lb - want).abs() < 1e-6);
                }
            }
        }
    }
}
