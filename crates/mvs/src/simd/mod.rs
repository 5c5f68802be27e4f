//! The full-window NCC sums and the reference patch's build with AVX2:
//! the one place of vp-mvs with `unsafe` code.
//!
//! Why: the sums' time goes mostly to the four bilinear taps of each window
//! sample, read one by one from indices the vectorised coordinate code has
//! to spill first (docs/performance.md, "vp-mvs, one 1024x1024 triplet").
//! The AVX2 code computes eight samples' indices at once and reads each
//! sample's two taps of a row as one 64-bit load (AVX2 gathers did the
//! same at 1.05x the time). `std::arch`'s loads, stores and the call into a
//! `#[target_feature]` function are `unsafe`; the
//! workspace denies unsafe code everywhere else, and here it follows the
//! team's rules:
//! - AVX2 is detected at run time ([`Avx2::detect`]); the token proving it
//!   is the only way to reach the AVX2 code, and the safe scalar loop in
//!   `cost.rs` remains the path on other CPUs and architectures;
//! - every tap index is clamped in-register to the image's bounds, so no
//!   input (a wrong homography, NaN coordinates, padding lanes) can read
//!   outside the slice, whatever the callers' invariants;
//! - every other vector load is from a bounds-checked fixed-size array;
//! - no FMA: every lane does the scalar loop's operations in the same order,
//!   so the sums are bit for bit the scalar ones (tested in `cost.rs`).
//!
//! The reference patch's build ([`Avx2::build_patch`]) is the safe
//! `cost::RefPatch::fill` compiled a second time with AVX2 enabled, so that
//! its bilateral weights' `exp` runs 8 lanes wide (0.965 of the CPU time on
//! `fast_256`), with AVX2's `cost::PatchKernels`: the window's intensities
//! read by one masked gather per chunk (each lane's index tested against
//! the image slice in-register; lanes outside read nothing) and the
//! moments on whole vectors. Those cut the build's instructions from
//! 1,042 to 587 (a bounds-checked load per sample was a third of them, and
//! the compiler kept the moments 2 lanes wide); the bits are the same
//! (tested in `cost.rs`).
//!
//! The semi-global matcher's row of a scanline pass ([`Avx2::sgm_pass_row`]),
//! row of winners ([`Avx2::sgm_winner_row`]) and row of census costs
//! ([`Avx2::sgm_cost_row`]) are the safe scalar `sgm::matching::pass_row`,
//! `winner_row` and `cost_row` compiled a second time with
//! AVX2 (and `popcnt` for the costs) enabled, so that LLVM vectorises the
//! aggregation 16 u16 lanes wide instead of the baseline's 8 and counts
//! bits in one instruction: the only `unsafe` is the call into the
//! `#[target_feature]` function, under the same detected token (and a
//! detected `popcnt`); the operations are integer and identical, so the
//! results are the scalar ones (tested in `sgm/tests.rs`).
//! Those and the AVX-512 copies (F, BW, VL, VPOPCNTDQ, runtime-detected
//! as a second token, [`sgm::Avx512`]) live in `simd/sgm.rs`, the
//! matcher's intrinsics kernels in `simd/sgm_kernels.rs`, under the same
//! rules; [`SgmSimd`] picks the widest level the CPU has.
//!
//! The sums of a window cut by the image border (`cost::sums_partial`,
//! eight samples' coordinates, range tests and bilinear taps at once, the
//! taps by clamped gathers) live in `simd/partial.rs`, under the same
//! rules and the same token.
#![allow(unsafe_code)]
// Off x86-64 the token is never made and the window's fields never read.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use crate::cost::CHUNK;

mod partial;
mod sgm;
#[cfg(target_arch = "x86_64")]
mod sgm_kernels;
pub(crate) use partial::CutWindow;
pub(crate) use sgm::SgmSimd;

/// Proof that the running CPU has AVX2 (only [`Avx2::detect`] makes one).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Avx2 {
    _private: (),
}

/// Everything the full-window sums read, with the window's origin already
/// warped: `origin` is the homogeneous source position of the first sample.
/// The window is in `cost::Window`'s packed layout: lane `k` of `w`, `wr`,
/// `lane_x` and `lane_y` is one sample, the first `samples` of them count
/// and the rest are padding.
pub(crate) struct FullWindow<'a> {
    /// Bilateral weights, a multiple of [`CHUNK`] lanes.
    pub w: &'a [f32],
    /// Weight times mean-free reference intensity, laid out like `w`.
    pub wr: &'a [f32],
    /// Offset of each lane from the first sample, x and y, reference pixels.
    pub lane_x: &'a [f32],
    pub lane_y: &'a [f32],
    /// Lanes that count (the rest are padding).
    pub samples: usize,
    pub origin: [f32; 3],
    pub h: &'a [f32; 9],
    /// The source image, row-major, `width` pixels a row.
    pub data: &'a [f32],
    pub width: usize,
}

impl Avx2 {
    /// `Some` when the running CPU has AVX2.
    pub(crate) fn detect() -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Some(Avx2 { _private: () });
        }
        None
    }

    /// The sums (w s, w s^2, w r s) of `cost::sums_full`, the same bits;
    /// `None` for shapes the vector code does not take (then the caller
    /// runs the scalar loop).
    #[allow(clippy::unused_self)] // `self` is the proof that AVX2 is there
    pub(crate) fn sums_full(self, win: &FullWindow) -> Option<[f32; 3]> {
        let lanes = win.w.len();
        let ok = CHUNK == 8
            && lanes.is_multiple_of(CHUNK)
            && win.samples <= lanes
            && win.wr.len() == lanes
            && win.lane_x.len() == lanes
            && win.lane_y.len() == lanes
            && win.data.len() >= win.width + 2
            && i32::try_from(win.data.len()).is_ok();
        if !ok {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only if `detect` found AVX2 on this CPU,
            // the one feature `x86::sums_full` is compiled for.
            Some(unsafe { x86::sums_full(win) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = self;
            None
        }
    }
}

impl Avx2 {
    /// `cost::RefPatch::fill` with AVX2 code generation: the same result.
    #[allow(clippy::unused_self)] // `self` is the proof that AVX2 is there
    pub(crate) fn build_patch(
        self,
        patch: &mut crate::cost::RefPatch,
        image: &crate::view::GreyImage,
        (x, y): (usize, usize),
        win: &crate::cost::Window,
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only if `detect` found AVX2 on this CPU,
            // the one feature `x86::build_patch` is compiled for; its body
            // is safe code.
            unsafe { x86::build_patch(patch, image, (x, y), win) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = self;
            patch.fill(image, x, y, win, &crate::cost::Scalar);
        }
    }
}

/// The patch build's gather and moments on AVX2: the same values as
/// `cost::Scalar`'s (tested in `cost.rs`).
impl crate::cost::PatchKernels for Avx2 {
    #[allow(clippy::inline_always)] // inlined into the AVX2 patch build
    #[inline(always)]
    fn gather(&self, region: &[f32], taps: &[[i32; CHUNK]], out: &mut [[f32; CHUNK]]) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only if `detect` found AVX2 on this CPU,
            // the one feature `x86::gather` is compiled for.
            unsafe { x86::gather(region, taps, out) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        crate::cost::PatchKernels::gather(&crate::cost::Scalar, region, taps, out);
    }

    #[allow(clippy::inline_always)] // inlined into the AVX2 patch build
    #[inline(always)]
    fn moments(&self, w: &[[f32; CHUNK]], wr: &mut [[f32; CHUNK]]) -> (f32, f32) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: as in `gather`, for `x86::moments`.
            unsafe { x86::moments(w, wr) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        crate::cost::PatchKernels::moments(&crate::cost::Scalar, w, wr)
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::FullWindow;
    use crate::cost::CHUNK;
    use std::arch::x86_64::{
        __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_and_ps, _mm256_andnot_si256,
        _mm256_castpd_ps, _mm256_castps256_ps128, _mm256_castsi256_ps, _mm256_cmpgt_epi32,
        _mm256_cvttps_epi32, _mm256_div_ps, _mm256_extractf128_ps, _mm256_floor_ps,
        _mm256_loadu_ps, _mm256_loadu_si256, _mm256_mask_i32gather_ps, _mm256_max_epi32,
        _mm256_min_epi32, _mm256_mul_ps, _mm256_mullo_epi32, _mm256_set1_epi32, _mm256_set1_ps,
        _mm256_setr_epi32, _mm256_setr_pd, _mm256_setzero_ps, _mm256_setzero_si256,
        _mm256_shuffle_ps, _mm256_storeu_ps, _mm256_storeu_si256, _mm256_sub_ps, _mm_add_ps,
        _mm_add_ss, _mm_cvtss_f32, _mm_movehl_ps, _mm_shuffle_ps,
    };

    /// See [`super::Avx2::build_patch`]: safe code compiled for AVX2, with
    /// AVX2's gather and moments ([`gather`], [`moments`]).
    #[target_feature(enable = "avx2")]
    pub(super) fn build_patch(
        patch: &mut crate::cost::RefPatch,
        image: &crate::view::GreyImage,
        (x, y): (usize, usize),
        win: &crate::cost::Window,
    ) {
        patch.fill(image, x, y, win, &super::Avx2 { _private: () });
    }

    /// `cost::Scalar::gather` with one AVX2 gather per chunk: the same
    /// values (a tap outside `region` reads 0), about a tenth of the
    /// instructions of a bounds-checked load per sample (those were a
    /// third of the patch build's).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn gather(region: &[f32], taps: &[[i32; CHUNK]], out: &mut [[f32; CHUNK]]) {
        let Ok(len) = i32::try_from(region.len()) else {
            crate::cost::PatchKernels::gather(&crate::cost::Scalar, region, taps, out);
            return;
        };
        let len = _mm256_set1_epi32(len);
        let zero = _mm256_setzero_si256();
        for (t, o) in taps.iter().zip(out) {
            // SAFETY: `t` is 8 readable i32s; the load is unaligned.
            let t = unsafe { _mm256_loadu_si256(t.as_ptr().cast()) };
            // Lanes in [0, len): the others keep 0 and read nothing.
            let inside =
                _mm256_andnot_si256(_mm256_cmpgt_epi32(zero, t), _mm256_cmpgt_epi32(len, t));
            // SAFETY: the gather reads `region` only at the lanes whose
            // mask bit is set, each an index in [0, region.len()).
            let v = unsafe {
                _mm256_mask_i32gather_ps::<4>(
                    _mm256_setzero_ps(),
                    region.as_ptr(),
                    t,
                    _mm256_castsi256_ps(inside),
                )
            };
            // SAFETY: `o` is 8 writable floats; the store is unaligned.
            unsafe { _mm256_storeu_ps(o.as_mut_ptr(), v) };
        }
    }

    /// `cost::Scalar::moments` on whole vectors: every lane the same
    /// operations in the same order, the lanes added up by [`total`]
    /// (`cost::lane_total`'s order), so the same bits.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(super) fn moments(w: &[[f32; CHUNK]], wr: &mut [[f32; CHUNK]]) -> (f32, f32) {
        let (mut sw, mut swv) = (_mm256_setzero_ps(), _mm256_setzero_ps());
        for (cw, cv) in w.iter().zip(wr.iter()) {
            let cw = load(cw);
            sw = _mm256_add_ps(sw, cw);
            swv = _mm256_add_ps(swv, _mm256_mul_ps(cw, load(cv)));
        }
        let sw = total(sw);
        let mean = _mm256_set1_ps(total(swv) / sw);
        let mut var = _mm256_setzero_ps();
        for (cw, cr) in w.iter().zip(wr.iter_mut()) {
            let r = _mm256_sub_ps(load(cr), mean);
            let t = _mm256_mul_ps(load(cw), r);
            var = _mm256_add_ps(var, _mm256_mul_ps(t, r));
            // SAFETY: `cr` is 8 writable floats; the store is unaligned.
            unsafe { _mm256_storeu_ps(cr.as_mut_ptr(), t) };
        }
        (sw, total(var))
    }

    /// Eight floats from a bounds-checked array.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(a: &[f32; CHUNK]) -> __m256 {
        // SAFETY: `a` is 8 readable floats; the load is unaligned.
        unsafe { _mm256_loadu_ps(a.as_ptr()) }
    }

    /// Floor of every lane, as floats and as integers. For `|x| < 2^22`,
    /// the only coordinates the caller's corner test lets through, these
    /// are the bits of the scalar loop's `floor_small`; other lanes (NaN,
    /// huge) give some integer, which the caller clamps.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn floor(x: __m256) -> (__m256, __m256i) {
        let f = _mm256_floor_ps(x);
        (f, _mm256_cvttps_epi32(f))
    }

    /// Every lane's top-left tap index, in range so that its four taps
    /// (+0, +1, +sw, +sw + 1) lie inside the image: made only by
    /// [`TapIndex::clamped`], which is what makes [`taps`]' reads safe.
    #[derive(Clone, Copy)]
    struct TapIndex([u32; CHUNK]);

    impl TapIndex {
        /// `i0` clamped to `[0, data.len() - sw - 2]`; the caller checked
        /// that this range is not empty and that `data.len()` fits in an
        /// i32.
        #[inline]
        #[target_feature(enable = "avx2")]
        fn clamped(i0: __m256i, data: &[f32], sw: usize) -> Self {
            let last = _mm256_set1_epi32((data.len() - sw - 2) as i32);
            let i0 = _mm256_min_epi32(_mm256_max_epi32(i0, _mm256_setzero_si256()), last);
            let mut idx = [0u32; CHUNK];
            // SAFETY: `idx` is 8 writable u32s (the lanes are in [0, i32::MAX]
            // after the clamp, so the same values); the store is unaligned.
            unsafe { _mm256_storeu_si256(idx.as_mut_ptr().cast(), i0) };
            TapIndex(idx)
        }
    }

    /// See [`super::Avx2::sums_full`]; the caller checked the shapes.
    ///
    /// Each chunk is one long chain (a division, the floor, the index, the
    /// loads, the interpolation). The loop is software-pipelined: the next
    /// chunk's coordinates, fractions and tap indices are computed before
    /// this chunk's taps are read, so that the loads of one chunk overlap
    /// the arithmetic of the next instead of waiting on it, with no arrays
    /// of them to fill (an earlier version computed a group of 8 chunks'
    /// first, and zeroed those arrays, 24 vectors, on every call: a tenth
    /// of the kernel's instructions). The sums are taken chunk after chunk
    /// as in the scalar loop.
    #[target_feature(enable = "avx2")]
    pub(super) fn sums_full(win: &FullWindow) -> [f32; 3] {
        let h = win.h;
        let [a0, b0, c0] = win.origin;
        let sw = win.width;
        let data = win.data;
        let sw_i = _mm256_set1_epi32(sw as i32);
        let (hx0, hx1, hx3, hx4, hx6, hx7) = (
            _mm256_set1_ps(h[0]),
            _mm256_set1_ps(h[1]),
            _mm256_set1_ps(h[3]),
            _mm256_set1_ps(h[4]),
            _mm256_set1_ps(h[6]),
            _mm256_set1_ps(h[7]),
        );
        let (a0, b0, c0) = (_mm256_set1_ps(a0), _mm256_set1_ps(b0), _mm256_set1_ps(c0));
        let (one, half) = (_mm256_set1_ps(1.0), _mm256_set1_ps(0.5));
        let lane_ids = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        // The window in whole chunks (the caller checked that every array
        // has the same multiple of CHUNK lanes).
        let (w, _) = win.w.as_chunks::<CHUNK>();
        let (wr, _) = win.wr.as_chunks::<CHUNK>();
        let (lane_x, _) = win.lane_x.as_chunks::<CHUNK>();
        let (lane_y, _) = win.lane_y.as_chunks::<CHUNK>();
        let chunks = w.len().min(wr.len()).min(lane_x.len()).min(lane_y.len());
        // Chunk c's tap indices and fractions along x and y.
        let cell = |c: usize| -> (TapIndex, __m256, __m256) {
            let fi = load(&lane_x[c]);
            let fj = load(&lane_y[c]);
            // The scalar loop's (origin + h fj) + h fi, lane by lane.
            let ra = _mm256_add_ps(a0, _mm256_mul_ps(hx1, fj));
            let rb = _mm256_add_ps(b0, _mm256_mul_ps(hx4, fj));
            let rc = _mm256_add_ps(c0, _mm256_mul_ps(hx7, fj));
            let iz = _mm256_div_ps(one, _mm256_add_ps(rc, _mm256_mul_ps(hx6, fi)));
            let fx = _mm256_sub_ps(
                _mm256_mul_ps(_mm256_add_ps(ra, _mm256_mul_ps(hx0, fi)), iz),
                half,
            );
            let fy = _mm256_sub_ps(
                _mm256_mul_ps(_mm256_add_ps(rb, _mm256_mul_ps(hx3, fi)), iz),
                half,
            );
            let (xf, x0) = floor(fx);
            let (yf, y0) = floor(fy);
            let i0 = _mm256_add_epi32(_mm256_mullo_epi32(y0, sw_i), x0);
            (
                TapIndex::clamped(i0, data, sw),
                _mm256_sub_ps(fx, xf),
                _mm256_sub_ps(fy, yf),
            )
        };
        let (mut s1, mut s2, mut sr) = (
            _mm256_setzero_ps(),
            _mm256_setzero_ps(),
            _mm256_setzero_ps(),
        );
        let mut next = (chunks > 0).then(|| cell(0));
        for c in 0..chunks {
            let Some((idx, ax, ay)) = next else { break };
            next = (c + 1 < chunks).then(|| cell(c + 1));
            let first = c * CHUNK;
            let live = win.samples - first.min(win.samples);
            let [c00, c01, c10, c11] = taps(data, sw, &idx, live);
            let t = _mm256_add_ps(c00, _mm256_mul_ps(ax, _mm256_sub_ps(c01, c00)));
            let b = _mm256_add_ps(c10, _mm256_mul_ps(ax, _mm256_sub_ps(c11, c10)));
            let s = _mm256_add_ps(t, _mm256_mul_ps(ay, _mm256_sub_ps(b, t)));
            // Padding lanes read clamped garbage or zeros: s = +0.
            let s = if live < CHUNK {
                let on = _mm256_cmpgt_epi32(_mm256_set1_epi32(live as i32), lane_ids);
                _mm256_and_ps(s, _mm256_castsi256_ps(on))
            } else {
                s
            };
            let ws = _mm256_mul_ps(load(&w[c]), s);
            s1 = _mm256_add_ps(s1, ws);
            s2 = _mm256_add_ps(s2, _mm256_mul_ps(ws, s));
            sr = _mm256_add_ps(sr, _mm256_mul_ps(load(&wr[c]), s));
        }
        [total(s1), total(s2), total(sr)]
    }

    /// The four bilinear taps (top left, top right, bottom left, bottom
    /// right) of each lane's cell, whose top-left index in `data` (rows of
    /// `sw`) is `idx`; lanes from `live` on may hold anything.
    ///
    /// The two taps of a cell row are adjacent: each is read as one 64-bit
    /// pair per lane, lanes {0, 1, 4, 5} into one vector and {2, 3, 6, 7}
    /// into another, so that one in-lane shuffle per tap puts the eight
    /// lanes back in order. Two 64-bit loads per 128-bit half, not an AVX2
    /// gather: 0.95 of the time on `paper_1024` (docs/performance.md,
    /// "Stop 56"). A chunk with at most four live lanes (the 6 x 6 grid's
    /// last: 36 = 4 x 8 + 4) reads lanes 0-3 only.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn taps(data: &[f32], sw: usize, idx: &TapIndex, live: usize) -> [__m256; 4] {
        let idx = &idx.0;
        let p = data.as_ptr();
        // SAFETY: every lane of `idx` is in [0, data.len() - sw - 2]
        // (`TapIndex::clamped`, its one maker) and `off` is 0 or sw, so
        // the two floats at each idx + off lie in `data`; `read_unaligned`
        // needs no alignment.
        #[allow(clippy::cast_ptr_alignment)]
        let pair = |lane: usize, off: usize| unsafe {
            p.add(idx[lane] as usize + off)
                .cast::<f64>()
                .read_unaligned()
        };
        let four = |l: [usize; 4], off: usize| {
            _mm256_castpd_ps(_mm256_setr_pd(
                pair(l[0], off),
                pair(l[1], off),
                pair(l[2], off),
                pair(l[3], off),
            ))
        };
        let four_low = |l: [usize; 2], off: usize| {
            _mm256_castpd_ps(_mm256_setr_pd(pair(l[0], off), pair(l[1], off), 0.0, 0.0))
        };
        let (top_lo, top_hi, bot_lo, bot_hi) = if live <= CHUNK / 2 {
            (
                four_low([0, 1], 0),
                four_low([2, 3], 0),
                four_low([0, 1], sw),
                four_low([2, 3], sw),
            )
        } else {
            (
                four([0, 1, 4, 5], 0),
                four([2, 3, 6, 7], 0),
                four([0, 1, 4, 5], sw),
                four([2, 3, 6, 7], sw),
            )
        };
        [
            _mm256_shuffle_ps::<0b10_00_10_00>(top_lo, top_hi),
            _mm256_shuffle_ps::<0b11_01_11_01>(top_lo, top_hi),
            _mm256_shuffle_ps::<0b10_00_10_00>(bot_lo, bot_hi),
            _mm256_shuffle_ps::<0b11_01_11_01>(bot_lo, bot_hi),
        ]
    }

    /// `cost::lane_total` of the eight lanes, the same additions in the
    /// same order, without leaving the registers.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn total(v: __m256) -> f32 {
        // q = [a0 + a4, a1 + a5, a2 + a6, a3 + a7]
        let q = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
        // [q0 + q2, q1 + q3, ..]
        let r = _mm_add_ps(q, _mm_movehl_ps(q, q));
        _mm_cvtss_f32(_mm_add_ss(r, _mm_shuffle_ps::<0b01>(r, r)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wild_coordinates_read_inside_the_image() {
        // Origins and homographies no caller passes (the corner test
        // refuses them): NaN, infinities, far outside, negative. The
        // clamped tap reads stay inside the 5x4 image whatever the lanes
        // hold; the result is garbage but no read leaves `data`.
        let Some(avx2) = Avx2::detect() else {
            return;
        };
        let data: Vec<f32> = (0..20).map(|i| i as f32 / 20.0).collect();
        let w = vec![1.0f32; 8];
        let lanes: Vec<f32> = (0..8).map(|i| i as f32).collect();
        let zeros = vec![0.0f32; 8];
        let big = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1e30,
            -1e30,
            -3.0,
            7.5,
            0.0,
        ];
        for &a in &big {
            for &c in &big {
                let h = [1.0, 0.0, a, 0.0, 1.0, -a, c, 0.0, 1.0];
                for samples in [2, 6] {
                    let sums = |lane_x: &[f32]| {
                        let win = FullWindow {
                            w: &w,
                            wr: &w,
                            lane_x,
                            lane_y: &zeros,
                            samples,
                            origin: [a, c, 1.0],
                            h: &h,
                            data: &data,
                            width: 5,
                        };
                        let s = avx2.sums_full(&win).expect("a shape the AVX2 sums take");
                        s.map(f32::to_bits)
                    };
                    // Padding lanes whose offsets are as wild.
                    let mut wild = lanes.clone();
                    wild[samples..].fill(c);
                    // Whatever the padding lanes (2..8 or 6..8) read, the
                    // sums are those of the live lanes alone.
                    assert_eq!(sums(&lanes), sums(&wild), "a {a}, c {c}, {samples} samples");
                }
            }
        }
    }
}
