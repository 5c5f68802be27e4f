//! The semi-global matcher's AVX-512 kernels written with intrinsics:
//! a census block ([`census_block_512`]), a pixel's cost cells
//! ([`cost_cells_512`]), the four scanline steps of a pixel
//! ([`step4_512`]) and a cell's winner ([`pick_512`]). Only
//! `simd/sgm.rs`'s `#[target_feature]` rows call them, under a detected
//! `Avx512` token; the rules of `simd/mod.rs` hold (bounds-checked loads
//! and stores, `// SAFETY:` on every block, results bit for bit the
//! scalar ones, tested in `sgm/tests.rs` at every level the CPU has).
//! Apart from `simd/sgm.rs` to keep both files short.

use std::arch::x86_64::{
    __m512i, _mm256_castsi256_si128, _mm256_extracti128_si256, _mm256_loadu_si256,
    _mm256_min_epu16, _mm512_add_epi16, _mm512_castsi512_si256, _mm512_cvtepu8_epi16,
    _mm512_extracti64x4_epi64, _mm512_loadu_si512, _mm512_min_epu16, _mm512_set1_epi16,
    _mm512_setzero_si512, _mm512_storeu_si512, _mm512_sub_epi16, _mm_cvtsi128_si32, _mm_min_epu16,
    _mm_minpos_epu16,
};

use std::arch::x86_64::{
    __m256i, __m512, _mm512_cmp_ps_mask, _mm512_cvtepu32_epi64, _mm512_loadu_ps,
    _mm512_mask_or_epi32, _mm512_or_si512, _mm512_set1_epi32, _mm512_slli_epi64, _CMP_LT_OQ,
};

use std::arch::x86_64::{
    _mm256_min_epu8, _mm256_or_si256, _mm256_set1_epi8, _mm256_storeu_si256,
    _mm512_mask_set1_epi16, _mm512_permutexvar_epi16,
};

use std::arch::x86_64::{
    _mm256_set_m128i, _mm512_castsi256_si512, _mm512_cvtepi64_epi8, _mm512_inserti64x4,
    _mm512_min_epu8, _mm512_popcnt_epi64, _mm512_set1_epi64, _mm512_set1_epi8, _mm512_xor_si512,
    _mm_unpacklo_epi64,
};

use std::arch::x86_64::{
    _mm512_cmpeq_epi16_mask, _mm512_cmplt_epu16_mask, _mm512_mask_mov_epi16, _mm512_set_epi16,
};

/// `sgm::costs::census_block` 16 pixels a vector: per window offset
/// one unaligned load of 16 floats, one ordered less-than compare (the
/// scalar `<`: false on NaN) and one masked or of the offset's bit into
/// the low or high code word, both held in registers; then the words
/// widened and joined into 16 u64 codes. The same bits as the scalar
/// block (tested in `sgm/tests.rs`).
#[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
pub(super) fn census_block_512(
    job: &crate::sgm::matching::CensusRow,
    x0: usize,
    out: &mut [u64; 16],
) {
    let (rx, ry) = (job.cw / 2, (job.ch / 2) as isize);
    let centre = crate::sgm::matching::window_row(job, 0);
    let c = load_ps(lanes_ps(centre, x0));
    let (mut lo, mut hi) = (_mm512_setzero_si512(), _mm512_setzero_si512());
    let mut k = 0u32;
    for dy in -ry..=ry {
        let src = crate::sgm::matching::window_row(job, dy);
        for dxi in 0..job.cw {
            if dxi == rx && dy == 0 {
                continue;
            }
            let sv = load_ps(lanes_ps(src, x0 + dxi - rx));
            let m = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(sv, c);
            if k < 32 {
                lo = _mm512_mask_or_epi32(lo, m, lo, _mm512_set1_epi32((1u32 << k) as i32));
            } else {
                let bit = _mm512_set1_epi32((1u32 << (k - 32)) as i32);
                hi = _mm512_mask_or_epi32(hi, m, hi, bit);
            }
            k += 1;
        }
    }
    let join = |l: __m256i, h: __m256i| {
        _mm512_or_si512(
            _mm512_cvtepu32_epi64(l),
            _mm512_slli_epi64::<32>(_mm512_cvtepu32_epi64(h)),
        )
    };
    let first = join(_mm512_castsi512_si256(lo), _mm512_castsi512_si256(hi));
    let second = join(
        _mm512_extracti64x4_epi64::<1>(lo),
        _mm512_extracti64x4_epi64::<1>(hi),
    );
    let (a, b) = out.split_at_mut(8);
    // SAFETY: `a` and `b` are 8 writable u64 each (64 bytes); the
    // stores are unaligned.
    unsafe {
        _mm512_storeu_si512(a.as_mut_ptr().cast(), first);
        _mm512_storeu_si512(b.as_mut_ptr().cast(), second);
    }
}

/// 16 floats from a bounds-checked array.
#[inline]
#[target_feature(enable = "avx512f")]
fn load_ps(a: &[f32; 16]) -> __m512 {
    // SAFETY: `a` is 64 readable bytes; the load is unaligned.
    unsafe { _mm512_loadu_ps(a.as_ptr()) }
}

/// `s[at..at + 16]`, bounds-checked.
#[inline]
fn lanes_ps(s: &[f32], at: usize) -> &[f32; 16] {
    let Ok(c) = <&[f32; 16]>::try_from(&s[at..at + 16]) else {
        unreachable!("a slice of 16 elements")
    };
    c
}

/// `sgm::costs::cost_cells` 64 (then 32) cells a step: eight `vpopcntq` of
/// eight codes each, narrowed to bytes and joined into one 64-byte
/// vector, or-ed with the validity mask and capped at `n_bits` (the
/// compiled scalar loop went 16 cells a step through 128-bit
/// registers); the rest of the cells by the scalar formula. The same
/// bytes (tested in `sgm/tests.rs`).
#[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
pub(super) fn cost_cells_512(code: u64, right: &[u64], mask: &[u8], n_bits: u8, out: &mut [u8]) {
    let n = out.len().min(right.len()).min(mask.len());
    let vcode = _mm512_set1_epi64(code as i64);
    let cap = _mm512_set1_epi8(n_bits as i8);
    let mut k = 0;
    while k + 64 <= n {
        let Ok(r) = <&[u64; 64]>::try_from(&right[k..k + 64]) else {
            unreachable!("a slice of 64 elements")
        };
        let Ok(m) = <&[u8; 64]>::try_from(&mask[k..k + 64]) else {
            unreachable!("a slice of 64 elements")
        };
        let bytes = |i: usize| {
            // SAFETY: `r[8 * i..8 * i + 8]` are 64 readable bytes
            // (i < 8); the load is unaligned.
            let v = unsafe { _mm512_loadu_si512(r[8 * i..8 * i + 8].as_ptr().cast()) };
            _mm512_cvtepi64_epi8(_mm512_popcnt_epi64(_mm512_xor_si512(v, vcode)))
        };
        let q = |i: usize| _mm_unpacklo_epi64(bytes(2 * i), bytes(2 * i + 1));
        let all = _mm512_inserti64x4::<1>(
            _mm512_castsi256_si512(_mm256_set_m128i(q(1), q(0))),
            _mm256_set_m128i(q(3), q(2)),
        );
        // SAFETY: `m` is 64 readable bytes; the load is unaligned.
        let vm = unsafe { _mm512_loadu_si512(m.as_ptr().cast()) };
        let v = _mm512_min_epu8(_mm512_or_si512(all, vm), cap);
        let Ok(dst) = <&mut [u8; 64]>::try_from(&mut out[k..k + 64]) else {
            unreachable!("a slice of 64 elements")
        };
        // SAFETY: `dst` is 64 writable bytes; the store is unaligned.
        unsafe { _mm512_storeu_si512(dst.as_mut_ptr().cast(), v) };
        k += 64;
    }
    // 32 cells a step for what is left (32 disparities, or the rest
    // of 96), the same operations in 256-bit registers.
    let cap32 = _mm256_set1_epi8(n_bits as i8);
    while k + 32 <= n {
        let Ok(r) = <&[u64; 32]>::try_from(&right[k..k + 32]) else {
            unreachable!("a slice of 32 elements")
        };
        let Ok(m) = <&[u8; 32]>::try_from(&mask[k..k + 32]) else {
            unreachable!("a slice of 32 elements")
        };
        let bytes = |i: usize| {
            // SAFETY: `r[8 * i..8 * i + 8]` are 64 readable bytes
            // (i < 4); the load is unaligned.
            let v = unsafe { _mm512_loadu_si512(r[8 * i..8 * i + 8].as_ptr().cast()) };
            _mm512_cvtepi64_epi8(_mm512_popcnt_epi64(_mm512_xor_si512(v, vcode)))
        };
        let all = _mm256_set_m128i(
            _mm_unpacklo_epi64(bytes(2), bytes(3)),
            _mm_unpacklo_epi64(bytes(0), bytes(1)),
        );
        // SAFETY: `m` is 32 readable bytes; the load is unaligned.
        let vm = unsafe { _mm256_loadu_si256(m.as_ptr().cast()) };
        let v = _mm256_min_epu8(_mm256_or_si256(all, vm), cap32);
        let Ok(dst) = <&mut [u8; 32]>::try_from(&mut out[k..k + 32]) else {
            unreachable!("a slice of 32 elements")
        };
        // SAFETY: `dst` is 32 writable bytes; the store is unaligned.
        unsafe { _mm256_storeu_si256(dst.as_mut_ptr().cast(), v) };
        k += 32;
    }
    crate::sgm::matching::cost_cells(code, &right[k..n], &mask[k..n], n_bits, &mut out[k..n]);
}

/// The first lanes of the 32-lane vectors over `nd` disparities:
/// whole vectors, the last one overlapping the one before when `nd` is
/// not a multiple of 32; none below 32. A plain range (the chained
/// iterator it replaces cost a branch on an `Option` per vector).
#[inline]
fn vector_starts(nd: usize) -> impl Iterator<Item = usize> + Clone {
    let n = if nd >= 32 { nd.div_ceil(32) } else { 0 };
    (0..n).map(move |i| (32 * i).min(nd - 32))
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
/// `extra` (the other pass's sums, or empty) is added to the sum
/// before it is stored.
#[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
#[allow(
    clippy::needless_range_loop,
    clippy::needless_pass_by_value,
    clippy::too_many_arguments
)]
pub(super) fn step4_512(
    cost: &[u8],
    prev: [&[u16]; 4],
    prev_min: [u16; 4],
    p1: u16,
    p2: u16,
    cur: [&mut [u16]; 4],
    out: &mut [u16],
    extra: &[u16],
) -> [u16; 4] {
    let with_extra = !extra.is_empty();
    let nd = cost.len();
    // Whole vectors, the last one overlapping the one before when nd
    // is not a multiple of 32 (recomputing a cell gives the same value;
    // minima do not mind a lane seen twice); below 32 disparities, one
    // by one.
    let starts = vector_starts(nd);
    let done = if nd >= 32 { nd } else { 0 };
    let vp1 = _mm512_set1_epi16(p1 as i16);
    let lim = prev_min.map(|m| _mm512_set1_epi16((m + p2) as i16));
    let vm = prev_min.map(|m| _mm512_set1_epi16(m as i16));
    let mut vmin = [_mm512_set1_epi16(-1); 4];
    // Lane i takes lane i - 1 (up; lane 0 is then replaced) or lane
    // i + 1 (down; lane 31 replaced).
    let up = _mm512_set_epi16(
        30, 29, 28, 27, 26, 25, 24, 23, 22, 21, 20, 19, 18, 17, 16, 15, 14, 13, 12, 11, 10, 9, 8,
        7, 6, 5, 4, 3, 2, 1, 0, 0,
    );
    let down = _mm512_set_epi16(
        31, 31, 30, 29, 28, 27, 26, 25, 24, 23, 22, 21, 20, 19, 18, 17, 16, 15, 14, 13, 12, 11, 10,
        9, 8, 7, 6, 5, 4, 3, 2, 1,
    );
    for k in starts.clone() {
        let Ok(c8) = <&[u8; 32]>::try_from(&cost[k..k + 32]) else {
            unreachable!("a slice of 32 elements")
        };
        // SAFETY: `c8` is 32 readable bytes; the load is unaligned.
        let c = _mm512_cvtepu8_epi16(unsafe { _mm256_loadu_si256(c8.as_ptr().cast()) });
        let mut sum = if with_extra {
            load_w(lanes_w(extra, k))
        } else {
            _mm512_setzero_si512()
        };
        for j in 0..4 {
            let q = prev[j];
            let mid = load_w(lanes_w(q, k + 1));
            let (lo, hi) = if j == 0 {
                // The in-row path's previous cells were stored by the
                // previous pixel's step just before: loads one lane
                // off those stores cannot take their data from the
                // store buffer and wait for the stores to reach the
                // cache, on the in-row path's dependency chain. The
                // same lanes from `mid` shifted by one, and the one
                // lane shifted in read as a scalar, within one store.
                (
                    _mm512_mask_set1_epi16(_mm512_permutexvar_epi16(up, mid), 1, q[k] as i16),
                    _mm512_mask_set1_epi16(
                        _mm512_permutexvar_epi16(down, mid),
                        1 << 31,
                        q[k + 33] as i16,
                    ),
                )
            } else {
                (load_w(lanes_w(q, k)), load_w(lanes_w(q, k + 2)))
            };
            // min(lo + p1, hi + p1) as min(lo, hi) + p1: one add
            // fewer, the same value (no term wraps: all stay below
            // BIG + 8000 < 65536).
            let near = _mm512_add_epi16(_mm512_min_epu16(lo, hi), vp1);
            let best = _mm512_min_epu16(_mm512_min_epu16(mid, near), lim[j]);
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
        let mut sum = if with_extra { extra[k] } else { 0 };
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

/// `sgm::matching::pick` 32 u16 lanes at a time: the smallest sum
/// and the first lane equal to it (the first smallest, as the scalar
/// key minimum), then the smallest sum outside best - 1 ..= best + 1
/// (those lanes masked to u16::MAX); below 32 disparities, one by
/// one.
#[target_feature(enable = "avx2,popcnt,avx512f,avx512bw,avx512vl,avx512vpopcntdq")]
pub(super) fn pick_512(s: &[u16]) -> (usize, u16) {
    let nd = s.len();
    // Whole vectors, the last one overlapping the one before when nd
    // is not a multiple of 32 (recomputing a cell gives the same value;
    // minima do not mind a lane seen twice); below 32 disparities, one
    // by one.
    let starts = vector_starts(nd);
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
        31, 30, 29, 28, 27, 26, 25, 24, 23, 22, 21, 20, 19, 18, 17, 16, 15, 14, 13, 12, 11, 10, 9,
        8, 7, 6, 5, 4, 3, 2, 1, 0,
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
