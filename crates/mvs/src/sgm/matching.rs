//! Semi-global matching of a rectified pair (Hirschmüller, PAMI 2008):
//! census costs (computed row by row inside the sweeps, never stored as a
//! volume), aggregation along 4 or 8 scanlines, then
//! winner-take-all with the uniqueness, sub-pixel, left-right and speckle
//! steps. All sums are integers, so the result does not depend on the
//! order rows are processed in, nor on which of the two sweeps
//! ([`aggregate_and_pick`]) reaches a row first. `sgm/reference.rs` is the
//! same matcher written plainly; the tests hold this one to it bit for bit.

use std::sync::{Mutex, PoisonError};

use rayon::prelude::*;

use super::SgmParams;
use crate::simd::SgmSimd;

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
fn costs_of_row(
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

/// One step of a scanline: `cur[1..=nd]` from the previous pixel's
/// `prev[1..=nd]` (both padded with `BIG` at 0 and nd + 1) and its minimum
/// `prev_min`, Hirschmüller's recursion `L(p, d) = C(p, d) + min(L(p-r, d),
/// L(p-r, d±1) + P1, min L(p-r) + P2) - min L(p-r)`. Returns the minimum of
/// `cur`, which the next step needs.
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
#[allow(clippy::inline_always)]
#[inline(always)]
fn start(cost: &[u8], cur: &mut [u16]) -> u16 {
    let mut min = u16::MAX;
    for (c, &v) in cur[1..=cost.len()].iter_mut().zip(cost) {
        *c = u16::from(v);
        min = min.min(*c);
    }
    min
}

/// One row of a pass over the rows ([`aggregate`]): the fixed inputs.
pub(crate) struct RowPass<'a> {
    /// The row's matching costs, `w * nd`.
    pub cost: &'a [u8],
    pub nd: usize,
    /// The first row of the pass: every row-to-row path starts here.
    pub first: bool,
    pub p1: u16,
    pub p2: u16,
    /// The in-row path's direction: +1 left to right, -1 right to left.
    pub hdx: isize,
    /// The row-to-row paths: pixel x continues the previous row's x - dx.
    pub vdx: &'a [isize],
}

/// The per-path scanline buffers of a pass: the previous and current
/// rows' aggregated costs of each row-to-row path (`nd + 2` per pixel,
/// `BIG` at both ends) and their minima, and the in-row path's last two
/// pixels.
pub(crate) struct PassState {
    pub prev: Vec<u16>,
    pub cur: Vec<u16>,
    pub prev_min: Vec<u16>,
    pub cur_min: Vec<u16>,
    pub row: Vec<u16>,
}

/// Four scanline steps of one pixel (the in-row path and the three
/// row-to-row ones of an 8-path pass), each [`step`], and their sum into
/// `out`. Returns the four minima. simd.rs has the same in one AVX-512
/// loop over the disparities (`x86::step4_512`), tested equal.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn step4(
    cost: &[u8],
    prev: [&[u16]; 4],
    prev_min: [u16; 4],
    p1: u16,
    p2: u16,
    cur: [&mut [u16]; 4],
    out: &mut [u16],
) -> [u16; 4] {
    let [c0, c1, c2, c3] = cur;
    let mins = [
        step(cost, prev[0], prev_min[0], p1, p2, c0),
        step(cost, prev[1], prev_min[1], p1, p2, c1),
        step(cost, prev[2], prev_min[2], p1, p2, c2),
        step(cost, prev[3], prev_min[3], p1, p2, c3),
    ];
    let nd = cost.len();
    let cells = c0[1..].iter().zip(&c1[1..]).zip(&c2[1..]).zip(&c3[1..]);
    // At most 8 paths x (64 + 8000) < 65536: never wraps.
    for (s, (((&a, &b), &c), &d)) in out[..nd].iter_mut().zip(cells) {
        *s = a.wrapping_add(b).wrapping_add(c).wrapping_add(d);
    }
    mins
}

/// The sum over a pass's paths of one row's aggregated costs, into `out`
/// (`w * nd`); the current buffers of `st` are filled (the caller swaps).
// Always inlined: simd.rs compiles a copy with AVX2 enabled, 16 u16 lanes
// wide instead of the baseline's 8; the operations are the same.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn pass_row(job: &RowPass, st: &mut PassState, out: &mut [u16]) {
    pass_row_with(job, st, out, |c, q, m, p1, p2, cur, o| {
        step4(c, q, m, p1, p2, cur, o)
    });
}

/// [`pass_row`] with the four steps of an inside pixel of an 8-path pass
/// done by `four` ([`step4`] or an equal vector version).
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn pass_row_with<F>(job: &RowPass, st: &mut PassState, out: &mut [u16], four: F)
where
    F: Fn(&[u8], [&[u16]; 4], [u16; 4], u16, u16, [&mut [u16]; 4], &mut [u16]) -> [u16; 4],
{
    let (nd, pad) = (job.nd, job.nd + 2);
    let w = out.len() / nd;
    let (p1, p2) = (job.p1, job.p2);
    let (mut hprev, mut hcur) = st.row.split_at_mut(pad);
    let mut hmin = 0;
    for n in 0..w {
        let x = if job.hdx > 0 { n } else { w - 1 - n };
        let c = &job.cost[x * nd..(x + 1) * nd];
        let o = &mut out[x * nd..(x + 1) * nd];
        // 8 paths inside the image: the four steps in one loop over the
        // disparities ([`step4`]), the usual case.
        if n > 0 && !job.first && job.vdx == [0, 1, -1] && x >= 1 && x + 1 < w {
            let (v0, rest) = st.cur.split_at_mut(w * pad);
            let (v1, v2) = rest.split_at_mut(w * pad);
            let prev = |j: usize, px: usize| {
                let p = j * w + px;
                (&st.prev[p * pad..(p + 1) * pad], st.prev_min[p])
            };
            let (q1, m1) = prev(0, x);
            let (q2, m2) = prev(1, x - 1);
            let (q3, m3) = prev(2, x + 1);
            let mins = four(
                c,
                [hprev, q1, q2, q3],
                [hmin, m1, m2, m3],
                p1,
                p2,
                [
                    &mut *hcur,
                    &mut v0[x * pad..(x + 1) * pad],
                    &mut v1[x * pad..(x + 1) * pad],
                    &mut v2[x * pad..(x + 1) * pad],
                ],
                o,
            );
            hmin = mins[0];
            for (j, &m) in mins[1..].iter().enumerate() {
                st.cur_min[j * w + x] = m;
            }
            std::mem::swap(&mut hprev, &mut hcur);
            continue;
        }
        hmin = if n == 0 {
            start(c, hcur)
        } else {
            step(c, hprev, hmin, p1, p2, hcur)
        };
        for (j, &dx) in job.vdx.iter().enumerate() {
            let at = j * w + x;
            let cell = &mut st.cur[at * pad..(at + 1) * pad];
            let px = x as isize - dx;
            st.cur_min[at] = if job.first || px < 0 || px >= w as isize {
                start(c, cell)
            } else {
                let p = j * w + px as usize;
                step(
                    c,
                    &st.prev[p * pad..(p + 1) * pad],
                    st.prev_min[p],
                    p1,
                    p2,
                    cell,
                )
            };
        }
        // The pass's sum in one go (the paths' cells are in L1). At most
        // 8 paths x (64 + 8000) < 65536: never wraps.
        let cell = |j: usize| &st.cur[(j * w + x) * pad + 1..(j * w + x) * pad + 1 + nd];
        let hs = &hcur[1..=nd];
        if job.vdx.len() == 3 {
            let (a, b, d) = (cell(0), cell(1), cell(2));
            for ((((s, &v), &va), &vb), &vd) in o.iter_mut().zip(hs).zip(a).zip(b).zip(d) {
                *s = v.wrapping_add(va).wrapping_add(vb).wrapping_add(vd);
            }
        } else {
            o.copy_from_slice(hs);
            for j in 0..job.vdx.len() {
                for (s, &v) in o.iter_mut().zip(cell(j)) {
                    *s = s.wrapping_add(v);
                }
            }
        }
        std::mem::swap(&mut hprev, &mut hcur);
    }
}

/// One pass over the rows, top to bottom (`forward`) or bottom to top:
/// hands `row_done(y, sums)` the sum of its paths' aggregated costs of
/// each row y (`w * nd`, laid out like the cost volume), which the sink
/// may keep (swapping in another buffer of the same length). The forward
/// pass holds the paths going right, down, down-right and down-left
/// (right and down with 4 paths), the backward one their opposites, so
/// the two passes together are Hirschmüller's 8 (or 4).
#[allow(clippy::too_many_arguments)]
fn sweep(
    codes: &PairCensus,
    pair: &RectifiedPair,
    params: &SgmParams,
    forward: bool,
    simd: SgmSimd,
    row_done: &mut dyn FnMut(usize, &mut Vec<u16>),
) {
    let (w, h, nd) = (pair.width, pair.height, pair.n_disp);
    let vdx: &[isize] = if params.paths == 4 { &[0] } else { &[0, 1, -1] };
    let pad = nd + 2;
    let cells = vdx.len() * w * pad;
    let mut st = PassState {
        prev: vec![BIG; cells],
        cur: vec![BIG; cells],
        prev_min: vec![0; vdx.len() * w],
        cur_min: vec![0; vdx.len() * w],
        row: vec![BIG; 2 * pad],
    };
    let mut out = vec![0u16; w * nd];
    let mut cost = vec![0u8; w * nd];
    let mut scratch = (Vec::new(), Vec::new());
    for n in 0..h {
        let y = if forward { n } else { h - 1 - n };
        costs_of_row(codes, pair, y, simd, &mut scratch, &mut cost);
        let job = RowPass {
            cost: &cost,
            nd,
            first: n == 0,
            p1: params.p1,
            p2: params.p2,
            hdx: if forward { 1 } else { -1 },
            vdx,
        };
        simd.pass_row(&job, &mut st, &mut out);
        std::mem::swap(&mut st.prev, &mut st.cur);
        std::mem::swap(&mut st.prev_min, &mut st.cur_min);
        row_done(y, &mut out);
    }
}

/// The two passes' sums, each as a volume laid out like the cost volume
/// (their sum is Hirschmüller's sum over the paths): the reference the
/// fused [`aggregate_and_pick`] is tested against.
#[cfg(test)]
pub(crate) fn aggregate(
    pair: &RectifiedPair,
    params: &SgmParams,
    simd: SgmSimd,
) -> (Vec<u16>, Vec<u16>) {
    let (w, h, nd) = (pair.width, pair.height, pair.n_disp);
    let (cw, ch) = (params.census_width as usize, params.census_height as usize);
    let codes = pair_census(pair, cw, ch, simd);
    let pass = |forward: bool| {
        let mut sum = vec![0u16; w * h * nd];
        sweep(&codes, pair, params, forward, simd, &mut |y, row| {
            sum[y * w * nd..(y + 1) * w * nd].copy_from_slice(row);
        });
        sum
    };
    (pass(true), pass(false))
}

/// Aggregation and winner-take-all in one go: the forward and backward
/// passes run side by side (two threads, each a sweep that depends on its
/// previous row) and meet in the middle. The first pass to finish a row
/// leaves its sums there; the second adds its own and picks the row's
/// winners ([`winner_row`]) while the row is in cache. Integer sums: the
/// result does not depend on which pass came first, nor on the threads.
///
/// # Performance
/// Each sweep computes a row's census costs where it needs them (a row of
/// `w * nd` bytes in cache; popcounts are cheap, memory traffic is not);
/// only the rows one pass has finished and the other has not reached are
/// kept (about half the image when both run at once), instead of a sum
/// volume per path or per pass. AVX2 or AVX-512 (detected at run time)
/// only change the code generation of the rows, not their result.
pub(crate) fn aggregate_and_pick(
    codes: &PairCensus,
    pair: &RectifiedPair,
    params: &SgmParams,
    simd: SgmSimd,
) -> Vec<f32> {
    let (w, h, nd) = (pair.width, pair.height, pair.n_disp);
    let meet: Vec<Mutex<Option<Vec<u16>>>> = (0..h).map(|_| Mutex::new(None)).collect();
    // Rows the second pass has used go back here for the first one to
    // fill again (every cell of a row is written before it is read), and
    // rows of an earlier pair of the same size ([`SPARE_ROWS`]).
    let mut kept = std::mem::take(&mut *lock(&SPARE_ROWS));
    kept.retain(|r| r.len() == w * nd);
    let spare: Mutex<Vec<Vec<u16>>> = Mutex::new(kept);
    let disp = Mutex::new(vec![f32::NAN; w * h]);
    let pass = |forward: bool| {
        let mut picked = vec![f32::NAN; w];
        let mut held = Vec::new();
        sweep(codes, pair, params, forward, simd, &mut |y, row| {
            let other = {
                let mut slot = lock(&meet[y]);
                let other = slot.take();
                if other.is_none() {
                    let fresh = lock(&spare).pop().unwrap_or_else(|| vec![0u16; w * nd]);
                    *slot = Some(std::mem::replace(row, fresh));
                }
                other
            };
            if let Some(other) = other {
                // At most 8 paths x (64 + 8000) < 65536: never wraps.
                for (s, &v) in row.iter_mut().zip(&other) {
                    *s = s.wrapping_add(v);
                }
                simd.winner_row(row, y, pair, params, &mut held, &mut picked);
                lock(&disp)[y * w..(y + 1) * w].copy_from_slice(&picked);
                lock(&spare).push(other);
            }
        });
    };
    rayon::join(|| pass(true), || pass(false));
    let mut kept = spare.into_inner().unwrap_or_else(PoisonError::into_inner);
    kept.truncate(KEEP_BYTES / (2 * w * nd).max(1));
    *lock(&SPARE_ROWS) = kept;
    disp.into_inner().unwrap_or_else(PoisonError::into_inner)
}

/// Rows of sums kept from one matcher run to the next, as StereoSGBM keeps
/// its buffer in its object: a run of the same size (the next pair of a
/// workspace, the next frame) then fills them instead of zeroing fresh
/// memory, about 1 byte per cell. Whole rows are overwritten before they
/// are read, so the results do not depend on what they held.
static SPARE_ROWS: Mutex<Vec<Vec<u16>>> = Mutex::new(Vec::new());

/// Most bytes [`SPARE_ROWS`] keeps between runs.
const KEEP_BYTES: usize = 64 << 20;

/// The lock of `m`, also after a panic elsewhere (the data are plain
/// sums, whole after any panic).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

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

/// The whole matcher: disparity indices of the left image (NaN where none).
pub(crate) fn match_pair(pair: &RectifiedPair, params: &SgmParams) -> Vec<f32> {
    let (cw, ch) = (params.census_width as usize, params.census_height as usize);
    let simd = SgmSimd::detect();
    let codes = pair_census(pair, cw, ch, simd);
    let mut disp = aggregate_and_pick(&codes, pair, params, simd);
    drop(codes);
    filter_speckles(
        &mut disp,
        pair.width,
        pair.height,
        params.speckle_size as usize,
        params.speckle_range,
    );
    disp
}
