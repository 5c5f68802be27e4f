//! The reference side of the NCC (`RefPatch`): built once per pixel and
//! update, shared by every hypothesis and source scored there.

use super::{lane_total, Window, CHUNK, MIN_VARIANCE};
use crate::fast_exp;
use crate::view::GreyImage;

/// The reference side of the NCC at one pixel: the window samples that fall
/// inside the image, their bilateral weights and their weighted-mean-free
/// intensities (times the weight). Built once per pixel and iteration,
/// shared by every hypothesis and source scored there; the vectors are
/// reused from pixel to pixel, so the hot loop allocates nothing.
#[derive(Debug, Default)]
pub(crate) struct RefPatch {
    /// Sample offsets; filled only for a window cut by the image border.
    pub(super) dx: Vec<f32>,
    pub(super) dy: Vec<f32>,
    /// Bilateral weight of each sample.
    pub(super) w: Vec<f32>,
    /// Weight times (intensity minus the weighted mean).
    pub(super) wr: Vec<f32>,
    pub(super) sum_w: f32,
    /// Sum of w * (intensity - mean)^2.
    pub(super) var: f32,
    /// 1 / `sum_w` and 1 / sqrt(`var`), once per patch, so that the NCC
    /// of each source scored ([`source_cost`](super::source_cost)) waits
    /// on one square root and one division, not on two divisions and a
    /// square root.
    pub(super) inv_sum_w: f32,
    pub(super) inv_sd: f32,
    /// Whether every sample of the window lies inside the image: then the
    /// samples are the full grid in the [`Window`]'s packed layout, padded
    /// with zero weights, and a source is scored by the chunked fast path
    /// ([`source_cost`](super::source_cost)).
    pub(super) full: bool,
    /// Each window sample's offset in the image data from the window's
    /// first sample, for images `taps_width` wide, padded with 0 to whole
    /// chunks (kept from pixel to pixel; see [`RefPatch::fill`]).
    taps: Vec<i32>,
    taps_width: usize,
}

impl RefPatch {
    /// Fills the patch of pixel (x, y) of `image`: [`RefPatch::fill`],
    /// compiled with AVX2 where the CPU has it (the same bits: the weights'
    /// `exp` runs 8 lanes wide instead of 4, every operation the same).
    pub(crate) fn build(&mut self, image: &GreyImage, x: usize, y: usize, win: &Window) {
        match win.avx2 {
            Some(avx2) => avx2.build_patch(self, image, (x, y), win),
            None => self.fill(image, x, y, win, &Scalar),
        }
    }

    /// The body of [`RefPatch::build`], inlined into each SIMD level's copy.
    ///
    /// Every weight and sum is computed per lane of the packed layout, in
    /// the same order for a full window and a cut one, so that the bits do
    /// not depend on how the loops are written (tested against a plain
    /// loop, `fill_matches_the_plain_loop_bit_for_bit`). For a full window
    /// the loops walk whole chunks of [`CHUNK`] fixed-size arrays, so that
    /// they vectorise with no bounds test per lane, and read the image
    /// through [`RefPatch::taps`], offsets computed once per row task;
    /// `kernels` read the samples and take the moments ([`Scalar`], or
    /// AVX2's: the same bits).
    #[allow(clippy::inline_always)] // inlined, it is compiled for each SIMD level
    #[inline(always)]
    pub(crate) fn fill(
        &mut self,
        image: &GreyImage,
        x: usize,
        y: usize,
        win: &Window,
        kernels: &impl PatchKernels,
    ) {
        self.dx.clear();
        self.dy.clear();
        self.sum_w = 0.0;
        self.var = 0.0;
        self.inv_sum_w = 0.0;
        self.inv_sd = 0.0;
        let (xi, yi) = (x as i32, y as i32);
        let Some(centre) = image.at(xi, yi) else {
            self.full = false;
            self.w.clear();
            self.wr.clear();
            return;
        };
        let (iw, ih) = (image.width as i32, image.height as i32);
        self.full = xi + win.first() >= 0
            && yi + win.first() >= 0
            && xi + win.last() < iw
            && yi + win.last() < ih;
        if self.full {
            self.fill_full(image, (x, y), centre, win, kernels);
            return;
        }
        self.w.clear();
        self.wr.clear();
        for (&(ox, oy), &s) in win.grid.iter().zip(&win.spatial) {
            let Some(v) = image.at(xi + ox, yi + oy) else {
                continue;
            };
            let dc = v - centre;
            let wt = s * fast_exp::exp(-dc * dc * win.inv_color);
            self.dx.push(ox as f32);
            self.dy.push(oy as f32);
            self.w.push(wt);
            self.wr.push(v);
        }
        // `wr` holds the intensities until the mean is known.
        let (sw, var) = lane_moments(&self.w, &mut self.wr);
        self.set_moments(sw, var);
    }

    /// [`RefPatch::fill`] for a window inside the image: the intensities in
    /// the packed layout (padding lanes 0), every weight in one loop that
    /// vectorises ([`fast_exp`]; padding lanes get weight 0 from their zero
    /// spatial weight), then the moments, a chunk at a time.
    #[allow(clippy::inline_always)] // inlined into `fill`'s SIMD copies
    #[inline(always)]
    fn fill_full(
        &mut self,
        image: &GreyImage,
        (x, y): (usize, usize),
        centre: f32,
        win: &Window,
        kernels: &impl PatchKernels,
    ) {
        let lanes = win.lanes();
        let w = image.width as usize;
        if self.taps_width != w || self.taps.len() != lanes {
            // Each sample's offset from the window's first, in this image,
            // 0 on padding; -1 (read as 0) if it does not fit an i32,
            // which only an image over 100 M pixels wide would need.
            let first = i64::from(win.first());
            self.taps = (0..lanes)
                .map(|k| {
                    win.grid.get(k).map_or(0, |&(ox, oy)| {
                        let o = (i64::from(oy) - first) * w as i64 + (i64::from(ox) - first);
                        i32::try_from(o).unwrap_or(-1)
                    })
                })
                .collect();
            self.taps_width = w;
        }
        let span = (win.last() - win.first()) as usize;
        // In range: the window is inside the image.
        let (x0, y0) = (x as i32 + win.first(), y as i32 + win.first());
        let top_left = y0 as usize * w + x0 as usize;
        let region = &image.data[top_left..=top_left + span * w + span];
        self.wr.resize(lanes, 0.0);
        self.w.resize(lanes, 0.0);
        kernels.gather(
            region,
            self.taps.as_chunks::<CHUNK>().0,
            self.wr.as_chunks_mut::<CHUNK>().0,
        );
        self.wr[win.samples()..].fill(0.0);
        // A plain loop over slices, not `extend` of a mapped iterator:
        // that left `Iterator::fold` as a function of its own, which the
        // AVX2 copy of this body did not inline, so the `exp` ran on SSE.
        for ((wt, &v), &s) in self.w.iter_mut().zip(&self.wr).zip(&win.spatial) {
            let dc = v - centre;
            *wt = s * fast_exp::exp(-dc * dc * win.inv_color);
        }
        let (sw, var) = kernels.moments(
            self.w.as_chunks::<CHUNK>().0,
            self.wr.as_chunks_mut::<CHUNK>().0,
        );
        self.set_moments(sw, var);
    }

    /// The weight sum and the weighted variance, and their inverses.
    #[inline]
    fn set_moments(&mut self, sw: f32, var: f32) {
        self.sum_w = sw;
        self.var = var;
        self.inv_sum_w = 1.0 / sw;
        self.inv_sd = 1.0 / var.sqrt();
    }

    /// Whether the patch has texture enough to score anything.
    pub(crate) fn textured(&self) -> bool {
        self.var > MIN_VARIANCE * self.sum_w
    }
}

/// The two loops of a full window's patch build that the compiler does
/// not turn into good vector code by itself: [`Scalar`]'s, and AVX2's
/// (`simd::Avx2`), which must give the same bits.
pub(crate) trait PatchKernels {
    /// `out[k] = region[taps[k]]` for every lane; a tap outside `region`
    /// reads 0 (none is: the window lies inside the image).
    fn gather(&self, region: &[f32], taps: &[[i32; CHUNK]], out: &mut [[f32; CHUNK]]);

    /// With the weights `w` and the intensities `wr` of a window's lanes:
    /// the weight sum and the weighted variance, each summed per lane over
    /// the chunks in order and added up as [`lane_total`] does, and `wr`
    /// replaced by the weight times the intensity minus the weighted mean.
    fn moments(&self, w: &[[f32; CHUNK]], wr: &mut [[f32; CHUNK]]) -> (f32, f32);
}

/// The kernels in plain Rust: the reference, and the path on CPUs
/// without AVX2.
pub(crate) struct Scalar;

impl PatchKernels for Scalar {
    #[allow(clippy::inline_always)] // inlined into `fill`'s SIMD copies
    #[inline(always)]
    fn gather(&self, region: &[f32], taps: &[[i32; CHUNK]], out: &mut [[f32; CHUNK]]) {
        for (t, o) in taps.iter().flatten().zip(out.iter_mut().flatten()) {
            *o = usize::try_from(*t)
                .ok()
                .and_then(|t| region.get(t))
                .copied()
                .unwrap_or(0.0);
        }
    }

    #[allow(clippy::inline_always)] // inlined into `fill`'s SIMD copies
    #[inline(always)]
    fn moments(&self, w: &[[f32; CHUNK]], wr: &mut [[f32; CHUNK]]) -> (f32, f32) {
        lane_moments(w.as_flattened(), wr.as_flattened_mut())
    }
}

/// [`PatchKernels::moments`] over any number of lanes (a cut window's
/// samples, packed): one partial sum per lane of a chunk, each over the
/// chunks in order, added up as [`lane_total`] does, as the window sums
/// are (one running sum made each add wait on the one before).
#[allow(clippy::inline_always)] // inlined into `fill`'s SIMD copies
#[inline(always)]
fn lane_moments(w: &[f32], wr: &mut [f32]) -> (f32, f32) {
    let (mut sw, mut swv) = ([0.0f32; CHUNK], [0.0f32; CHUNK]);
    for (cw, cv) in w.chunks(CHUNK).zip(wr.chunks(CHUNK)) {
        for (l, (&wt, &v)) in cw.iter().zip(cv).enumerate() {
            sw[l] += wt;
            swv[l] += wt * v;
        }
    }
    let (sw, mean) = (lane_total(sw), lane_total(swv) / lane_total(sw));
    let mut var = [0.0f32; CHUNK];
    for (cr, cw) in wr.chunks_mut(CHUNK).zip(w.chunks(CHUNK)) {
        for (l, (wr, &wt)) in cr.iter_mut().zip(cw).enumerate() {
            let r = *wr - mean;
            var[l] += wt * r * r;
            *wr = wt * r;
        }
    }
    (sw, lane_total(var))
}
