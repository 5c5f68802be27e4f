//! Semi-global matching of a rectified pair (Hirschmüller, PAMI 2008): a
//! census cost volume, aggregation along 4 or 8 scanlines, then
//! winner-take-all with the uniqueness, sub-pixel, left-right and speckle
//! steps. All sums are integers, so the result does not depend on the
//! order rows are processed in (rows run in parallel).

use rayon::prelude::*;

use super::SgmParams;
use crate::simd::Avx2;

/// A rectified image pair on one grid, the reference (left) first.
pub(crate) struct RectifiedPair {
    pub width: usize,
    pub height: usize,
    pub left: Vec<f32>,
    pub left_valid: Vec<bool>,
    pub right: Vec<f32>,
    pub right_valid: Vec<bool>,
    pub n_disp: usize,
}

/// Aggregated costs start here beyond the disparity range's ends, so that
/// `BIG + p1` never wins and never overflows (validated: p1, p2 < 8000).
const BIG: u16 = 0x4000;

/// Census transform: bit k of a pixel is set when the k-th pixel of its
/// window (row-major, centre skipped, coordinates clamped to the image)
/// is darker than the centre.
pub(crate) fn census(img: &[f32], w: usize, h: usize, cw: usize, ch: usize) -> Vec<u64> {
    let (rx, ry) = ((cw / 2) as isize, (ch / 2) as isize);
    let mut out = vec![0u64; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, c) in row.iter_mut().enumerate() {
            let centre = img[y * w + x];
            let mut bits = 0u64;
            let mut k = 0;
            for dy in -ry..=ry {
                let yy = (y as isize + dy).clamp(0, h as isize - 1) as usize;
                for dx in -rx..=rx {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    let xx = (x as isize + dx).clamp(0, w as isize - 1) as usize;
                    bits |= u64::from(img[yy * w + xx] < centre) << k;
                    k += 1;
                }
            }
            *c = bits;
        }
    });
    out
}

/// The cost volume `cost[(y * w + x) * n_disp + k]`: Hamming distance
/// between the census codes of left pixel x and right pixel x - k; the
/// largest cost (`n_bits`) where either pixel lies outside its original
/// image.
pub(crate) fn cost_volume(pair: &RectifiedPair, cw: usize, ch: usize) -> Vec<u8> {
    let (w, h, nd) = (pair.width, pair.height, pair.n_disp);
    let n_bits = (cw * ch - 1) as u8;
    let cl = census(&pair.left, w, h, cw, ch);
    let cr = census(&pair.right, w, h, cw, ch);
    let mut cost = vec![n_bits; w * h * nd];
    cost.par_chunks_mut(w * nd)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                let i = y * w + x;
                if !pair.left_valid[i] {
                    continue;
                }
                let cell = &mut row[x * nd..(x + 1) * nd];
                for (k, c) in cell.iter_mut().enumerate().take(x + 1) {
                    let j = i - k;
                    if pair.right_valid[j] {
                        *c = (cl[i] ^ cr[j]).count_ones() as u8;
                    }
                }
            }
        });
    cost
}

/// One step of a scanline: `cur[1..=nd]` from the previous pixel's
/// `prev[1..=nd]` (both padded with `BIG` at 0 and nd + 1) and its minimum
/// `prev_min`, Hirschmüller's recursion `L(p, d) = C(p, d) + min(L(p-r, d),
/// L(p-r, d±1) + P1, min L(p-r) + P2) - min L(p-r)`. Returns the minimum of
/// `cur`, which the next step needs.
// Always inlined: the copy inside simd.rs's `#[target_feature(enable =
// "avx2")]` function is then compiled for AVX2; a call would run this one.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn step(
    cost: &[u8],
    prev: &[u16],
    prev_min: u16,
    p1: u16,
    p2: u16,
    cur: &mut [u16],
) -> u16 {
    let nd = cost.len();
    let lim = prev_min + p2;
    let (lo, mid, hi) = (&prev[..nd], &prev[1..=nd], &prev[2..nd + 2]);
    let mut min = u16::MAX;
    for ((((o, &c), &m), &l), &h) in cur[1..=nd].iter_mut().zip(cost).zip(mid).zip(lo).zip(hi) {
        // Wrapping ops that never wrap (every term stays below BIG + 8000 +
        // 64): without overflow checks the loop vectorises in test builds too.
        let best = m.min(l.wrapping_add(p1)).min(h.wrapping_add(p1)).min(lim);
        let v = u16::from(c).wrapping_add(best).wrapping_sub(prev_min);
        *o = v;
        min = min.min(v);
    }
    min
}

/// A path's first pixel: its aggregated cost is its matching cost. Returns
/// the minimum.
#[inline]
fn start(cost: &[u8], cur: &mut [u16]) -> u16 {
    let mut min = u16::MAX;
    for (c, &v) in cur[1..=cost.len()].iter_mut().zip(cost) {
        *c = u16::from(v);
        min = min.min(*c);
    }
    min
}

#[inline]
fn accumulate(sum: &mut [u16], cur: &[u16]) {
    // At most 8 paths x (64 + 8000) < 65536: never wraps.
    for (s, &v) in sum.iter_mut().zip(&cur[1..]) {
        *s = s.wrapping_add(v);
    }
}

/// Sum over the scanline directions of the aggregated costs, laid out like
/// the cost volume.
///
/// # Performance
/// Each direction touches every cell once with a handful of u16 min/add
/// operations that LLVM vectorises. Horizontal paths run rows in
/// parallel; the others sweep rows in order with the pixels of a row in
/// parallel (each depends only on the previous row). AVX2 (detected at
/// run time) only changes the code generation of the step, not its result.
pub(crate) fn aggregate(
    cost: &[u8],
    w: usize,
    h: usize,
    nd: usize,
    params: &SgmParams,
    avx2: Option<Avx2>,
) -> Vec<u16> {
    let (p1, p2) = (params.p1, params.p2);
    let advance = |c: &[u8], prev: &[u16], prev_min: u16, cur: &mut [u16]| match avx2 {
        Some(a) => a.sgm_step(c, prev, prev_min, p1, p2, cur),
        None => step(c, prev, prev_min, p1, p2, cur),
    };
    let mut sum = vec![0u16; w * h * nd];
    let dirs: &[(isize, isize)] = if params.paths == 4 {
        &[(1, 0), (-1, 0), (0, 1), (0, -1)]
    } else {
        &[
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (-1, 1),
            (1, -1),
            (-1, -1),
        ]
    };
    let pad = nd + 2;
    for &(dx, dy) in dirs {
        if dy == 0 {
            sum.par_chunks_mut(w * nd)
                .zip(cost.par_chunks(w * nd))
                .for_each(|(srow, crow)| {
                    let mut prev = vec![BIG; pad];
                    let mut cur = vec![BIG; pad];
                    let mut min = 0;
                    for n in 0..w {
                        let x = if dx > 0 { n } else { w - 1 - n };
                        let c = &crow[x * nd..(x + 1) * nd];
                        min = if n == 0 {
                            start(c, &mut cur)
                        } else {
                            advance(c, &prev, min, &mut cur)
                        };
                        accumulate(&mut srow[x * nd..(x + 1) * nd], &cur);
                        std::mem::swap(&mut prev, &mut cur);
                    }
                });
            continue;
        }
        let mut prev = vec![BIG; w * pad];
        let mut cur = vec![BIG; w * pad];
        let mut prev_mins = vec![0u16; w];
        let mut cur_mins = vec![0u16; w];
        for n in 0..h {
            let y = if dy > 0 { n } else { h - 1 - n };
            let crow = &cost[y * w * nd..(y + 1) * w * nd];
            let srow = &mut sum[y * w * nd..(y + 1) * w * nd];
            let (prev_row, mins) = (&prev, &prev_mins);
            cur.par_chunks_mut(pad)
                .zip(srow.par_chunks_mut(nd))
                .zip(cur_mins.par_iter_mut())
                .enumerate()
                .with_min_len(64)
                .for_each(|(x, ((cell, s), min))| {
                    let c = &crow[x * nd..(x + 1) * nd];
                    let px = x as isize - dx;
                    *min = if n == 0 || px < 0 || px >= w as isize {
                        start(c, cell)
                    } else {
                        let p = px as usize;
                        advance(c, &prev_row[p * pad..(p + 1) * pad], mins[p], cell)
                    };
                    accumulate(s, cell);
                });
            std::mem::swap(&mut prev, &mut cur);
            std::mem::swap(&mut prev_mins, &mut cur_mins);
        }
    }
    sum
}

/// Winner-take-all over the aggregated sums with Hirschmüller's checks:
/// uniqueness (the best sum at most `uniqueness` times every sum two or
/// more disparities away), parabola sub-pixel fit, and left-right
/// consistency against the right image's winners taken from the same sums
/// (as OpenCV's StereoSGBM does). Returns the disparity index (fractional)
/// per left pixel, NaN where rejected.
pub(crate) fn winners(sum: &[u16], pair: &RectifiedPair, params: &SgmParams) -> Vec<f32> {
    let (w, nd) = (pair.width, pair.n_disp);
    let mut disp = vec![f32::NAN; w * pair.height];
    disp.par_chunks_mut(w).enumerate().for_each(|(y, out)| {
        let row = &sum[y * w * nd..(y + 1) * w * nd];
        // Right pixel xr's best disparity: left pixel xr + k at index k.
        let right: Vec<usize> = (0..w)
            .map(|xr| {
                let mut best = (u16::MAX, 0);
                for k in 0..nd.min(w - xr) {
                    let s = row[(xr + k) * nd + k];
                    if s < best.0 {
                        best = (s, k);
                    }
                }
                best.1
            })
            .collect();
        for (x, o) in out.iter_mut().enumerate() {
            if !pair.left_valid[y * w + x] {
                continue;
            }
            let s = &row[x * nd..(x + 1) * nd];
            let mut best = 0;
            for k in 1..nd {
                if s[k] < s[best] {
                    best = k;
                }
            }
            if best > x || !pair.right_valid[y * w + x - best] {
                continue;
            }
            let min = f32::from(s[best]);
            let unique = s
                .iter()
                .enumerate()
                .all(|(k, &v)| k.abs_diff(best) <= 1 || min <= params.uniqueness * f32::from(v));
            if !unique || right[x - best].abs_diff(best) > params.lr_max_diff as usize {
                continue;
            }
            let mut d = best as f32;
            if best > 0 && best + 1 < nd {
                let (a, b, c) = (f32::from(s[best - 1]), min, f32::from(s[best + 1]));
                let denom = a + c - 2.0 * b;
                if denom > 0.0 {
                    d += (a - c) / (2.0 * denom);
                }
            }
            *o = d;
        }
    });
    disp
}

/// OpenCV's `filterSpeckles`: 4-connected regions whose neighbours differ
/// by at most `max_diff` and that hold at most `max_size` pixels are set to
/// NaN. Regions are grown from pixels in row-major order.
pub(crate) fn filter_speckles(
    disp: &mut [f32],
    w: usize,
    h: usize,
    max_size: usize,
    max_diff: f32,
) {
    if max_size == 0 {
        return;
    }
    let mut label = vec![0u32; w * h];
    let mut small = vec![false; 1];
    let mut stack = Vec::new();
    let mut region = Vec::new();
    for start in 0..w * h {
        if label[start] != 0 || disp[start].is_nan() {
            continue;
        }
        let id = small.len() as u32;
        label[start] = id;
        stack.push(start);
        region.clear();
        while let Some(p) = stack.pop() {
            region.push(p);
            let (x, y) = (p % w, p / w);
            let d = disp[p];
            let mut visit = |q: usize| {
                if label[q] == 0 && !disp[q].is_nan() && (disp[q] - d).abs() <= max_diff {
                    label[q] = id;
                    stack.push(q);
                }
            };
            if x > 0 {
                visit(p - 1);
            }
            if x + 1 < w {
                visit(p + 1);
            }
            if y > 0 {
                visit(p - w);
            }
            if y + 1 < h {
                visit(p + w);
            }
        }
        small.push(region.len() <= max_size);
    }
    for (d, &l) in disp.iter_mut().zip(&label) {
        if l != 0 && small[l as usize] {
            *d = f32::NAN;
        }
    }
}

/// The whole matcher: disparity indices of the left image (NaN where none).
pub(crate) fn match_pair(pair: &RectifiedPair, params: &SgmParams) -> Vec<f32> {
    let (cw, ch) = (params.census_width as usize, params.census_height as usize);
    let cost = cost_volume(pair, cw, ch);
    let sum = aggregate(
        &cost,
        pair.width,
        pair.height,
        pair.n_disp,
        params,
        Avx2::detect(),
    );
    drop(cost);
    let mut disp = winners(&sum, pair, params);
    filter_speckles(
        &mut disp,
        pair.width,
        pair.height,
        params.speckle_size as usize,
        params.speckle_range,
    );
    disp
}
