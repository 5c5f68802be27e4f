//! The semi-global matcher's row kernels at each SIMD level: the safe
//! scalar rows of `sgm::costs`, `sgm::matching` and `sgm::winners`
//! compiled again under `#[target_feature]` (AVX2; AVX-512 F, BW, VL and
//! VPOPCNTDQ), some with AVX-512 kernels written with intrinsics
//! (`simd/sgm_kernels.rs`: census blocks, cost cells, the four scanline
//! steps of a pixel, a cell's winner). The rules of the parent module hold: runtime
//! detection, a token as the only way in, bounds-checked loads and
//! stores, `// SAFETY:` on every block, and results bit for bit the
//! scalar ones (tested in `sgm/tests.rs` at every level the CPU has).

use super::Avx2;

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
    pub(crate) fn census_row(self, job: &crate::sgm::matching::CensusRow, out: &mut [u64]) {
        match self {
            SgmSimd::Scalar => crate::sgm::matching::census_row(job, out),
            SgmSimd::Avx2(_) => {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Avx2` token exists only if `detect` found
                // AVX2 on this CPU, the one feature `x86::sgm_census_row`
                // is compiled for; its body is safe code.
                unsafe {
                    x86::sgm_census_row(job, out);
                }
                #[cfg(not(target_arch = "x86_64"))]
                crate::sgm::matching::census_row(job, out);
            }
            SgmSimd::Avx512(_) => {
                #[cfg(target_arch = "x86_64")]
                // SAFETY: an `Avx512` token exists only if `detect` found
                // every feature `x86::sgm_census_row_512` is compiled for;
                // its body is safe code.
                unsafe {
                    x86::sgm_census_row_512(job, out);
                }
                #[cfg(not(target_arch = "x86_64"))]
                crate::sgm::matching::census_row(job, out);
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
    use super::super::sgm_kernels::{census_block_512, cost_cells_512, pick_512, step4_512};
    use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};

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
    pub(super) fn sgm_census_row(job: &crate::sgm::matching::CensusRow, out: &mut [u64]) {
        crate::sgm::matching::census_row(job, out);
    }

    /// The census row compiled for AVX-512, the interior blocks by
    /// [`census_block_512`].
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    pub(super) fn sgm_census_row_512(job: &crate::sgm::matching::CensusRow, out: &mut [u64]) {
        // A closure inherits this function's target features.
        crate::sgm::matching::census_row_with(job, out, |j, x0, o| census_block_512(j, x0, o));
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
        crate::sgm::matching::cost_row_with(
            cl,
            cr,
            left_valid,
            right_valid,
            n_bits,
            scratch,
            out,
            // A closure inherits this function's target features.
            |code, right, mask, n, o| cost_cells_512(code, right, mask, n, o),
        );
    }

    /// The safe scalar row of a pass compiled for AVX-512, with the four
    /// steps of inside pixels by [`step4_512`]. When the row carries the
    /// other pass's sums, those of the pixel [`AHEAD`] pixels on are
    /// prefetched: the other pass wrote them long ago (they are in
    /// memory, not in cache), and the loads of each pixel's sums otherwise
    /// wait for memory (13 % of this function in a `perf` profile).
    #[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
    pub(super) fn sgm_pass_row_512(
        job: &crate::sgm::matching::RowPass,
        st: &mut crate::sgm::matching::PassState,
        out: &mut [u16],
    ) {
        let ahead = job.hdx * (AHEAD * job.nd) as isize;
        let lines = (job.nd * 2).div_ceil(64);
        crate::sgm::matching::pass_row_with(job, st, out, |c, q, m, p1, p2, cur, o, e| {
            // A closure inherits this function's target features.
            if !e.is_empty() {
                let p = e.as_ptr().cast::<i8>().wrapping_offset(2 * ahead);
                for l in 0..lines {
                    // A hint: it neither faults nor changes memory,
                    // whatever the address (here possibly past the row).
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * l));
                }
            }
            step4_512(c, q, m, p1, p2, cur, o, e)
        });
    }

    /// How many pixels ahead [`sgm_pass_row_512`] prefetches the other
    /// pass's sums.
    const AHEAD: usize = 12;

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
}
