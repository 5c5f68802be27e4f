//! Semi-global matching of a rectified pair (Hirschmüller, PAMI 2008):
//! census costs (computed row by row inside the sweeps, never stored as a
//! volume), aggregation along 4 or 8 scanlines, then
//! winner-take-all with the uniqueness, sub-pixel, left-right and speckle
//! steps. All sums are integers, so the result does not depend on the
//! order rows are processed in, nor on which of the two sweeps
//! ([`aggregate_and_pick`]) reaches a row first. `sgm/reference.rs` is the
//! same matcher written plainly; the tests hold this one to it bit for bit.

use std::sync::{Mutex, PoisonError};

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

use super::costs::costs_of_row;
#[cfg(test)]
pub(crate) use super::costs::{census, cost_volume};
pub(crate) use super::costs::{
    census_row, census_row_with, cost_cells, cost_row, cost_row_with, pair_census, window_row,
    CensusRow, PairCensus,
};
pub(crate) use super::winners::{filter_speckles, winner_row, winner_row_with};

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
    /// The other pass's sums of this row (`w * nd`), added to this pass's
    /// as each pixel is done (the row's total, ready for its winners), or
    /// empty.
    pub other: &'a [u16],
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
/// `out`, plus `extra` (the other pass's sums of the pixel) unless that
/// is empty. Returns the four minima. simd.rs has the same in one AVX-512
/// loop over the disparities (`sgm_kernels::step4_512`), tested equal.
#[allow(clippy::inline_always, clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn step4(
    cost: &[u8],
    prev: [&[u16]; 4],
    prev_min: [u16; 4],
    p1: u16,
    p2: u16,
    cur: [&mut [u16]; 4],
    out: &mut [u16],
    extra: &[u16],
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
    add_extra(&mut out[..nd], extra);
    mins
}

/// `out += extra` (wrapping, as the sums; nothing when `extra` is empty):
/// the other pass's sums of a pixel, added while its cells are in L1.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn add_extra(out: &mut [u16], extra: &[u16]) {
    // At most 8 paths x (64 + 8000) < 65536: never wraps.
    for (s, &v) in out.iter_mut().zip(extra) {
        *s = s.wrapping_add(v);
    }
}

/// The sum over a pass's paths of one row's aggregated costs, into `out`
/// (`w * nd`); the current buffers of `st` are filled (the caller swaps).
// Always inlined: simd.rs compiles a copy with AVX2 enabled, 16 u16 lanes
// wide instead of the baseline's 8; the operations are the same.
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn pass_row(job: &RowPass, st: &mut PassState, out: &mut [u16]) {
    pass_row_with(job, st, out, |c, q, m, p1, p2, cur, o, e| {
        step4(c, q, m, p1, p2, cur, o, e)
    });
}

/// [`pass_row`] with the four steps of an inside pixel of an 8-path pass
/// done by `four` ([`step4`] or an equal vector version).
#[allow(clippy::inline_always)]
#[inline(always)]
pub(crate) fn pass_row_with<F>(job: &RowPass, st: &mut PassState, out: &mut [u16], four: F)
where
    F: Fn(&[u8], [&[u16]; 4], [u16; 4], u16, u16, [&mut [u16]; 4], &mut [u16], &[u16]) -> [u16; 4],
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
        let extra = job.other.get(x * nd..(x + 1) * nd).unwrap_or(&[]);
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
                extra,
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
        add_extra(o, extra);
        std::mem::swap(&mut hprev, &mut hcur);
    }
}

/// [`sweep`]'s sink of finished rows: (y, the row's sums, the other
/// pass's row that was added to them, if any).
type RowDone<'a> = dyn FnMut(usize, &mut Vec<u16>, Option<Vec<u16>>) + 'a;

/// One pass over the rows, top to bottom (`forward`) or bottom to top:
/// asks `before(y)` for the other pass's sums of row y (`None`: not
/// there yet), then hands `row_done(y, sums, other)` the sum of its
/// paths' aggregated costs of the row (`w * nd`, laid out like the cost
/// volume; the total of both passes when `other` is the row `before`
/// gave), which the sink may keep (swapping in another buffer of the same
/// length). The forward pass holds the paths going right, down,
/// down-right and down-left (right and down with 4 paths), the backward
/// one their opposites, so the two passes together are Hirschmüller's 8
/// (or 4).
#[allow(clippy::too_many_arguments)]
fn sweep(
    codes: &PairCensus,
    pair: &RectifiedPair,
    params: &SgmParams,
    forward: bool,
    simd: SgmSimd,
    before: &mut dyn FnMut(usize) -> Option<Vec<u16>>,
    row_done: &mut RowDone,
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
        let other = before(y);
        let job = RowPass {
            cost: &cost,
            nd,
            first: n == 0,
            p1: params.p1,
            p2: params.p2,
            hdx: if forward { 1 } else { -1 },
            vdx,
            other: other.as_deref().unwrap_or(&[]),
        };
        simd.pass_row(&job, &mut st, &mut out);
        std::mem::swap(&mut st.prev, &mut st.cur);
        std::mem::swap(&mut st.prev_min, &mut st.cur_min);
        row_done(y, &mut out, other);
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
        sweep(
            &codes,
            pair,
            params,
            forward,
            simd,
            &mut |_| None,
            &mut |y, row, _| {
                sum[y * w * nd..(y + 1) * w * nd].copy_from_slice(row);
            },
        );
        sum
    };
    (pass(true), pass(false))
}

/// Aggregation and winner-take-all in one go: the forward and backward
/// passes run side by side (two threads, each a sweep that depends on its
/// previous row) and meet in the middle. The first pass to finish a row
/// leaves its sums there; the second, finding them before it starts the
/// row, adds them to its own pixel by pixel as it goes (after the row
/// when both started it at once) and picks the row's winners
/// ([`winner_row`]) while the row is in cache. Integer sums: the
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
        // The other pass's row when it is already there: this pass adds
        // it pixel by pixel while its own sums are in L1 (no second trip
        // over the row), then picks the winners.
        let mut before = |y: usize| lock(&meet[y]).take();
        let mut done = |y: usize, row: &mut Vec<u16>, added: Option<Vec<u16>>| {
            if let Some(used) = added {
                lock(&spare).push(used);
            } else {
                // Not there before this row: leave this pass's sums for
                // the other, unless it arrived meanwhile.
                let mut slot = lock(&meet[y]);
                let Some(other) = slot.take() else {
                    let fresh = lock(&spare).pop().unwrap_or_else(|| vec![0u16; w * nd]);
                    *slot = Some(std::mem::replace(row, fresh));
                    return;
                };
                drop(slot);
                add_extra(row, &other);
                lock(&spare).push(other);
            }
            simd.winner_row(row, y, pair, params, &mut held, &mut picked);
            lock(&disp)[y * w..(y + 1) * w].copy_from_slice(&picked);
        };
        sweep(codes, pair, params, forward, simd, &mut before, &mut done);
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
