//! The sums of a window cut by the reference image's border
//! (`cost::sums_partial`) with AVX2, under the rules of `simd/mod.rs`.
//!
//! Why: near the border a window keeps only its samples inside the
//! reference image, and each is tested against the source image on its
//! own, so these windows take a per-sample path: a division, four range
//! tests and a bilinear sample per window sample, one sample at a time.
//! On small images that path is much of the matching (14 % of vp-mvs's
//! instructions on `fast_256`'s 256 x 256 triplet; docs/performance.md,
//! "Stop 62"). Here eight samples' coordinates, tests and bilinear
//! samples are computed at once, each lane with the scalar loop's
//! operations in its order; the sums are then added sample after sample
//! as the scalar loop adds them, so the result is the same bits (tested in
//! `cost.rs`).

use super::Avx2;

/// What `cost::sums_partial` reads: the window's samples inside the
/// reference image (offsets from the pixel, weights, weighted mean-free
/// values), the pixel's warped position `hp` and the homography `h`, and
/// the source image.
pub(crate) struct CutWindow<'a> {
    pub dx: &'a [f32],
    pub dy: &'a [f32],
    pub w: &'a [f32],
    pub wr: &'a [f32],
    pub hp: [f32; 3],
    pub h: &'a [f32; 9],
    /// The source image, row-major, `width` x `height` pixels.
    pub data: &'a [f32],
    pub width: usize,
    pub height: usize,
}

impl Avx2 {
    /// `cost::sums_partial`'s result, the same bits: `Some(None)` where a
    /// sample leaves the source image or a plane's front; `None` for
    /// shapes the vector code does not take (then the caller runs the
    /// scalar loop).
    #[allow(clippy::unused_self)] // `self` is the proof that AVX2 is there
    #[allow(clippy::option_option)] // not taken, refused, or the sums
    pub(crate) fn sums_partial(self, c: &CutWindow) -> Option<Option<[f32; 3]>> {
        let n = c.w.len();
        let pixels = c.width.checked_mul(c.height);
        let ok = c.dx.len() == n
            && c.dy.len() == n
            && c.wr.len() == n
            && c.width > 0
            && c.height > 0
            && pixels.is_some_and(|p| p <= c.data.len() && i32::try_from(p).is_ok());
        if !ok {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` exists only if `detect` found AVX2 on this CPU,
            // the one feature `x86::sums_partial` is compiled for.
            Some(unsafe { x86::sums_partial(c) })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = self;
            None
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::CutWindow;
    use crate::cost::CHUNK;
    use std::arch::x86_64::{
        __m256, __m256i, _mm256_add_epi32, _mm256_add_ps, _mm256_and_ps, _mm256_and_si256,
        _mm256_cmp_ps, _mm256_cmpgt_epi32, _mm256_cvtepi32_ps, _mm256_cvttps_epi32, _mm256_div_ps,
        _mm256_i32gather_ps, _mm256_loadu_ps, _mm256_max_epi32, _mm256_min_epi32,
        _mm256_movemask_ps, _mm256_mul_ps, _mm256_mullo_epi32, _mm256_set1_epi32, _mm256_set1_ps,
        _mm256_setzero_ps, _mm256_setzero_si256, _mm256_storeu_ps, _mm256_sub_ps, _CMP_GE_OQ,
        _CMP_GT_OQ, _CMP_LE_OQ,
    };

    /// Eight floats from a bounds-checked array.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(a: &[f32; CHUNK]) -> __m256 {
        // SAFETY: `a` is 8 readable floats; the load is unaligned.
        unsafe { _mm256_loadu_ps(a.as_ptr()) }
    }

    /// See [`super::Avx2::sums_partial`]; the caller checked the shapes:
    /// equal lengths, a non-empty image whose pixels `data` holds and
    /// whose pixel count fits an i32.
    #[target_feature(enable = "avx2")]
    pub(super) fn sums_partial(c: &CutWindow) -> Option<[f32; 3]> {
        let (h, [p0, p1, p2]) = (c.h, c.hp);
        let set = _mm256_set1_ps;
        let zero = _mm256_setzero_ps();
        // `GreyImage::sample`'s range: the span of the pixel centres.
        let (x_max, y_max) = (set((c.width - 1) as f32), set((c.height - 1) as f32));
        let width = _mm256_set1_epi32(c.width as i32);
        let (x_last, y_last) = (
            _mm256_set1_epi32(c.width as i32 - 1),
            _mm256_set1_epi32(c.height as i32 - 1),
        );
        let last = _mm256_set1_epi32((c.data.len().min(i32::MAX as usize) - 1) as i32);
        let (mut s1, mut s2, mut sr) = (0.0f32, 0.0f32, 0.0f32);
        let n = c.w.len();
        for first in (0..n).step_by(CHUNK) {
            let live = (n - first).min(CHUNK);
            let (mut dx, mut dy) = ([0.0f32; CHUNK], [0.0f32; CHUNK]);
            dx[..live].copy_from_slice(&c.dx[first..first + live]);
            dy[..live].copy_from_slice(&c.dy[first..first + live]);
            let (dx, dy) = (load(&dx), load(&dy));
            // The scalar loop's `hp + h d` sums, in its order.
            let along = |p: f32, a: f32, b: f32| {
                _mm256_add_ps(
                    _mm256_add_ps(set(p), _mm256_mul_ps(set(a), dx)),
                    _mm256_mul_ps(set(b), dy),
                )
            };
            let z = along(p2, h[6], h[7]);
            let iz = _mm256_div_ps(set(1.0), z);
            let fx = _mm256_sub_ps(_mm256_mul_ps(along(p0, h[0], h[1]), iz), set(0.5));
            let fy = _mm256_sub_ps(_mm256_mul_ps(along(p1, h[3], h[4]), iz), set(0.5));
            // The scalar tests, ordered (NaN fails each): the sample lies
            // in front of the source and within its pixel centres.
            let inside = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(z, zero),
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_GE_OQ>(fx, zero),
                        _mm256_cmp_ps::<_CMP_GE_OQ>(fy, zero),
                    ),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LE_OQ>(fx, x_max),
                    _mm256_cmp_ps::<_CMP_LE_OQ>(fy, y_max),
                ),
            );
            let live_bits = (1i32 << live) - 1;
            if _mm256_movemask_ps(inside) & live_bits != live_bits {
                return None;
            }
            // Truncation is the floor here (0 <= f), and the lanes' integer
            // parts are below 2^31: `as usize` and back `as f32` alike.
            let (x0, y0) = (_mm256_cvttps_epi32(fx), _mm256_cvttps_epi32(fy));
            let ax = _mm256_sub_ps(fx, _mm256_cvtepi32_ps(x0));
            let ay = _mm256_sub_ps(fy, _mm256_cvtepi32_ps(y0));
            // The next column (1) and row (width) unless on the last one.
            let right = _mm256_and_si256(_mm256_cmpgt_epi32(x_last, x0), _mm256_set1_epi32(1));
            let down = _mm256_and_si256(_mm256_cmpgt_epi32(y_last, y0), width);
            let i = _mm256_add_epi32(_mm256_mullo_epi32(y0, width), x0);
            let tap = |at: __m256i| {
                // Clamped into `data` in-register, whatever the lanes hold
                // (the padding lanes' are unused).
                let at = _mm256_min_epi32(_mm256_max_epi32(at, _mm256_setzero_si256()), last);
                // SAFETY: every lane of `at` is in [0, data.len() - 1].
                unsafe { _mm256_i32gather_ps::<4>(c.data.as_ptr(), at) }
            };
            let (d00, d01) = (tap(i), tap(_mm256_add_epi32(i, right)));
            let i1 = _mm256_add_epi32(i, down);
            let (d10, d11) = (tap(i1), tap(_mm256_add_epi32(i1, right)));
            let top = _mm256_add_ps(d00, _mm256_mul_ps(ax, _mm256_sub_ps(d01, d00)));
            let bottom = _mm256_add_ps(d10, _mm256_mul_ps(ax, _mm256_sub_ps(d11, d10)));
            let s = _mm256_add_ps(top, _mm256_mul_ps(ay, _mm256_sub_ps(bottom, top)));
            let mut sv = [0.0f32; CHUNK];
            // SAFETY: `sv` is 8 writable floats; the store is unaligned.
            unsafe { _mm256_storeu_ps(sv.as_mut_ptr(), s) };
            // Sample after sample, as the scalar loop adds them.
            let k = first..first + live;
            for ((&s, &w), &wr) in sv.iter().zip(&c.w[k.clone()]).zip(&c.wr[k]) {
                let ws = w * s;
                s1 += ws;
                s2 += ws * s;
                sr += wr * s;
            }
        }
        Some([s1, s2, sr])
    }
}
