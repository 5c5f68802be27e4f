//! The full-window NCC sums with AVX2 gathers: the one place of vp-mvs
//! with `unsafe` code.
//!
//! Why: the sums' time goes mostly to the four bilinear taps of each window
//! sample, read one by one from indices the vectorised coordinate code has
//! to spill first (docs/performance.md, "vp-mvs, one 1024x1024 triplet").
//! AVX2 gathers read eight of them at once. `std::arch`'s gathers, loads
//! and the call into a `#[target_feature]` function are `unsafe`; the
//! workspace denies unsafe code everywhere else, and here it follows the
//! team's rules:
//! - AVX2 is detected at run time ([`Avx2::detect`]); the token proving it
//!   is the only way to reach the AVX2 code, and the safe scalar loop in
//!   `cost.rs` remains the path on other CPUs and architectures;
//! - every gather index is clamped in-register to the image's bounds, so no
//!   input (a wrong homography, NaN coordinates, padding lanes) can read
//!   outside the slice, whatever the callers' invariants;
//! - every vector load is from a bounds-checked fixed-size array;
//! - no FMA: every lane does the scalar loop's operations in the same order,
//!   so the sums are bit for bit the scalar ones (tested in `cost.rs`).
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
#![allow(unsafe_code)]
// Off x86-64 the token is never made and the window's fields never read.
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use crate::cost::CHUNK;

/// Proof that the running CPU has AVX2 (only [`Avx2::detect`] makes one).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Avx2 {
    _private: (),
}

/// Everything the full-window sums read, with the window's origin already
/// warped: `origin` is the homogeneous source position of the first sample.
pub(crate) struct FullWindow<'a> {
    /// Bilateral weights, `rows` rows of `stride` samples.
    pub w: &'a [f32],
    /// Weight times mean-free reference intensity, laid out like `w`.
    pub wr: &'a [f32],
    /// Offset of each lane from the row's first sample, `stride` of them.
    pub lanes: &'a [f32],
    /// Samples per window row that count (the rest are padding).
    pub n: usize,
    /// Samples stored per row, a multiple of [`CHUNK`].
    pub stride: usize,
    /// Distance between window rows, in reference pixels.
    pub step: f32,
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

    /// The per-lane sums (w s, w s^2, w r s) of `cost::sums_full`, the same
    /// bits; `None` for shapes the vector code does not take (then the
    /// caller runs the scalar loop).
    #[allow(clippy::unused_self)] // `self` is the proof that AVX2 is there
    pub(crate) fn sums_full(self, win: &FullWindow) -> Option<[[f32; CHUNK]; 3]> {
        let ok = CHUNK == 8
            && win.stride.is_multiple_of(CHUNK)
            && win.n <= win.stride
            && win.lanes.len() >= win.stride
            && win.w.len() == win.wr.len()
            && win.w.len() == win.n * win.stride
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
    /// `sgm::matching::pass_row` with AVX2 code generation: the same result.
    #[allow(clippy::unused_self)] // `self` is the proof that AVX2 is there
    pub(crate) fn sgm_pass_row(
        self,
        job: &crate::sgm::matching::RowPass,
        st: &mut crate::sgm::matching::PassState,
        out: &mut [u16],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only if `detect` found AVX2 on this CPU,
            // the one feature `x86::sgm_pass_row` is compiled for; its body
            // is safe code.
            unsafe { x86::sgm_pass_row(job, st, out) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = self;
            crate::sgm::matching::pass_row(job, st, out);
        }
    }

    /// `sgm::matching::winner_row` with AVX2 code generation: the same result.
    #[allow(clippy::unused_self)] // `self` is the proof that AVX2 is there
    pub(crate) fn sgm_winner_row(
        self,
        row: &[u16],
        y: usize,
        pair: &crate::sgm::matching::RectifiedPair,
        params: &crate::sgm::SgmParams,
        held: &mut Vec<u32>,
        out: &mut [f32],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only if `detect` found AVX2 on this CPU,
            // the one feature `x86::sgm_winner_row` is compiled for; its
            // body is safe code.
            unsafe { x86::sgm_winner_row(row, y, pair, params, held, out) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = self;
            crate::sgm::matching::winner_row(row, y, pair, params, held, out);
        }
    }

    /// `sgm::matching::cost_row` with AVX2 and, when the CPU has it,
    /// `popcnt` code generation: the same result.
    #[allow(clippy::unused_self, clippy::too_many_arguments)] // `self`: the proof of AVX2
    pub(crate) fn sgm_cost_row(
        self,
        cl: &[u64],
        cr: &[u64],
        left_valid: &[bool],
        right_valid: &[bool],
        n_bits: u8,
        scratch: &mut (Vec<u64>, Vec<u8>),
        out: &mut [u8],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("popcnt") {
            // SAFETY: `self` proves AVX2 and the line above `popcnt`, the
            // two features `x86::sgm_cost_row` is compiled for; its body is
            // safe code.
            unsafe { x86::sgm_cost_row(cl, cr, left_valid, right_valid, n_bits, scratch, out) };
            return;
        }
        let _ = self;
        crate::sgm::matching::cost_row(cl, cr, left_valid, right_valid, n_bits, scratch, out);
    }
}

/// Proof that the running CPU has AVX-512 F, BW, VL and VPOPCNTDQ besides
/// AVX2 and `popcnt` (only [`Avx512::detect`] makes one).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Avx512 {
    _private: (),
}

impl Avx512 {
    /// `Some` when the running CPU has every feature `x86::sgm_*_512` is
    /// compiled for.
    pub(crate) fn detect() -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512bw")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx512vpopcntdq")
        {
            return Some(Avx512 { _private: () });
        }
        None
    }
}

/// The code generation the semi-global matcher's row kernels (census,
/// costs, scanline pass, winners) run with: the same safe scalar code,
/// compiled a second time with AVX2 or AVX-512 enabled so that LLVM
/// vectorises it 16 or 32 u16 lanes wide (and counts bits with `popcnt`
/// or `vpopcntq`). Integer operations, identical on every level: the
/// results are the scalar ones (tested in `sgm/tests.rs`).
#[derive(Debug, Clone, Copy)]
pub(crate) enum SgmSimd {
    Scalar,
    Avx2(Avx2),
    Avx512(Avx512),
}

impl SgmSimd {
    /// The widest level the running CPU has.
    pub(crate) fn detect() -> Self {
        if let Some(a) = Avx512::detect() {
            SgmSimd::Avx512(a)
        } else if let Some(a) = Avx2::detect() {
            SgmSimd::Avx2(a)
        } else {
            SgmSimd::Scalar
        }
    }

    /// Every level the running CPU has, scalar first (for the tests).
    #[cfg(test)]
    pub(crate) fn levels() -> Vec<Self> {
        let mut v = vec![SgmSimd::Scalar];
        v.extend(Avx2::detect().map(SgmSimd::Avx2));
        v.extend(Avx512::detect().map(SgmSimd::Avx512));
        v
    }

    /// `sgm::matching::census_row` at this level.
    pub(crate) fn census_row(
        self,
        job: &crate::sgm::matching::CensusRow,
        lo_bits: &mut [u32],
        hi_bits: &mut [u32],
        out: &mut [u64],
    ) {
        match self {
            SgmSimd::Scalar => crate::sgm::matching::census_row(job, lo_bits, hi_bits, out),
            SgmSimd::Avx2(_) => {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Avx2` token exists only if `detect` found
                // AVX2 on this CPU, the one feature `x86::sgm_census_row`
                // is compiled for; its body is safe code.
                unsafe {
                    x86::sgm_census_row(job, lo_bits, hi_bits, out);
                }
                #[cfg(not(target_arch = "x86_64"))]
                crate::sgm::matching::census_row(job, lo_bits, hi_bits, out);
            }
            SgmSimd::Avx512(_) => {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Avx512` token exists only if `detect` found
                // every feature `x86::sgm_census_row_512` is compiled for;
                // its body is safe code.
                unsafe {
                    x86::sgm_census_row_512(job, lo_bits, hi_bits, out);
                }
                #[cfg(not(target_arch = "x86_64"))]
                crate::sgm::matching::census_row(job, lo_bits, hi_bits, out);
            }
        }
    }

    /// `sgm::matching::cost_row` at this level.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn cost_row(
        self,
        cl: &[u64],
        cr: &[u64],
        left_valid: &[bool],
        right_valid: &[bool],
        n_bits: u8,
        scratch: &mut (Vec<u64>, Vec<u8>),
        out: &mut [u8],
    ) {
        match self {
            SgmSimd::Scalar => {
                crate::sgm::matching::cost_row(
                    cl,
                    cr,
                    left_valid,
                    right_valid,
                    n_bits,
                    scratch,
                    out,
                );
            }
            SgmSimd::Avx2(a) => {
                a.sgm_cost_row(cl, cr, left_valid, right_valid, n_bits, scratch, out);
            }
            SgmSimd::Avx512(_) => {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Avx512` token exists only if `detect` found
                // every feature `x86::sgm_cost_row_512` is compiled for;
                // its body is safe code.
                unsafe {
                    x86::sgm_cost_row_512(cl, cr, left_valid, right_valid, n_bits, scratch, out);
                }
                #[cfg(not(target_arch = "x86_64"))]
                crate::sgm::matching::cost_row(
                    cl,
                    cr,
                    left_valid,
                    right_valid,
                    n_bits,
                    scratch,
                    out,
                );
            }
        }
    }

    /// `sgm::matching::pass_row` at this level.
    pub(crate) fn pass_row(
        self,
        job: &crate::sgm::matching::RowPass,
        st: &mut crate::sgm::matching::PassState,
        out: &mut [u16],
    ) {
        match self {
            SgmSimd::Scalar => crate::sgm::matching::pass_row(job, st, out),
            SgmSimd::Avx2(a) => a.sgm_pass_row(job, st, out),
            SgmSimd::Avx512(_) => {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Avx512` token exists only if `detect` found
                // every feature `x86::sgm_pass_row_512` is compiled for;
                // its body is safe code.
                unsafe {
                    x86::sgm_pass_row_512(job, st, out);
                }
                #[cfg(not(target_arch = "x86_64"))]
                crate::sgm::matching::pass_row(job, st, out);
            }
        }
    }

    /// `sgm::matching::winner_row` at this level.
    pub(crate) fn winner_row(
        self,
        row: &[u16],
        y: usize,
        pair: &crate::sgm::matching::RectifiedPair,
        params: &crate::sgm::SgmParams,
        held: &mut Vec<u32>,
        out: &mut [f32],
    ) {
        match self {
            SgmSimd::Scalar => crate::sgm::matching::winner_row(row, y, pair, params, held, out),
            SgmSimd::Avx2(a) => a.sgm_winner_row(row, y, pair, params, held, out),
            SgmSimd::Avx512(_) => {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Avx512` token exists only if `detect` found
                // every feature `x86::sgm_winner_row_512` is compiled for;
                // its body is safe code.
                unsafe {
                    x86::sgm_winner_row_512(row, y, pair, params, held, out);
                }
                #[cfg(not(target_arch = "x86_64"))]
                crate::sgm::matching::winner_row(row, y, pair, params, held, out);
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{
        __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_and_ps, _mm256_blendv_ps,
        _mm256_castpd_ps, _mm256_castps_si256, _mm256_castsi256_ps, _mm256_castsi256_si128,
        _mm256_cmp_ps, _mm256_cmpgt_epi32, _mm256_div_ps, _mm256_extracti128_si256,
        _mm256_i32gather_pd, _mm256_loadu_ps, _mm256_max_epi32, _mm256_min_epi32, _mm256_mul_ps,
        _mm256_mullo_epi32, _mm256_permute4x64_epi64, _mm256_set1_epi32, _mm256_set1_ps,
        _mm256_setr_epi32, _mm256_setzero_ps, _mm256_setzero_si256, _mm256_shuffle_ps,
        _mm256_storeu_ps, _mm256_sub_epi32, _mm256_sub_ps, _mm_add_epi32, _mm_set1_epi32,
        _CMP_GT_OQ,
    };
    use std::arch::x86_64::{
        __m512i, _mm256_loadu_si256, _mm256_min_epu16, _mm512_add_epi16, _mm512_castsi512_si256,
        _mm512_cvtepu8_epi16, _mm512_extracti64x4_epi64, _mm512_loadu_si512, _mm512_min_epu16,
        _mm512_set1_epi16, _mm512_setzero_si512, _mm512_storeu_si512, _mm512_sub_epi16,
        _mm_cvtsi128_si32, _mm_min_epu16, _mm_minpos_epu16,
    };

    use std::arch::x86_64::{
        _mm512_cmpeq_epi16_mask, _mm512_cmplt_epu16_mask, _mm512_mask_mov_epi16, _mm512_set_epi16,
    };

    use super::FullWindow;
    use crate::cost::CHUNK;

    /// Eight floats from a bounds-checked array.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(a: &[f32; CHUNK]) -> __m256 {
        // SAFETY: `a` is 8 readable floats; the load is unaligned.
        unsafe { _mm256_loadu_ps(a.as_ptr()) }
    }

    /// `a[at..at + 8]`, bounds-checked.
    #[inline]
    fn chunk(a: &[f32], at: usize) -> &[f32; CHUNK] {
        let Ok(c) = <&[f32; CHUNK]>::try_from(&a[at..at + CHUNK]) else {
            unreachable!("a slice of CHUNK elements")
        };
        c
    }

    /// `floor_small` of every lane: (floor as float, floor as integer).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn floor_small(x: __m256) -> (__m256, __m256i) {
        const MAGIC: f32 = 12_582_912.0;
        let magic = _mm256_set1_ps(MAGIC);
        let t = _mm256_add_ps(x, magic);
        let r = _mm256_sub_ps(t, magic);
        // All ones (-1 as an integer) where rounding went up.
        let up = _mm256_cmp_ps::<_CMP_GT_OQ>(r, x);
        let bits = _mm256_sub_epi32(
            _mm256_castps_si256(t),
            _mm256_set1_epi32(MAGIC.to_bits() as i32),
        );
        let i = _mm256_add_epi32(bits, _mm256_castps_si256(up));
        let f = _mm256_blendv_ps(r, _mm256_sub_ps(r, _mm256_set1_ps(1.0)), up);
        (f, i)
    }

    /// The safe scalar row of a pass, inlined here and so compiled for AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn sgm_pass_row(
        job: &crate::sgm::matching::RowPass,
        st: &mut crate::sgm::matching::PassState,
        out: &mut [u16],
    ) {
        crate::sgm::matching::pass_row(job, st, out);
    }

    /// The safe scalar winners of a row, inlined here and so compiled for
    /// AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn sgm_winner_row(
        row: &[u16],
        y: usize,
        pair: &crate::sgm::matching::RectifiedPair,
        params: &crate::sgm::SgmParams,
        held: &mut Vec<u32>,
        out: &mut [f32],
    ) {
        crate::sgm::matching::winner_row(row, y, pair, params, held, out);
    }

    /// The safe scalar cost row, inlined here and so compiled for AVX2 and
    /// `popcnt`.
    #[target_feature(enable = "avx2,popcnt")]
    pub(super) fn sgm_cost_row(
        cl: &[u64],
        cr: &[u64],
        left_valid: &[bool],
        right_valid: &[bool],
        n_bits: u8,
        scratch: &mut (Vec<u64>, Vec<u8>),
        out: &mut [u8],
    ) {
        crate::sgm::matching::cost_row(cl, cr, left_valid, right_valid, n_bits, scratch, out);
    }

    /// The safe scalar census row, inlined here and so compiled for AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) fn sgm_census_row(
        job: &crate::sgm::matching::CensusRow,
        lo_bits: &mut [u32],
        hi_bits: &mut [u32],
        out: &mut [u64],
    ) {
        crate::sgm::matching::census_row(job, lo_bits, hi_bits, out);
    }

    /// The safe scalar census row compiled for AVX-512.
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    pub(super) fn sgm_census_row_512(
        job: &crate::sgm::matching::CensusRow,
        lo_bits: &mut [u32],
        hi_bits: &mut [u32],
        out: &mut [u64],
    ) {
        crate::sgm::matching::census_row(job, lo_bits, hi_bits, out);
    }

    /// The safe scalar cost row compiled for AVX-512 (`vpopcntq`).
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    pub(super) fn sgm_cost_row_512(
        cl: &[u64],
        cr: &[u64],
        left_valid: &[bool],
        right_valid: &[bool],
        n_bits: u8,
        scratch: &mut (Vec<u64>, Vec<u8>),
        out: &mut [u8],
    ) {
        crate::sgm::matching::cost_row(cl, cr, left_valid, right_valid, n_bits, scratch, out);
    }

    /// The safe scalar row of a pass compiled for AVX-512, with the four
    /// steps of inside pixels by [`step4_512`].
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    pub(super) fn sgm_pass_row_512(
        job: &crate::sgm::matching::RowPass,
        st: &mut crate::sgm::matching::PassState,
        out: &mut [u16],
    ) {
        crate::sgm::matching::pass_row_with(job, st, out, |c, q, m, p1, p2, cur, o| {
            // A closure inherits this function's target features.
            step4_512(c, q, m, p1, p2, cur, o)
        });
    }

    /// 32 u16 from a bounds-checked array.
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw")]
    fn load_w(a: &[u16; 32]) -> __m512i {
        // SAFETY: `a` is 64 readable bytes; the load is unaligned.
        unsafe { _mm512_loadu_si512(a.as_ptr().cast()) }
    }

    /// `s[at..at + 32]`, bounds-checked.
    #[inline]
    fn lanes_w(s: &[u16], at: usize) -> &[u16; 32] {
        let Ok(c) = <&[u16; 32]>::try_from(&s[at..at + 32]) else {
            unreachable!("a slice of 32 elements")
        };
        c
    }

    /// The smallest of 32 u16 lanes.
    #[inline]
    #[target_feature(enable = "avx2,avx512f,avx512bw")]
    fn min_w(v: __m512i) -> u16 {
        let a = _mm256_min_epu16(_mm512_castsi512_si256(v), _mm512_extracti64x4_epi64::<1>(v));
        let b = _mm_min_epu16(_mm256_castsi256_si128(a), _mm256_extracti128_si256::<1>(a));
        (_mm_cvtsi128_si32(_mm_minpos_epu16(b)) & 0xFFFF) as u16
    }

    /// `sgm::matching::step4` in one loop over the disparities, 32 u16
    /// lanes a vector: the same wrapping u16 additions and unsigned
    /// minima, term for term, so the same results (tested in
    /// `sgm/tests.rs`); below 32 disparities, the scalar `step` formula.
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    #[allow(clippy::needless_range_loop, clippy::needless_pass_by_value)]
    fn step4_512(
        cost: &[u8],
        prev: [&[u16]; 4],
        prev_min: [u16; 4],
        p1: u16,
        p2: u16,
        cur: [&mut [u16]; 4],
        out: &mut [u16],
    ) -> [u16; 4] {
        let nd = cost.len();
        // Whole vectors, the last one overlapping the one before when nd
        // is not a multiple of 32 (recomputing a cell gives the same value;
        // minima do not mind a lane seen twice); below 32 disparities, one
        // by one.
        let starts = (0..nd / 32 * 32)
            .step_by(32)
            .chain((nd % 32 != 0 && nd > 32).then_some(nd.saturating_sub(32)));
        let done = if nd >= 32 { nd } else { 0 };
        let vp1 = _mm512_set1_epi16(p1 as i16);
        let lim = prev_min.map(|m| _mm512_set1_epi16((m + p2) as i16));
        let vm = prev_min.map(|m| _mm512_set1_epi16(m as i16));
        let mut vmin = [_mm512_set1_epi16(-1); 4];
        for k in starts.clone() {
            let Ok(c8) = <&[u8; 32]>::try_from(&cost[k..k + 32]) else {
                unreachable!("a slice of 32 elements")
            };
            // SAFETY: `c8` is 32 readable bytes; the load is unaligned.
            let c = _mm512_cvtepu8_epi16(unsafe { _mm256_loadu_si256(c8.as_ptr().cast()) });
            let mut sum = _mm512_setzero_si512();
            for j in 0..4 {
                let q = prev[j];
                let (lo, mid, hi) = (
                    load_w(lanes_w(q, k)),
                    load_w(lanes_w(q, k + 1)),
                    load_w(lanes_w(q, k + 2)),
                );
                let best = _mm512_min_epu16(
                    _mm512_min_epu16(mid, _mm512_add_epi16(lo, vp1)),
                    _mm512_min_epu16(_mm512_add_epi16(hi, vp1), lim[j]),
                );
                let v = _mm512_sub_epi16(_mm512_add_epi16(c, best), vm[j]);
                let Ok(dst) = <&mut [u16; 32]>::try_from(&mut cur[j][k + 1..k + 33]) else {
                    unreachable!("a slice of 32 elements")
                };
                // SAFETY: `dst` is 64 writable bytes; the store is unaligned.
                unsafe { _mm512_storeu_si512(dst.as_mut_ptr().cast(), v) };
                vmin[j] = _mm512_min_epu16(vmin[j], v);
                sum = _mm512_add_epi16(sum, v);
            }
            let Ok(dst) = <&mut [u16; 32]>::try_from(&mut out[k..k + 32]) else {
                unreachable!("a slice of 32 elements")
            };
            // SAFETY: `dst` is 64 writable bytes; the store is unaligned.
            unsafe { _mm512_storeu_si512(dst.as_mut_ptr().cast(), sum) };
        }
        #[allow(clippy::redundant_closure)] // a closure inherits the features
        let mut mins = vmin.map(|v| min_w(v));
        for k in done..nd {
            let c = u16::from(cost[k]);
            let mut sum = 0u16;
            for j in 0..4 {
                let q = prev[j];
                let best = q[k + 1]
                    .min(q[k].wrapping_add(p1))
                    .min(q[k + 2].wrapping_add(p1))
                    .min(prev_min[j] + p2);
                let v = c.wrapping_add(best).wrapping_sub(prev_min[j]);
                cur[j][k + 1] = v;
                mins[j] = mins[j].min(v);
                sum = sum.wrapping_add(v);
            }
            out[k] = sum;
        }
        mins
    }

    /// The safe scalar winners of a row compiled for AVX-512, each cell's
    /// winner picked by [`pick_512`].
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    pub(super) fn sgm_winner_row_512(
        row: &[u16],
        y: usize,
        pair: &crate::sgm::matching::RectifiedPair,
        params: &crate::sgm::SgmParams,
        held: &mut Vec<u32>,
        out: &mut [f32],
    ) {
        // A closure inherits this function's target features.
        crate::sgm::matching::winner_row_with(row, y, pair, params, held, out, |s| pick_512(s));
    }

    /// `sgm::matching::pick` 32 u16 lanes at a time: the smallest sum
    /// and the first lane equal to it (the first smallest, as the scalar
    /// key minimum), then the smallest sum outside best - 1 ..= best + 1
    /// (those lanes masked to u16::MAX); below 32 disparities, one by
    /// one.
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    fn pick_512(s: &[u16]) -> (usize, u16) {
        let nd = s.len();
        // Whole vectors, the last one overlapping the one before when nd
        // is not a multiple of 32 (recomputing a cell gives the same value;
        // minima do not mind a lane seen twice); below 32 disparities, one
        // by one.
        let starts = (0..nd / 32 * 32)
            .step_by(32)
            .chain((nd % 32 != 0 && nd > 32).then_some(nd.saturating_sub(32)));
        let done = if nd >= 32 { nd } else { 0 };
        let mut acc = _mm512_set1_epi16(-1);
        for k in starts.clone() {
            acc = _mm512_min_epu16(acc, load_w(lanes_w(s, k)));
        }
        let mut m = min_w(acc);
        for &v in &s[done..] {
            m = m.min(v);
        }
        let vm = _mm512_set1_epi16(m as i16);
        let mut best = nd;
        for k in starts.clone() {
            let eq = _mm512_cmpeq_epi16_mask(load_w(lanes_w(s, k)), vm);
            if eq != 0 {
                best = k + eq.trailing_zeros() as usize;
                break;
            }
        }
        if best == nd {
            best = done + s[done..].iter().position(|&v| v == m).unwrap_or(0);
        }
        let lo = best.saturating_sub(1) as u16;
        let (vlo, span) = (
            _mm512_set1_epi16(lo as i16),
            _mm512_set1_epi16((best + 2 - usize::from(lo)) as i16),
        );
        let iota = _mm512_set_epi16(
            31, 30, 29, 28, 27, 26, 25, 24, 23, 22, 21, 20, 19, 18, 17, 16, 15, 14, 13, 12, 11, 10,
            9, 8, 7, 6, 5, 4, 3, 2, 1, 0,
        );
        let mut acc = _mm512_set1_epi16(-1);
        for k in starts.clone() {
            let idx = _mm512_add_epi16(iota, _mm512_set1_epi16(k as i16));
            let near = _mm512_cmplt_epu16_mask(_mm512_sub_epi16(idx, vlo), span);
            let v = _mm512_mask_mov_epi16(load_w(lanes_w(s, k)), near, _mm512_set1_epi16(-1));
            acc = _mm512_min_epu16(acc, v);
        }
        let mut rival = min_w(acc);
        for (k, &v) in s.iter().enumerate().skip(done) {
            if k + 1 < best || k > best + 1 {
                rival = rival.min(v);
            }
        }
        (best, rival)
    }

    /// See [`super::Avx2::sums_full`]; the caller checked the shapes.
    #[target_feature(enable = "avx2")]
    pub(super) fn sums_full(win: &FullWindow) -> [[f32; CHUNK]; 3] {
        let h = win.h;
        let [a0, b0, c0] = win.origin;
        let sw = win.width;
        let data = win.data;
        // Largest top-left index whose four taps (+0, +1, +sw, +sw + 1)
        // stay inside `data`; the caller checked that it is >= 0 and that
        // `data.len()` fits in an i32.
        let last = _mm256_set1_epi32((data.len() - sw - 2) as i32);
        let zero_i = _mm256_setzero_si256();
        let (sw_i, sw4) = (_mm256_set1_epi32(sw as i32), _mm_set1_epi32(sw as i32));
        let (hx0, hx3, hx6) = (
            _mm256_set1_ps(h[0]),
            _mm256_set1_ps(h[3]),
            _mm256_set1_ps(h[6]),
        );
        let (one, half) = (_mm256_set1_ps(1.0), _mm256_set1_ps(0.5));
        let lane_ids = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let (mut s1, mut s2, mut sr) = (
            _mm256_setzero_ps(),
            _mm256_setzero_ps(),
            _mm256_setzero_ps(),
        );
        for j in 0..win.n {
            let fj = j as f32 * win.step;
            let ra = _mm256_set1_ps(a0 + h[1] * fj);
            let rb = _mm256_set1_ps(b0 + h[4] * fj);
            let rc = _mm256_set1_ps(c0 + h[7] * fj);
            for first in (0..win.stride).step_by(CHUNK) {
                let at = j * win.stride + first;
                let w = load(chunk(win.w, at));
                let wr = load(chunk(win.wr, at));
                let fi = load(chunk(win.lanes, first));
                let iz = _mm256_div_ps(one, _mm256_add_ps(rc, _mm256_mul_ps(hx6, fi)));
                let fx = _mm256_sub_ps(
                    _mm256_mul_ps(_mm256_add_ps(ra, _mm256_mul_ps(hx0, fi)), iz),
                    half,
                );
                let fy = _mm256_sub_ps(
                    _mm256_mul_ps(_mm256_add_ps(rb, _mm256_mul_ps(hx3, fi)), iz),
                    half,
                );
                let (xf, x0) = floor_small(fx);
                let (yf, y0) = floor_small(fy);
                let ax = _mm256_sub_ps(fx, xf);
                let ay = _mm256_sub_ps(fy, yf);
                let i0 = _mm256_add_epi32(_mm256_mullo_epi32(y0, sw_i), x0);
                let i0 = _mm256_min_epi32(_mm256_max_epi32(i0, zero_i), last);
                // The two taps of a cell row are adjacent: gather them as
                // one 64-bit pair per lane, four lanes a gather, lanes
                // {0, 1, 4, 5} then {2, 3, 6, 7}, so that one in-lane
                // shuffle per tap puts the eight lanes back in order.
                let perm = _mm256_permute4x64_epi64::<0b11_01_10_00>(i0);
                let (lo, hi) = (
                    _mm256_castsi256_si128(perm),
                    _mm256_extracti128_si256::<1>(perm),
                );
                let (lo_b, hi_b) = (_mm_add_epi32(lo, sw4), _mm_add_epi32(hi, sw4));
                // Only the gathers read through `p`, and they need no
                // alignment.
                #[allow(clippy::cast_ptr_alignment)]
                let p = data.as_ptr().cast::<f64>();
                // SAFETY: every lane of `i0` is in [0, data.len() - sw - 2]
                // (clamped just above), so the 8 bytes at f32 index i0 and
                // at i0 + sw (floats i0, i0 + 1, i0 + sw, i0 + sw + 1) lie
                // in `data`; the scale 4 is f32's size, and gathers need no
                // alignment.
                let (top_lo, top_hi, bot_lo, bot_hi) = unsafe {
                    (
                        _mm256_castpd_ps(_mm256_i32gather_pd::<4>(p, lo)),
                        _mm256_castpd_ps(_mm256_i32gather_pd::<4>(p, hi)),
                        _mm256_castpd_ps(_mm256_i32gather_pd::<4>(p, lo_b)),
                        _mm256_castpd_ps(_mm256_i32gather_pd::<4>(p, hi_b)),
                    )
                };
                let c00 = _mm256_shuffle_ps::<0b10_00_10_00>(top_lo, top_hi);
                let c01 = _mm256_shuffle_ps::<0b11_01_11_01>(top_lo, top_hi);
                let c10 = _mm256_shuffle_ps::<0b10_00_10_00>(bot_lo, bot_hi);
                let c11 = _mm256_shuffle_ps::<0b11_01_11_01>(bot_lo, bot_hi);
                let t = _mm256_add_ps(c00, _mm256_mul_ps(ax, _mm256_sub_ps(c01, c00)));
                let b = _mm256_add_ps(c10, _mm256_mul_ps(ax, _mm256_sub_ps(c11, c10)));
                let s = _mm256_add_ps(t, _mm256_mul_ps(ay, _mm256_sub_ps(b, t)));
                // Lanes past the row's end read clamped garbage: s = +0.
                let live = _mm256_cmpgt_epi32(
                    _mm256_set1_epi32((win.n - first.min(win.n)) as i32),
                    lane_ids,
                );
                let s = _mm256_and_ps(s, _mm256_castsi256_ps(live));
                let ws = _mm256_mul_ps(w, s);
                s1 = _mm256_add_ps(s1, ws);
                s2 = _mm256_add_ps(s2, _mm256_mul_ps(ws, s));
                sr = _mm256_add_ps(sr, _mm256_mul_ps(wr, s));
            }
        }
        let mut out = [[0.0f32; CHUNK]; 3];
        for (o, v) in out.iter_mut().zip([s1, s2, sr]) {
            // SAFETY: `o` is 8 writable floats; the store is unaligned.
            unsafe { _mm256_storeu_ps(o.as_mut_ptr(), v) };
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wild_coordinates_read_inside_the_image() {
        // Origins and homographies no caller passes (the corner test
        // refuses them): NaN, infinities, far outside, negative. The
        // clamped gathers read inside the 5x4 image whatever the lanes
        // hold; the result is garbage but no read leaves `data`.
        let Some(avx2) = Avx2::detect() else {
            return;
        };
        let data: Vec<f32> = (0..20).map(|i| i as f32 / 20.0).collect();
        let w = vec![1.0f32; 2 * 8];
        let lanes: Vec<f32> = (0..8).map(|i| i as f32).collect();
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
                let win = FullWindow {
                    w: &w,
                    wr: &w,
                    lanes: &lanes,
                    n: 2,
                    stride: 8,
                    step: 1.0,
                    origin: [a, c, 1.0],
                    h: &h,
                    data: &data,
                    width: 5,
                };
                let sums = avx2.sums_full(&win).expect("a shape the AVX2 sums take");
                // Padding lanes (2..8) stay zero whatever their taps read.
                for s in sums {
                    assert!(s[2..].iter().all(|&v| v.to_bits() == 0), "{s:?}");
                }
            }
        }
    }
}
