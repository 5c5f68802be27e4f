//! The census transform and the matching costs of a rectified pair
//! (Hamming distances of census codes), row by row: the sweeps of
//! `matching.rs` compute each row's costs where they need them.

use rayon::prelude::*;

use super::matching::RectifiedPair;
use crate::simd::SgmSimd;

/// Census transform: bit k of a pixel is set when the k-th pixel of its
/// window (row-major, centre skipped, coordinates clamped to the image)
/// is darker than the centre. Rows in parallel, each a [`census_row`].
pub(crate) fn census(
    img: &[f32],
    w: usize,
    h: usize,
    cw: usize,
    ch: usize,
    simd: SgmSimd,
) -> Vec<u64> {
    let mut out = vec![0u64; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        let job = CensusRow {
            img,
            w,
            h,
            y,
            cw,
            ch,
        };
        simd.census_row(&job, row);
    });
    out
}

/// One row of [`census`]: the image, the row and the window.
pub(crate) struct CensusRow<'a> {
    pub img: &'a [f32],
    pub w: usize,
    pub h: usize,
    pub y: usize,
    pub cw: usize,
    pub ch: usize,
}

/// The census codes of row `job.y` into `row` (`w` of them).
///
/// # Performance
/// The interior of the row (no clamping) goes [`CENSUS_LANES`] pixels at
/// a time, each block's two code words held in registers over all the
/// window's offsets: one shifted load, one compare and one masked or per
/// offset, where a pass per offset over the whole row would also load and
/// store the code words each time (the census took 9 % of the matcher).
/// Only the pixels within `cw / 2` of each end, and the remainder of the
/// last block, take the clamped per-offset loop.
// Always inlined: simd.rs compiles copies with AVX2 and AVX-512 enabled.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn census_row(job: &CensusRow, row: &mut [u64]) {
    census_row_with(job, row, census_block);
}

/// The window's row `dy` (clamped to the image) around row `job.y`.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn window_row<'a>(job: &CensusRow<'a>, dy: isize) -> &'a [f32] {
    let yy = (job.y as isize + dy).clamp(0, job.h as isize - 1) as usize;
    &job.img[yy * job.w..(yy + 1) * job.w]
}

/// The codes of the interior block of [`CENSUS_LANES`] pixels from `x0`
/// (every `x0 + i + dx` inside the row): both code words of the block
/// held over all the window's offsets.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn census_block(job: &CensusRow, x0: usize, out: &mut [u64; CENSUS_LANES]) {
    let (rx, ry) = (job.cw / 2, (job.ch / 2) as isize);
    let centre = window_row(job, 0);
    let Ok(c) = <&[f32; CENSUS_LANES]>::try_from(&centre[x0..x0 + CENSUS_LANES]) else {
        unreachable!("a slice of CENSUS_LANES elements")
    };
    let (mut lo, mut hi) = ([0u32; CENSUS_LANES], [0u32; CENSUS_LANES]);
    let mut k = 0u32;
    for dy in -ry..=ry {
        let src = window_row(job, dy);
        for dxi in 0..job.cw {
            if dxi == rx && dy == 0 {
                continue;
            }
            let at = x0 + dxi - rx;
            let Ok(s) = <&[f32; CENSUS_LANES]>::try_from(&src[at..at + CENSUS_LANES]) else {
                unreachable!("a slice of CENSUS_LANES elements")
            };
            // Two loops, not one through a reference to lo or hi: both
            // words then stay in registers.
            if k < 32 {
                let bit = 1u32 << k;
                for ((b, &sv), &cv) in lo.iter_mut().zip(s).zip(c) {
                    *b |= if sv < cv { bit } else { 0 };
                }
            } else {
                let bit = 1u32 << (k - 32);
                for ((b, &sv), &cv) in hi.iter_mut().zip(s).zip(c) {
                    *b |= if sv < cv { bit } else { 0 };
                }
            }
            k += 1;
        }
    }
    for ((o, &l), &hv) in out.iter_mut().zip(&lo).zip(&hi) {
        *o = u64::from(hv) << 32 | u64::from(l);
    }
}

/// [`census_row`] with the interior blocks' codes computed by `block`
/// ([`census_block`] or an equal vector version).
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn census_row_with<F>(job: &CensusRow, row: &mut [u64], block: F)
where
    F: Fn(&CensusRow, usize, &mut [u64; CENSUS_LANES]),
{
    let w = job.w;
    let (rx, ry) = (job.cw / 2, (job.ch / 2) as isize);
    let centre = window_row(job, 0);
    // Interior blocks: pixels x0 .. x0 + LANES with x0 >= rx and
    // x0 + LANES + rx <= w, so every x + dx lies in the row.
    let mut x0 = rx;
    while x0 + CENSUS_LANES + rx <= w {
        let Ok(out) = <&mut [u64; CENSUS_LANES]>::try_from(&mut row[x0..x0 + CENSUS_LANES]) else {
            unreachable!("a slice of CENSUS_LANES elements")
        };
        block(job, x0, out);
        x0 += CENSUS_LANES;
    }
    // The rest: 0 .. rx and x0 .. w, offset by offset with clamping.
    for x in (0..rx.min(w)).chain(x0.max(rx.min(w))..w) {
        let (mut lo, mut hi) = (0u32, 0u32);
        let mut k = 0u32;
        for dy in -ry..=ry {
            let src = window_row(job, dy);
            for dxi in 0..job.cw {
                if dxi == rx && dy == 0 {
                    continue;
                }
                let xx = (x as isize + dxi as isize - rx as isize).clamp(0, w as isize - 1);
                let set = src[xx as usize] < centre[x];
                if k < 32 {
                    lo |= u32::from(set) << k;
                } else {
                    hi |= u32::from(set) << (k - 32);
                }
                k += 1;
            }
        }
        row[x] = u64::from(hi) << 32 | u64::from(lo);
    }
}

/// Pixels per interior block of [`census_row`]: one AVX-512 register of
/// f32 (two of AVX2).
pub(crate) const CENSUS_LANES: usize = 16;

/// One row of the cost volume: `out[x * nd + k]` is the Hamming distance
/// between the census codes of left pixel x and right pixel x - k, or
/// `n_bits` (the largest cost) where either pixel lies outside its
/// original image.
// Always inlined: the copy inside simd.rs's `#[target_feature(enable =
// "avx2,popcnt")]` function then counts bits with `popcnt`.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn cost_row(
    cl: &[u64],
    cr: &[u64],
    left_valid: &[bool],
    right_valid: &[bool],
    n_bits: u8,
    scratch: &mut (Vec<u64>, Vec<u8>),
    out: &mut [u8],
) {
    cost_row_with(
        cl,
        cr,
        left_valid,
        right_valid,
        n_bits,
        scratch,
        out,
        cost_cells,
    );
}

/// One left pixel's costs against consecutive right pixels: `out[k]` is
/// the Hamming distance of `code` and `right[k]`, or `n_bits` where
/// `mask[k]` is 0xFF (a popcount is at most `n_bits`, so `(n | mask)
/// .min(n_bits)` needs no branch).
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn cost_cells(code: u64, right: &[u64], mask: &[u8], n_bits: u8, out: &mut [u8]) {
    for (c, (&r, &m)) in out.iter_mut().zip(right.iter().zip(mask)) {
        *c = ((code ^ r).count_ones() as u8 | m).min(n_bits);
    }
}

/// [`cost_row`] with each pixel's in-range costs computed by `cells`
/// ([`cost_cells`] or an equal vector version).
#[allow(clippy::inline_always, clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn cost_row_with<F>(
    cl: &[u64],
    cr: &[u64],
    left_valid: &[bool],
    right_valid: &[bool],
    n_bits: u8,
    scratch: &mut (Vec<u64>, Vec<u8>),
    out: &mut [u8],
    cells: F,
) where
    F: Fn(u64, &[u64], &[u8], u8, &mut [u8]),
{
    let w = cl.len();
    scratch.0.resize(w, 0);
    scratch.1.resize(w, 0);
    let nd = out.len() / w.max(1);
    // The right row reversed, so that left pixel x's candidates x, x - 1,
    // ..., x - k are consecutive (a forward loop that vectorises), and its
    // validity as a mask: a popcount is at most n_bits, so
    // `(n | mask).min(n_bits)` is n where the right pixel is valid and
    // n_bits where not, without a branch.
    let (rev, mask) = (&mut scratch.0[..w], &mut scratch.1[..w]);
    for ((r, m), (&c, &ok)) in rev
        .iter_mut()
        .zip(mask.iter_mut())
        .zip(cr.iter().zip(right_valid).rev())
    {
        *r = c;
        *m = if ok { 0 } else { 0xFF };
    }
    for (x, cell) in out.chunks_exact_mut(nd).enumerate() {
        if !left_valid[x] {
            cell.fill(n_bits);
            continue;
        }
        let reach = nd.min(x + 1);
        let (inside, outside) = cell.split_at_mut(reach);
        outside.fill(n_bits);
        // Index k is right pixel x - k, reversed slot w - 1 - x + k.
        let first = w - 1 - x;
        cells(
            cl[x],
            &rev[first..first + reach],
            &mask[first..first + reach],
            n_bits,
            inside,
        );
    }
}

/// The census codes of both images of a pair, and the largest cost
/// (window pixels but the centre).
pub(crate) struct PairCensus {
    pub left: Vec<u64>,
    pub right: Vec<u64>,
    pub n_bits: u8,
}

/// Both census transforms of a pair, side by side.
pub(crate) fn pair_census(pair: &RectifiedPair, cw: usize, ch: usize, simd: SgmSimd) -> PairCensus {
    let (w, h) = (pair.width, pair.height);
    let (left, right) = rayon::join(
        || census(&pair.left, w, h, cw, ch, simd),
        || census(&pair.right, w, h, cw, ch, simd),
    );
    PairCensus {
        left,
        right,
        n_bits: (cw * ch - 1) as u8,
    }
}

/// Row y's matching costs ([`cost_row`], `w * nd`) into `out`.
pub(crate) fn costs_of_row(
    codes: &PairCensus,
    pair: &RectifiedPair,
    y: usize,
    simd: SgmSimd,
    scratch: &mut (Vec<u64>, Vec<u8>),
    out: &mut [u8],
) {
    let r = y * pair.width..(y + 1) * pair.width;
    simd.cost_row(
        &codes.left[r.clone()],
        &codes.right[r.clone()],
        &pair.left_valid[r.clone()],
        &pair.right_valid[r],
        codes.n_bits,
        scratch,
        out,
    );
}

/// The cost volume `cost[(y * w + x) * n_disp + k]` of [`cost_row`]: the
/// sweeps compute each row's costs where they need them, this whole
/// volume is for the tests against the reference.
#[cfg(test)]
pub(crate) fn cost_volume(pair: &RectifiedPair, cw: usize, ch: usize, simd: SgmSimd) -> Vec<u8> {
    let (w, h, nd) = (pair.width, pair.height, pair.n_disp);
    let codes = pair_census(pair, cw, ch, simd);
    let mut cost = vec![0u8; w * h * nd];
    let mut scratch = (Vec::new(), Vec::new());
    for (y, row) in cost.chunks_mut(w * nd).enumerate() {
        costs_of_row(&codes, pair, y, simd, &mut scratch, row);
    }
    cost
}
