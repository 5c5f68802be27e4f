//! CIE Lab conversion, once per image, into padded 8-bit planes.
//!
//! The forest's split tests read single channel values at offsets of up to
//! [`RADIUS`] pixels from the sample. Padding every plane by that radius
//! (replicating the border) removes all bounds checks from the hot loops, and
//! 8-bit quantisation keeps a 27x27x3 patch in 2187 bytes and every test
//! response a small integer, which is what lets thresholds be found with
//! histograms instead of sorting.
//!
//! Quantisation: `L8 = round(L * 255 / 100)`, `a8 = round(a) + 128`,
//! `b8 = round(b) + 128` (clamped to 0..=255), from sRGB with the D65 white.

use rayon::prelude::*;
use vp_scene::raster::RgbImage;

use crate::patch::RADIUS;

/// Number of padding pixels on each side of a plane.
pub const PAD: usize = RADIUS;

/// An image in CIE Lab, quantised to 8 bits per channel, as three planes
/// padded by [`PAD`] pixels of replicated border; optionally followed by the
/// three complemented planes (255 - v). Prediction no longer needs them (it
/// complements per node, see [`crate::predict`]'s docs) and ignores them.
/// `LabPlanes::default()` is empty: a scratch for a band conversion.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LabPlanes {
    width: u32,
    height: u32,
    stride: usize,
    plane_len: usize,
    data: Vec<u8>,
}

/// (6/29)^3: below it CIE's f(t) is linear.
const EPSILON: f32 = 0.008_856_452;

/// sRGB byte to linear light, built once.
fn linear_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0.0f32; 256];
        for (i, v) in t.iter_mut().enumerate() {
            let c = i as f64 / 255.0;
            *v = if c <= 0.040_45 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            } as f32;
        }
        t
    })
}

/// CIE f(t): cube root above (6/29)^3, linear below. The cube root is
/// x * x^(-1/3), the inverse cube root from a bit-trick estimate refined by
/// two Newton steps (relative error about 1e-5, far below the 8-bit
/// quantisation; the reference test bounds its effect). Only multiplies and adds, no branch: the compiler
/// vectorises it, where libm's `cbrtf` is a call per value.
#[inline]
fn cie_f(t: f32) -> f32 {
    let x = t.max(EPSILON);
    // Estimate of x^(-1/3) from the exponent bits, computed in float so it vectorises.
    let bits = x.to_bits() as i32 as f32;
    let mut y = f32::from_bits(integer_to_u32(1_419_789_131.0 - bits * (1.0 / 3.0)));
    for _ in 0..2 {
        y *= (4.0 - x * y * y * y) * (1.0 / 3.0);
    }
    let cube_root = x * y * y;
    let linear = t * 7.787_037 + 4.0 / 29.0;
    if t > EPSILON {
        cube_root
    } else {
        linear
    }
}

/// `v as u32` for an f32 v in [2^29, 2^31) (every such f32 is an integer),
/// from its bits: mantissa with the implicit one, shifted by 6, doubled
/// once more if the exponent says v >= 2^30. The estimate in [`cie_f`]
/// always lies in that range (x in [EPSILON, 2) gives 1.06e9..1.09e9,
/// around 2^30; a test checks every x). A plain `as` cast saturates, which
/// the compiler lowers to scalar code with NaN and overflow fixups per
/// value: this was a fifth of the conversion time.
#[inline]
fn integer_to_u32(v: f32) -> u32 {
    let b = v.to_bits();
    let m = ((b & 0x7f_ffff) | 0x80_0000) << 6;
    // Biased exponent 156 (v < 2^30) or 157: its low bit says which.
    let doubled = 0u32.wrapping_sub((b >> 23) & 1);
    m.wrapping_add(m & doubled)
}

/// Rounds v (clamped to [0, 255]) to the nearest integer by the
/// 1.5 * 2^23 trick: pure float and bit operations, which vectorise, where
/// a float-to-integer cast saturates value by value.
#[inline]
fn quantise(v: f32) -> u8 {
    ((v.clamp(0.0, 255.0) + 12_582_912.0).to_bits() & 0xff) as u8
}

/// XYZ (relative to the D65 white) from linear sRGB.
#[inline]
fn xyz(r: f32, g: f32, b: f32) -> [f32; 3] {
    [
        (0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b) * (1.0 / 0.950_47),
        0.212_672_9 * r + 0.715_152_2 * g + 0.072_175 * b,
        (0.019_333_9 * r + 0.119_192 * g + 0.950_304_1 * b) * (1.0 / 1.088_83),
    ]
}

/// Quantised Lab from f(X), f(Y), f(Z).
#[inline]
fn lab8(fx: f32, fy: f32, fz: f32) -> [u8; 3] {
    [
        quantise((116.0 * fy - 16.0) * 2.55),
        quantise(500.0 * (fx - fy) + 128.0),
        quantise(200.0 * (fy - fz) + 128.0),
    ]
}

/// Quantised Lab of one sRGB pixel.
pub fn rgb_to_lab8(rgb: [u8; 3]) -> [u8; 3] {
    let t = linear_table();
    let [x, y, z] = xyz(t[rgb[0] as usize], t[rgb[1] as usize], t[rgb[2] as usize]);
    lab8(cie_f(x), cie_f(y), cie_f(z))
}

/// [`convert_row`] compiled for the best instruction set the CPU has
/// (`pulp` picks it at run time; AVX2 doubles the vector width of the
/// baseline SSE2). Only the width changes, not the results: Rust never
/// fuses a multiply and an add on its own, so every operation rounds
/// as in the baseline build (a test compares with the per-pixel path).
struct ConvertRow<'a> {
    rgb: &'a [u8],
    out: [&'a mut [u8]; 3],
}

impl pulp::WithSimd for ConvertRow<'_> {
    type Output = ();

    // The CPU features reach only code inlined into the dispatched function.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        convert_row(self.rgb, self.out);
    }
}

/// Pixels converted together: three f32 arrays of this many stay in L1
/// between the passes (a whole 4912-pixel row of them, 59 KB, did not).
const CHUNK: usize = 128;

/// Converts one row, [`CHUNK`] pixels at a time, in passes over small
/// arrays: table lookups, then loops of pure arithmetic of a length the
/// compiler knows, which it turns into SIMD without remainder loops.
#[allow(clippy::inline_always)] // see ConvertRow::with_simd
#[inline(always)]
fn convert_row(rgb: &[u8], out: [&mut [u8]; 3]) {
    let [o0, o1, o2] = out;
    let pixels = rgb.chunks(3 * CHUNK);
    let outs = o0
        .chunks_mut(CHUNK)
        .zip(o1.chunks_mut(CHUNK))
        .zip(o2.chunks_mut(CHUNK));
    for (rgb, ((l, a), b)) in pixels.zip(outs) {
        if rgb.len() == 3 * CHUNK {
            convert_chunk::<CHUNK>(rgb, [l, a, b]);
        } else {
            // The row's last pixels: a whole chunk from padded copies.
            let n = rgb.len() / 3;
            let mut padded = [0u8; 3 * CHUNK];
            padded[..rgb.len()].copy_from_slice(rgb);
            let mut lab = [[0u8; CHUNK]; 3];
            let [pl, pa, pb] = &mut lab;
            convert_chunk::<CHUNK>(&padded, [pl, pa, pb]);
            l.copy_from_slice(&lab[0][..n]);
            a.copy_from_slice(&lab[1][..n]);
            b.copy_from_slice(&lab[2][..n]);
        }
    }
}

/// Converts exactly `N` pixels (`rgb`: 3N bytes; each output: N bytes).
#[allow(clippy::inline_always)] // see ConvertRow::with_simd
#[inline(always)]
fn convert_chunk<const N: usize>(rgb: &[u8], out: [&mut [u8]; 3]) {
    let t = linear_table();
    let (mut c0, mut c1, mut c2) = ([0f32; N], [0f32; N], [0f32; N]);
    for (i, p) in rgb[..3 * N].chunks_exact(3).enumerate() {
        [c0[i], c1[i], c2[i]] = [t[p[0] as usize], t[p[1] as usize], t[p[2] as usize]];
    }
    for i in 0..N {
        [c0[i], c1[i], c2[i]] = xyz(c0[i], c1[i], c2[i]);
    }
    for c in [&mut c0, &mut c1, &mut c2] {
        for v in c.iter_mut() {
            *v = cie_f(*v);
        }
    }
    let [o0, o1, o2] = out;
    let (o0, o1, o2) = (&mut o0[..N], &mut o1[..N], &mut o2[..N]);
    for i in 0..N {
        [o0[i], o1[i], o2[i]] = lab8(c0[i], c1[i], c2[i]);
    }
}

/// Row length and plane length of planes for an image `width` pixels wide
/// and `rows` high (or a band of `rows` rows): the padded layout every
/// [`LabPlanes`] has, which compiled trees' offsets depend on.
pub(crate) fn layout(width: usize, rows: usize) -> (usize, usize) {
    let stride = width + 2 * PAD;
    (stride, stride * (rows + 2 * PAD))
}

/// Converts one image row (`rgb`) into a padded row of each plane
/// (`stride` bytes) and replicates its first and last pixels into the
/// padding.
fn convert_padded_row(arch: pulp::Arch, rgb: &[u8], rows: [&mut [u8]; 3]) {
    let w = rgb.len() / 3;
    let [r0, r1, r2] = rows;
    arch.dispatch(ConvertRow {
        rgb,
        out: [
            &mut r0[PAD..PAD + w],
            &mut r1[PAD..PAD + w],
            &mut r2[PAD..PAD + w],
        ],
    });
    for row in [r0, r1, r2] {
        let (left, right) = (row[PAD], row[PAD + w - 1]);
        row[..PAD].fill(left);
        row[PAD + w..].fill(right);
    }
}

impl LabPlanes {
    /// Converts an RGB image (rows in parallel).
    ///
    /// # Performance
    /// Three table lookups and vectorised arithmetic per pixel, written
    /// straight into the padded planes.
    pub fn from_rgb(image: &RgbImage) -> Self {
        Self::convert(image, false)
    }

    /// [`LabPlanes::from_rgb`] plus the complemented planes (twice the
    /// memory; prediction does not need them).
    pub fn from_rgb_with_complement(image: &RgbImage) -> Self {
        Self::convert(image, true)
    }

    /// These planes with the complemented planes added (a copy).
    pub fn with_complement(&self) -> Self {
        let mut out = self.clone();
        if !out.has_complement() {
            out.data.resize(6 * self.plane_len, 0);
            out.fill_complement();
        }
        out
    }

    /// Whether the complemented planes follow the three Lab planes.
    pub fn has_complement(&self) -> bool {
        self.data.len() == 6 * self.plane_len
    }

    fn fill_complement(&mut self) {
        let (lab, complement) = self.data.split_at_mut(3 * self.plane_len);
        complement
            .par_chunks_mut(1 << 16)
            .zip(lab.par_chunks(1 << 16))
            .for_each(|(out, lab)| {
                for (o, v) in out.iter_mut().zip(lab) {
                    *o = 255 - v;
                }
            });
    }

    fn convert(image: &RgbImage, complement: bool) -> Self {
        let (width, height) = image.dimensions();
        let (w, h) = (width as usize, height as usize);
        let (stride, plane_len) = layout(w, h);
        let mut planes = LabPlanes {
            width,
            height,
            stride,
            plane_len,
            data: vec![0u8; if complement { 6 } else { 3 } * plane_len],
        };
        if w == 0 || h == 0 {
            return planes;
        }
        let raw = image.as_raw();
        let arch = pulp::Arch::new();
        let [p0, p1, p2] = planes.planes_mut();
        let rows = PAD * stride..(PAD + h) * stride;
        p0[rows.clone()]
            .par_chunks_mut(stride)
            .zip(p1[rows.clone()].par_chunks_mut(stride))
            .zip(p2[rows].par_chunks_mut(stride))
            .zip(raw.par_chunks(3 * w))
            .for_each(|(((r0, r1), r2), rgb)| convert_padded_row(arch, rgb, [r0, r1, r2]));
        // Replicate the first and last rows into the top and bottom padding.
        for plane in planes.data[..3 * plane_len].chunks_exact_mut(plane_len) {
            let (top, rest) = plane.split_at_mut(PAD * stride);
            let first = &rest[..stride];
            for row in top.chunks_exact_mut(stride) {
                row.copy_from_slice(first);
            }
            let (body, bottom) = plane.split_at_mut((PAD + h) * stride);
            let last = &body[(PAD + h - 1) * stride..];
            for row in bottom.chunks_exact_mut(stride) {
                row.copy_from_slice(last);
            }
        }
        if complement {
            planes.fill_complement();
        }
        planes
    }

    /// The three Lab planes, mutable.
    fn planes_mut(&mut self) -> [&mut [u8]; 3] {
        let (p01, rest) = self.data.split_at_mut(2 * self.plane_len);
        let (p0, p1) = p01.split_at_mut(self.plane_len);
        [p0, p1, &mut rest[..self.plane_len]]
    }

    /// Converts a band of `image` into these planes, reusing their memory:
    /// planes `rows` high standing for the image rows from `y0`, each plane
    /// row (padding included) converted from the image row it stands for,
    /// clamped into the image. A read up to [`PAD`] pixels from a pixel of
    /// the band sees what the whole image's planes hold there, so a forest
    /// walks a band exactly as it walks the whole image
    /// ([`crate::Forest::predict_image`] converts band by band).
    pub(crate) fn convert_band_into(&mut self, image: &RgbImage, y0: usize, rows: usize) {
        let (width, height) = image.dimensions();
        let (w, h) = (width as usize, height as usize);
        let (stride, plane_len) = layout(w, rows);
        let mut data = std::mem::take(&mut self.data);
        // Stale bytes may stay: every byte of the planes is written below.
        data.resize(3 * plane_len, 0);
        *self = LabPlanes {
            width,
            height: rows as u32,
            stride,
            plane_len,
            data,
        };
        if w == 0 || h == 0 {
            return;
        }
        let raw = image.as_raw();
        let arch = pulp::Arch::new();
        let [p0, p1, p2] = self.planes_mut();
        let rows = p0
            .chunks_mut(stride)
            .zip(p1.chunks_mut(stride))
            .zip(p2.chunks_mut(stride));
        for (r, ((r0, r1), r2)) in rows.enumerate() {
            let y = (y0 + r).saturating_sub(PAD).min(h - 1);
            convert_padded_row(arch, &raw[3 * w * y..3 * w * (y + 1)], [r0, r1, r2]);
        }
    }

    /// Folds the planes' bytes into `h` (see [`crate::TrainingSet::fingerprint`]).
    pub(crate) fn digest(&self, mut h: u64) -> u64 {
        let mut chunks = self.data.chunks_exact(8);
        for c in &mut chunks {
            let mut b = [0u8; 8];
            b.copy_from_slice(c);
            h = crate::train::mix(h, u64::from_le_bytes(b));
        }
        for &b in chunks.remainder() {
            h = crate::train::mix(h, u64::from(b));
        }
        h
    }

    /// Image width in pixels (without padding).
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels (without padding).
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Row length of a padded plane.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// Length of one padded plane; channel c starts at `c * plane_len`.
    pub fn plane_len(&self) -> usize {
        self.plane_len
    }

    /// The padded planes, L then a then b, then (if present) their complements.
    pub fn data(&self) -> &[u8] {
        &self.data
    }

    /// Index in plane 0 of image pixel (x, y); add `c * plane_len` for channel c.
    #[inline]
    pub fn base(&self, x: u32, y: u32) -> usize {
        (y as usize + PAD) * self.stride + x as usize + PAD
    }

    /// Quantised Lab value of pixel (x, y), coordinates clamped into the image.
    pub fn at(&self, x: i64, y: i64, c: usize) -> u8 {
        let x = x.clamp(0, i64::from(self.width) - 1) as u32;
        let y = y.clamp(0, i64::from(self.height) - 1) as u32;
        self.data[c * self.plane_len + self.base(x, y)]
    }
}

#[cfg(test)]
#[path = "lab_tests.rs"]
mod tests;
