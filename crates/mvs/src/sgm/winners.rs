//! Winner-take-all over a row's aggregated sums with Hirschmüller's
//! checks, and OpenCV's speckle filter over the disparity image.

use rayon::prelude::*;

use super::matching::RectifiedPair;
use super::{LeftRight, SgmParams};

/// Winner-take-all over one row's aggregated sums (`w * nd`) with
/// Hirschmüller's checks: uniqueness (the best sum at most `uniqueness`
/// times every sum two or more disparities away), parabola sub-pixel fit,
/// and left-right consistency against the right image's winners taken
/// from the same sums, by `params.left_right`: Hirschmüller's right
/// winner (PAMI 2008, sec. 3.4: the smallest sum along the right pixel's
/// whole epipolar line) or OpenCV StereoSGBM's (the best left winner
/// landing on it, [`winner_row_best_left`]), which keeps more pixels
/// where the disparity changes by more than 1 px per pixel (wide angles;
/// docs/performance.md). Writes the disparity index (fractional) of each
/// left pixel of row y into `out`, NaN where rejected.
// Always inlined: simd.rs compiles copies with AVX2 and AVX-512 enabled.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn winner_row(
    row: &[u16],
    y: usize,
    pair: &RectifiedPair,
    params: &SgmParams,
    held: &mut Vec<u32>,
    out: &mut [f32],
) {
    winner_row_with(row, y, pair, params, held, out, pick);
}

/// A cell's winner: the index of its first smallest sum, and the smallest
/// sum two or more disparities away from it (u16::MAX for none: sums stay
/// below 8 x (64 + 8000) < 65535). simd.rs has the same with AVX-512
/// (`sgm_kernels::pick_512`), tested equal.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn pick(s: &[u16]) -> (usize, u16) {
    // The first smallest sum: the minimum of (sum << 16 | k).
    let key = s
        .iter()
        .zip(0u32..)
        .map(|(&v, k)| u32::from(v) << 16 | k)
        .min()
        .unwrap_or(0);
    let best = (key & 0xFFFF) as usize;
    let fold = |v: &[u16]| v.iter().fold(u16::MAX, |a, &b| a.min(b));
    let rival = fold(&s[..best.saturating_sub(1)]).min(fold(s.get(best + 2..).unwrap_or(&[])));
    (best, rival)
}

/// [`winner_row`] with the cells' winners picked by `pick` ([`pick`] or
/// an equal vector version).
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn winner_row_with<F: Fn(&[u16]) -> (usize, u16)>(
    row: &[u16],
    y: usize,
    pair: &RectifiedPair,
    params: &SgmParams,
    held: &mut Vec<u32>,
    out: &mut [f32],
    pick: F,
) {
    const STRIDE: usize = 16;
    if params.left_right == LeftRight::Opencv {
        return winner_row_best_left(row, y, pair, params, held, out, pick);
    }
    let (w, nd) = (pair.width, pair.n_disp);
    // Right pixel xr's best disparity, the first smallest of left pixel
    // xr + k's sum at index k over k. Each right pixel holds (sum << 16 |
    // k), whose minimum is the smallest sum with the smallest k; left
    // pixels in order offer their sums to the right pixels x - k. Right
    // pixels are stored from the right end (slot w - 1 - xr), so that left
    // pixel x's offers go to consecutive slots: a u32 minimum that
    // vectorises.
    let ks: Vec<u32> = (0..nd as u32).collect();
    held.clear();
    held.resize(w, u32::MAX);
    // Left pixels `STRIDE` apart in turn: consecutive offers then cover
    // whole vectors of the slots the previous one stored, which the CPU
    // forwards (offers of neighbouring pixels, one slot apart, would each
    // wait for the store to finish). A minimum: the order does not matter.
    for phase in 0..STRIDE.min(w) {
        for x in (phase..w).step_by(STRIDE) {
            let reach = nd.min(x + 1);
            let at = w - 1 - x;
            let offers = row[x * nd..x * nd + reach].iter().zip(&ks[..reach]);
            for (h, (&v, &k)) in held[at..at + reach].iter_mut().zip(offers) {
                *h = (*h).min(u32::from(v) << 16 | k);
            }
        }
    }
    for (x, o) in out.iter_mut().enumerate() {
        *o = f32::NAN;
        if !pair.left_valid[y * w + x] {
            continue;
        }
        let s = &row[x * nd..(x + 1) * nd];
        let (best, smallest) = pick(s);
        if best > x || !pair.right_valid[y * w + x - best] {
            continue;
        }
        let unique = is_unique(s, best, smallest, params.uniqueness);
        let right_best = (held[w - 1 - (x - best)] & 0xFFFF) as usize;
        if !unique || right_best.abs_diff(best) > params.lr_max_diff as usize {
            continue;
        }
        *o = subpixel(s, best);
    }
}

/// The uniqueness test: the winner's sum `s[best]` at most `uniqueness`
/// times `smallest`, the smallest sum two or more disparities away (every
/// such sum passes the ratio test exactly when the smallest of them does:
/// f32 products are monotone).
#[allow(clippy::inline_always)]
#[inline(always)]
fn is_unique(s: &[u16], best: usize, smallest: u16, uniqueness: f32) -> bool {
    let rival = if smallest == u16::MAX {
        f32::INFINITY
    } else {
        f32::from(smallest)
    };
    f32::from(s[best]) <= uniqueness * rival
}

/// The winner's disparity refined by the parabola through its sum and its
/// two neighbours' (none at the ends of the range, or on a flat top).
#[allow(clippy::inline_always)]
#[inline(always)]
fn subpixel(s: &[u16], best: usize) -> f32 {
    let mut d = best as f32;
    if best > 0 && best + 1 < s.len() {
        let (a, b, c) = (
            f32::from(s[best - 1]),
            f32::from(s[best]),
            f32::from(s[best + 1]),
        );
        let denom = a + c - 2.0 * b;
        if denom > 0.0 {
            d += (a - c) / (2.0 * denom);
        }
    }
    d
}

/// [`winner_row_with`] under [`LeftRight::Opencv`]: first every left
/// pixel's unique winner (uniqueness and sub-pixel fit as there), each
/// offered to the right pixel it lands on, which keeps the offer with the
/// smallest sum (ties: the smaller disparity); then a left pixel is
/// dropped when the right pixels at the floor and at the ceiling of its
/// disparity both hold an offer that differs from it by more than
/// `lr_max_diff`. `held` holds the offers (sum << 16 | disparity).
#[allow(clippy::inline_always)]
#[inline(always)]
fn winner_row_best_left<F: Fn(&[u16]) -> (usize, u16)>(
    row: &[u16],
    y: usize,
    pair: &RectifiedPair,
    params: &SgmParams,
    held: &mut Vec<u32>,
    out: &mut [f32],
    pick: F,
) {
    let (w, nd) = (pair.width, pair.n_disp);
    held.clear();
    // Slot w takes the offers of rejected pixels (never read): the loop
    // below selects instead of branching, since which pixels pass the
    // checks is data, not a pattern the branch predictor learns (the
    // branches were half the time of this function).
    held.resize(w + 1, u32::MAX);
    let (lv, rv) = (
        &pair.left_valid[y * w..(y + 1) * w],
        &pair.right_valid[y * w..(y + 1) * w],
    );
    for (x, o) in out.iter_mut().enumerate() {
        let s = &row[x * nd..(x + 1) * nd];
        let (best, smallest) = pick(s);
        // Right pixel x - best (wrapped past w when best > x).
        let xr = x.wrapping_sub(best);
        #[allow(clippy::needless_bitwise_bool)] // all evaluated: no branches
        let keep =
            lv[x] & (xr < w) & rv[xr.min(w - 1)] & is_unique(s, best, smallest, params.uniqueness);
        let slot = if keep { xr } else { w };
        let offer = &mut held[slot];
        *offer = (*offer).min(u32::from(s[best]) << 16 | best as u32);
        let d = subpixel(s, best);
        *o = if keep { d } else { f32::NAN };
    }
    held.truncate(w);
    let tolerance = params.lr_max_diff as usize;
    for (x, o) in out.iter_mut().enumerate() {
        // The right pixel at disparity k disagrees when it holds an offer
        // more than the tolerance away (no offer, or outside the image:
        // no evidence against the left pixel). Selects, not branches, as
        // above; a NaN disparity stays NaN whatever they say.
        let disagrees = |k: usize| {
            let xr = x.wrapping_sub(k);
            let h = held[xr.min(w - 1)];
            let h = if xr < w { h } else { u32::MAX };
            (h != u32::MAX) & (((h & 0xFFFF) as usize).abs_diff(k) > tolerance)
        };
        let d = *o;
        let (lo, hi) = (d.floor() as usize, d.ceil() as usize);
        *o = if disagrees(lo) & disagrees(hi) {
            f32::NAN
        } else {
            d
        };
    }
}

/// OpenCV's `filterSpeckles`: 4-connected regions whose neighbours differ
/// by at most `max_diff` and that hold at most `max_size` pixels are set to
/// NaN. Bands of rows in parallel ([`filter_speckles_in_bands`]).
pub(crate) fn filter_speckles(
    disp: &mut [f32],
    w: usize,
    h: usize,
    max_size: usize,
    max_diff: f32,
) {
    let bands = rayon::current_num_threads().clamp(1, h.max(1));
    filter_speckles_in_bands(disp, w, h, max_size, max_diff, bands);
}

/// [`filter_speckles`] over `bands` bands of rows: each band's regions are
/// grown on their own (in parallel), then regions that touch across a
/// band boundary are joined (union-find) and their sizes added. The
/// neighbour relation is symmetric, so a region is the same set of pixels
/// wherever its growth starts: the result does not depend on `bands`
/// (tested).
pub(crate) fn filter_speckles_in_bands(
    disp: &mut [f32],
    w: usize,
    h: usize,
    max_size: usize,
    max_diff: f32,
    bands: usize,
) {
    if max_size == 0 || w == 0 || h == 0 {
        return;
    }
    let rows = h.div_ceil(bands.max(1));
    let mut label = vec![0u32; w * h];
    let image: &[f32] = disp;
    // Per band, each region's size (region i has label i + 1).
    let sizes: Vec<Vec<u32>> = label
        .par_chunks_mut(rows * w)
        .enumerate()
        .map(|(b, lab)| {
            let y0 = b * rows;
            grow_regions(&image[y0 * w..y0 * w + lab.len()], w, max_diff, lab)
        })
        .collect();
    let mut first = Vec::with_capacity(sizes.len());
    let mut size: Vec<u64> = Vec::new();
    for s in &sizes {
        first.push(size.len());
        size.extend(s.iter().map(|&n| u64::from(n)));
    }
    let id = |y: usize, l: u32| first[y / rows] + l as usize - 1;
    let mut parent: Vec<usize> = (0..size.len()).collect();
    for y in (rows..h).step_by(rows) {
        for x in 0..w {
            let (p, q) = ((y - 1) * w + x, y * w + x);
            if label[p] != 0 && label[q] != 0 && (image[q] - image[p]).abs() <= max_diff {
                let (a, b) = (
                    root(&mut parent, id(y - 1, label[p])),
                    root(&mut parent, id(y, label[q])),
                );
                if a != b {
                    parent[b] = a;
                    size[a] += size[b];
                }
            }
        }
    }
    let small: Vec<bool> = (0..size.len())
        .map(|i| size[root(&mut parent, i)] <= max_size as u64)
        .collect();
    disp.par_chunks_mut(w)
        .zip(label.par_chunks(w))
        .enumerate()
        .for_each(|(y, (row, lab))| {
            for (d, &l) in row.iter_mut().zip(lab) {
                if l != 0 && small[id(y, l)] {
                    *d = f32::NAN;
                }
            }
        });
}

/// The root of `i` in a union-find forest, halving the path on the way.
fn root(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// The regions of one band (`disp.len() / w` rows), grown from pixels in
/// row-major order into `label` (region i gets label i + 1, NaN pixels
/// 0); returns each region's size.
fn grow_regions(disp: &[f32], w: usize, max_diff: f32, label: &mut [u32]) -> Vec<u32> {
    let h = disp.len() / w;
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for start in 0..w * h {
        if label[start] != 0 || disp[start].is_nan() {
            continue;
        }
        let id = sizes.len() as u32 + 1;
        label[start] = id;
        stack.push(start);
        let mut n = 0u32;
        while let Some(p) = stack.pop() {
            n += 1;
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
        sizes.push(n);
    }
    sizes
}
