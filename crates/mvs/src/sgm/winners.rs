//! Winner-take-all over a row's aggregated sums with Hirschmüller's
//! checks, and OpenCV's speckle filter over the disparity image.

use super::matching::RectifiedPair;
use super::SgmParams;

/// Winner-take-all over one row's aggregated sums (`w * nd`) with
/// Hirschmüller's checks: uniqueness (the best sum at most `uniqueness`
/// times every sum two or more disparities away), parabola sub-pixel fit,
/// and left-right consistency against the right image's winners taken
/// from the same sums. The right winner is Hirschmüller's (PAMI 2008,
/// sec. 3.4): the smallest sum along the right pixel's whole epipolar
/// line. OpenCV's StereoSGBM differs here: a right pixel takes the
/// disparity of the best left winner landing on it (none: no check), and
/// a left pixel is rejected only when the right pixels at both the floor
/// and the ceiling of its disparity disagree, which keeps more pixels
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
/// (`x86::pick_512`), tested equal.
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
        let min = f32::from(s[best]);
        // Every sum two or more disparities away passes the ratio test
        // exactly when the smallest of them does (f32 products are
        // monotone).
        let rival = if smallest == u16::MAX {
            f32::INFINITY
        } else {
            f32::from(smallest)
        };
        let unique = min <= params.uniqueness * rival;
        let right_best = (held[w - 1 - (x - best)] & 0xFFFF) as usize;
        if !unique || right_best.abs_diff(best) > params.lr_max_diff as usize {
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
