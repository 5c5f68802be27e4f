//! Photo-consistency: bilaterally weighted NCC over a sparse window, warped
//! into each source through the plane-induced homography, aggregated over
//! the sources with a best-k view selection.

use crate::params::MvsParams;
use crate::simd::{Avx2, CutWindow, FullWindow};
use crate::view::GreyImage;

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
///
/// A full patch stores the window's samples row-major and packed, the
/// grid's rows one after another with no gap, padded at the end to whole
/// chunks of [`CHUNK`]: the default 6 x 6 grid without its corners is 4
/// chunks (32 lanes, no padding; with its corners 5 chunks, 40 lanes, 4 of
/// them padding), where a row padded to a chunk each took 6 (48 lanes, 12
/// padding). The sums' work is per chunk, so fewer chunks is less work.
#[derive(Debug, Clone)]
pub(crate) struct Window {
    /// Offsets along one axis: `-r, -r + step, ..., <= r`.
    pub offsets: Vec<i32>,
    /// The samples, (x, y) offsets from the centre, in the packed order
    /// ([`MvsParams::window_samples`]).
    pub grid: Vec<(i32, i32)>,
    /// `exp(-(dx^2 + dy^2) / (2 sigma_s^2))` per lane of the packed
    /// layout, 0 on padding (so that a full patch's weights are one
    /// product per lane).
    spatial: Vec<f32>,
    /// `1 / (2 sigma_c^2)`.
    inv_color: f32,
    /// Offset of each lane of the packed layout from the window's first
    /// sample, along x and y (reference pixels); 0 on padding.
    lane_x: Vec<f32>,
    lane_y: Vec<f32>,
    /// The AVX2 sums, when the CPU has AVX2 (detected once per run).
    avx2: Option<Avx2>,
}

impl Window {
    pub(crate) fn new(params: &MvsParams) -> Self {
        let offsets = params.window_offsets();
        let samples = params.window_samples();
        let inv_s = 1.0 / (2.0 * params.sigma_spatial * params.sigma_spatial);
        let first = offsets[0];
        let lanes = samples.len().div_ceil(CHUNK) * CHUNK;
        // (ox, oy) of every lane; None on padding.
        let grid = |k: usize| samples.get(k).copied();
        let spatial = (0..lanes)
            .map(|k| {
                grid(k).map_or(0.0, |(ox, oy)| {
                    (-((ox * ox + oy * oy) as f32) * inv_s).exp()
                })
            })
            .collect();
        let lane = |axis: fn((i32, i32)) -> i32| -> Vec<f32> {
            (0..lanes)
                .map(|k| grid(k).map_or(0.0, |o| (axis(o) - first) as f32))
                .collect()
        };
        Window {
            spatial,
            inv_color: 1.0 / (2.0 * params.sigma_color * params.sigma_color),
            lane_x: lane(|(ox, _)| ox),
            lane_y: lane(|(_, oy)| oy),
            offsets,
            grid: samples,
            avx2: Avx2::detect(),
        }
    }

    /// Samples of the whole window.
    #[inline]
    pub(crate) fn samples(&self) -> usize {
        self.grid.len()
    }

    /// Lanes of a full patch: the samples padded to whole chunks of
    /// [`CHUNK`] with zero weights.
    #[inline]
    pub(crate) fn lanes(&self) -> usize {
        self.spatial.len()
    }

    fn first(&self) -> i32 {
        self.offsets[0]
    }

    fn last(&self) -> i32 {
        self.offsets[self.offsets.len() - 1]
    }
}

#[path = "ref_patch.rs"]
mod ref_patch;
pub(crate) use ref_patch::{PatchKernels, RefPatch, Scalar};

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
/// the homography is evaluated from the first sample's warped position,
/// eight samples at a time, without a per-sample bounds test.
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
        sums_partial(patch, win, u, v, h, src)
    };
    let Some((s1, s2, sr)) = sums else {
        return MAX_COST;
    };
    let var_s = s2 - s1 * s1 * patch.inv_sum_w;
    if !(var_s > MIN_VARIANCE * patch.sum_w) {
        return MAX_COST;
    }
    let ncc = sr * patch.inv_sd / var_s.sqrt();
    (1.0 - ncc).clamp(0.0, MAX_COST)
}

/// The homogeneous source coordinates of the window's first sample, if
/// all four warped corners of the window land inside `src` (then, the
/// homography being projective and the window convex, every sample does);
/// `None` if a corner falls outside or behind the source camera.
#[inline]
#[allow(clippy::needless_bitwise_bool)] // see the corner loop
fn warped_origin(win: &Window, u: f32, v: f32, h: &[f32; 9], src: &GreyImage) -> Option<[f32; 3]> {
    let o0 = win.first() as f32;
    let (u0, v0) = (u + o0, v + o0);
    let a0 = h[0] * u0 + h[1] * v0 + h[2];
    let b0 = h[3] * u0 + h[4] * v0 + h[5];
    let c0 = h[6] * u0 + h[7] * v0 + h[8];
    let span = (win.last() - win.first()) as f32;
    let x_max = src.width as f32 - 0.5 - EDGE_MARGIN;
    let y_max = src.height as f32 - 0.5 - EDGE_MARGIN;
    // The four corners side by side, with no branch inside the loop, so
    // that they are computed as one vector of four.
    let (cx, cy) = ([0.0, span, 0.0, span], [0.0, 0.0, span, span]);
    let mut inside = [false; 4];
    // x = X / z lies in [lo, x_max) where X lies in [lo z, x_max z), for
    // z > 0: the test needs no division. Rounding may move a corner within
    // EDGE_MARGIN of the border to either side; the sums clamp every tap
    // into the image, so none reads outside it either way.
    let lo = 0.5 + EDGE_MARGIN;
    for i in 0..4 {
        let z = c0 + h[6] * cx[i] + h[7] * cy[i];
        let x = a0 + h[0] * cx[i] + h[1] * cy[i];
        let y = b0 + h[3] * cx[i] + h[4] * cy[i];
        // `&`, not `&&`: no branch per test, so the four corners stay one
        // vector (a tenth of this function's instructions).
        inside[i] = (z > 0.0) & (x >= lo * z) & (y >= lo * z) & (x < x_max * z) & (y < y_max * z);
    }
    (inside[0] & inside[1] & inside[2] & inside[3]).then_some([a0, b0, c0])
}

/// Weighted sums (w s, w s^2, w r s) over the full window grid.
///
/// Bit for bit the sums of the straightforward loop
/// ([`sums_full_reference`]): every sample goes through the same operations
/// in the same order, and each lane adds up the same samples. What changed
/// is the machine code around them: the chunks are walked with fixed-size
/// arrays, and the float-to-integer casts are done for the whole chunk at
/// once, with float and integer arithmetic, so that they vectorise.
#[inline]
fn sums_full(
    patch: &RefPatch,
    win: &Window,
    u: f32,
    v: f32,
    h: &[f32; 9],
    src: &GreyImage,
) -> Option<(f32, f32, f32)> {
    let origin = warped_origin(win, u, v, h, src)?;
    if src.width >= FLOOR_SMALL_LIMIT || src.height >= FLOOR_SMALL_LIMIT {
        return sums_full_reference(patch, win, u, v, h, src);
    }
    if let Some(avx2) = win.avx2 {
        let lanes = avx2.sums_full(&FullWindow {
            w: &patch.w,
            wr: &patch.wr,
            lane_x: &win.lane_x,
            lane_y: &win.lane_y,
            samples: win.samples(),
            origin,
            h,
            data: &src.data,
            width: src.width as usize,
        });
        if let Some([s1, s2, sr]) = lanes {
            return Some((s1, s2, sr));
        }
    }
    let [a0, b0, c0] = origin;
    let sw = src.width as usize;
    let data = &src.data[..];
    // One partial sum per lane: the adds of neighbouring samples do not
    // wait on each other, and the lane loops vectorise.
    let (mut s1, mut s2, mut sr) = ([0.0f32; CHUNK], [0.0f32; CHUNK], [0.0f32; CHUNK]);
    for first in (0..win.lanes()).step_by(CHUNK) {
        let (w, wr, fi, fj) = (
            chunk(&patch.w, first),
            chunk(&patch.wr, first),
            chunk(&win.lane_x, first),
            chunk(&win.lane_y, first),
        );
        // Coordinates, cells and fractions of the whole chunk
        // (branch-free, so that they vectorise); padding lanes are
        // computed but unused.
        let (mut x0, mut y0) = ([0i32; CHUNK], [0i32; CHUNK]);
        let mut ax = [0.0f32; CHUNK];
        let mut ay = [0.0f32; CHUNK];
        for i in 0..CHUNK {
            let iz = 1.0 / ((c0 + h[7] * fj[i]) + h[6] * fi[i]);
            let fx = ((a0 + h[1] * fj[i]) + h[0] * fi[i]) * iz - 0.5;
            let fy = ((b0 + h[4] * fj[i]) + h[3] * fi[i]) * iz - 0.5;
            let (xf, xi) = floor_small(fx);
            let (yf, yi) = floor_small(fy);
            (x0[i], y0[i]) = (xi, yi);
            ax[i] = fx - xf;
            ay[i] = fy - yf;
        }
        // Padding lanes keep s = 0 (and have weight 0).
        let mut sv = [0.0f32; CHUNK];
        for i in 0..CHUNK.min(win.samples() - first) {
            // In range by the corner test, up to rounding at the border:
            // clamped as the AVX2 taps are, so no rounding reads outside.
            let i0 = tap_index(
                i64::from(y0[i]) * sw as i64 + i64::from(x0[i]),
                data.len(),
                sw,
            );
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
    Some((lane_total(s1), lane_total(s2), lane_total(sr)))
}

/// `a[at..at + CHUNK]` as an array, bounds-checked.
#[inline]
pub(crate) fn chunk(a: &[f32], at: usize) -> &[f32; CHUNK] {
    let Ok(c) = <&[f32; CHUNK]>::try_from(&a[at..at + CHUNK]) else {
        unreachable!("a slice of CHUNK elements")
    };
    c
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

/// A bilinear cell's first index `i0` clamped to `[0, len - sw - 2]`, so
/// that its four taps (`i0`, `i0 + 1`, `i0 + sw`, `i0 + sw + 1`) lie in an
/// image of `len` pixels and row stride `sw`: what `TapIndex::clamped` does
/// for the AVX2 sums (simd/mod.rs), for the scalar ones. The corner test
/// keeps every cell inside but for rounding within `EDGE_MARGIN` of the
/// border, and there a clamped tap is the nearest pixel, not a panic.
#[inline]
fn tap_index(i0: i64, len: usize, sw: usize) -> usize {
    i0.clamp(0, len.saturating_sub(sw + 2) as i64) as usize
}

/// Sum of the lanes, in the order every full-window sum uses.
#[inline]
fn lane_total(a: [f32; CHUNK]) -> f32 {
    let q = [a[0] + a[4], a[1] + a[5], a[2] + a[6], a[3] + a[7]];
    (q[0] + q[2]) + (q[1] + q[3])
}

/// Weighted sums over the samples of a window cut by the reference image's
/// border, each tested against the source image.
///
/// With AVX2, eight samples at a time (`simd::CutWindow`): the same bits.
fn sums_partial(
    patch: &RefPatch,
    win: &Window,
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
    if let Some(avx2) = win.avx2 {
        let cut = CutWindow {
            dx: &patch.dx,
            dy: &patch.dy,
            w: &patch.w,
            wr: &patch.wr,
            hp,
            h,
            data: &src.data,
            width: src.width as usize,
            height: src.height as usize,
        };
        if let Some(sums) = avx2.sums_partial(&cut) {
            return sums.map(|[s1, s2, sr]| (s1, s2, sr));
        }
    }
    sums_partial_scalar(patch, hp, h, src)
}

/// [`sums_partial`] one sample at a time: the reference, and the path on
/// CPUs without AVX2.
fn sums_partial_scalar(
    patch: &RefPatch,
    hp: [f32; 3],
    h: &[f32; 9],
    src: &GreyImage,
) -> Option<(f32, f32, f32)> {
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
    let [a0, b0, c0] = warped_origin(win, u, v, h, src)?;
    let sw = src.width as usize;
    let data = &src.data[..];
    // One partial sum per lane: the adds of neighbouring samples do not
    // wait on each other, and the lane loops vectorise.
    let (mut s1, mut s2, mut sr) = ([0.0f32; CHUNK], [0.0f32; CHUNK], [0.0f32; CHUNK]);
    let lanes = patch
        .w
        .chunks_exact(CHUNK)
        .zip(patch.wr.chunks_exact(CHUNK));
    for (c, (w, wr)) in lanes.enumerate() {
        let first = c * CHUNK;
        // Padding lanes keep s = 0 (and have weight 0).
        let mut sv = [0.0f32; CHUNK];
        let live = CHUNK.min(win.samples() - first);
        let offsets = win.lane_x[first..].iter().zip(&win.lane_y[first..]);
        for (s, (&fi, &fj)) in sv.iter_mut().zip(offsets).take(live) {
            let iz = 1.0 / ((c0 + h[7] * fj) + h[6] * fi);
            let fx = ((a0 + h[1] * fj) + h[0] * fi) * iz - 0.5;
            let fy = ((b0 + h[4] * fj) + h[3] * fi) * iz - 0.5;
            // In range by the corner test, up to rounding at the border
            // (clamped there, as the fast path's taps are).
            let (x0, y0) = (fx as usize, fy as usize);
            let (ax, ay) = (fx - x0 as f32, fy - y0 as f32);
            let i0 = tap_index((y0 * sw + x0) as i64, data.len(), sw);
            let top = &data[i0..i0 + 2];
            let bottom = &data[i0 + sw..i0 + sw + 2];
            let t = top[0] + ax * (top[1] - top[0]);
            let b = bottom[0] + ax * (bottom[1] - bottom[0]);
            *s = t + ay * (b - t);
        }
        for i in 0..CHUNK {
            let ws = w[i] * sv[i];
            s1[i] += ws;
            s2[i] += ws * sv[i];
            sr[i] += wr[i] * sv[i];
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
#[path = "cost_tests.rs"]
mod tests;
