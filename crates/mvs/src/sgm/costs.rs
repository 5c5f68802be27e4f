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
    out.par_chunks_mut(w).enumerate().for_each_init(
        || (vec![0u32; w], vec![0u32; w]),
        |(lo_bits, hi_bits), (y, row)| {
            let job = CensusRow {
                img,
                w,
                h,
                y,
                cw,
                ch,
            };
            simd.census_row(&job, lo_bits, hi_bits, row);
        },
    );
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

/// The census codes of row `job.y` into `row` (`w` of them); `lo_bits`
/// and `hi_bits` are scratch rows of `w` words (any contents), reused
/// from row to row.
///
/// # Performance
/// One window offset at a time over a whole row: the interior of the row
/// (no clamping) is a straight compare-and-or loop that LLVM vectorises;
/// only the `cw / 2` pixels at each end take the clamped index.
// Always inlined: simd.rs compiles copies with AVX2 and AVX-512 enabled.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn census_row(
    job: &CensusRow,
    lo_bits: &mut [u32],
    hi_bits: &mut [u32],
    row: &mut [u64],
) {
    let (img, w, h, y) = (job.img, job.w, job.h, job.y);
    let (rx, ry) = ((job.cw / 2) as isize, (job.ch / 2) as isize);
    let centre = &img[y * w..(y + 1) * w];
    // Bits 0..32 and 32..64 in two u32 words: a float comparison is a
    // 32-bit mask, so eight pixels fit one AVX2 register (four as u64).
    lo_bits.fill(0);
    hi_bits.fill(0);
    let mut k = 0;
    for dy in -ry..=ry {
        let yy = (y as isize + dy).clamp(0, h as isize - 1) as usize;
        let src = &img[yy * w..(yy + 1) * w];
        for dx in -rx..=rx {
            if dx == 0 && dy == 0 {
                continue;
            }
            let bits = if k < 32 { &mut *lo_bits } else { &mut *hi_bits };
            let bit = 1u32 << (k % 32);
            // Pixels x whose neighbour x + dx lies inside the row.
            let lo = (-dx).clamp(0, w as isize) as usize;
            let hi = (w as isize - dx).clamp(lo as isize, w as isize) as usize;
            let shifted = &src[(lo as isize + dx) as usize..(hi as isize + dx) as usize];
            for ((c, &m), &s) in bits[lo..hi].iter_mut().zip(&centre[lo..hi]).zip(shifted) {
                *c |= if s < m { bit } else { 0 };
            }
            for x in (0..lo).chain(hi..w) {
                let xx = (x as isize + dx).clamp(0, w as isize - 1) as usize;
                bits[x] |= if src[xx] < centre[x] { bit } else { 0 };
            }
            k += 1;
        }
    }
    for ((c, &l), &h) in row.iter_mut().zip(&*lo_bits).zip(&*hi_bits) {
        *c = u64::from(h) << 32 | u64::from(l);
    }
}

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
        let code = cl[x];
        let right = rev[first..first + reach]
            .iter()
            .zip(&mask[first..first + reach]);
        for (c, (&r, &m)) in inside.iter_mut().zip(right) {
            *c = ((code ^ r).count_ones() as u8 | m).min(n_bits);
        }
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
