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
/// padded by [`PAD`] pixels of replicated border.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LabPlanes {
    width: u32,
    height: u32,
    stride: usize,
    plane_len: usize,
    data: Vec<u8>,
}

/// Entries of the cube-root table over [0, CBRT_MAX].
const CBRT_STEPS: usize = 4096;
/// X/Xn, Y/Yn, Z/Zn stay below about 1.0 for sRGB; a margin covers rounding.
const CBRT_MAX: f32 = 1.1;
/// (6/29)^3: below it CIE's f(t) is linear.
const EPSILON: f32 = 0.008_856_452;

/// Lookup tables, built once: sRGB byte to linear light, and the cube root
/// (libm's `cbrtf` would dominate the conversion of a 16 Mpx image).
struct Tables {
    linear: [f32; 256],
    cbrt: Vec<f32>,
}

fn tables() -> &'static Tables {
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    TABLES.get_or_init(|| {
        let mut linear = [0.0f32; 256];
        for (i, v) in linear.iter_mut().enumerate() {
            let c = i as f64 / 255.0;
            *v = if c <= 0.040_45 {
                c / 12.92
            } else {
                ((c + 0.055) / 1.055).powf(2.4)
            } as f32;
        }
        let cbrt = (0..=CBRT_STEPS + 1)
            .map(|i| (f64::from(CBRT_MAX) * i as f64 / CBRT_STEPS as f64).cbrt() as f32)
            .collect();
        Tables { linear, cbrt }
    })
}

/// CIE f(t): cube root above (6/29)^3, linear below.
#[inline]
fn cie_f(t: f32, cbrt: &[f32]) -> f32 {
    if t <= EPSILON {
        t * 7.787_037 + 4.0 / 29.0
    } else {
        let x = t.min(CBRT_MAX) * (CBRT_STEPS as f32 / CBRT_MAX);
        let i = (x as usize).min(CBRT_STEPS - 1);
        let f = x - i as f32;
        cbrt[i] + f * (cbrt[i + 1] - cbrt[i])
    }
}

/// Quantised Lab of one sRGB pixel.
#[inline]
pub fn rgb_to_lab8(rgb: [u8; 3]) -> [u8; 3] {
    let t = tables();
    let (r, g, b) = (
        t.linear[rgb[0] as usize],
        t.linear[rgb[1] as usize],
        t.linear[rgb[2] as usize],
    );
    let x = (0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b) / 0.950_47;
    let y = 0.212_672_9 * r + 0.715_152_2 * g + 0.072_175 * b;
    let z = (0.019_333_9 * r + 0.119_192 * g + 0.950_304_1 * b) / 1.088_83;
    let (fx, fy, fz) = (cie_f(x, &t.cbrt), cie_f(y, &t.cbrt), cie_f(z, &t.cbrt));
    let l = 116.0 * fy - 16.0;
    let a = 500.0 * (fx - fy);
    let bb = 200.0 * (fy - fz);
    let q = |v: f32| v.round().clamp(0.0, 255.0) as u8;
    [q(l * 2.55), q(a + 128.0), q(bb + 128.0)]
}

impl LabPlanes {
    /// Converts an RGB image (rows in parallel).
    ///
    /// # Performance
    /// Table lookups and nine multiply-adds per pixel; about 3 to 6 ns per
    /// pixel and core.
    pub fn from_rgb(image: &RgbImage) -> Self {
        let (width, height) = image.dimensions();
        let (w, h) = (width as usize, height as usize);
        let stride = w + 2 * PAD;
        let plane_len = stride * (h + 2 * PAD);
        let mut data = vec![0u8; 3 * plane_len];
        if w == 0 || h == 0 {
            return LabPlanes {
                width,
                height,
                stride,
                plane_len,
                data,
            };
        }
        // Convert the image rows once, interleaved, then scatter into padded planes.
        let raw = image.as_raw();
        let mut lab = vec![0u8; 3 * w * h];
        lab.par_chunks_mut(3 * w)
            .zip(raw.par_chunks(3 * w))
            .for_each(|(out, row)| {
                for (o, p) in out.chunks_exact_mut(3).zip(row.chunks_exact(3)) {
                    o.copy_from_slice(&rgb_to_lab8([p[0], p[1], p[2]]));
                }
            });
        let (planes01, plane2) = data.split_at_mut(2 * plane_len);
        let (plane0, plane1) = planes01.split_at_mut(plane_len);
        for (c, plane) in [plane0, plane1, plane2].into_iter().enumerate() {
            plane
                .par_chunks_mut(stride)
                .enumerate()
                .for_each(|(py, out)| {
                    let y = py.saturating_sub(PAD).min(h - 1);
                    let src = &lab[3 * w * y..3 * w * (y + 1)];
                    for (px, o) in out.iter_mut().enumerate() {
                        let x = px.saturating_sub(PAD).min(w - 1);
                        *o = src[3 * x + c];
                    }
                });
        }
        LabPlanes {
            width,
            height,
            stride,
            plane_len,
            data,
        }
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

    /// The three padded planes, L then a then b.
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
mod tests {
    use super::*;

    #[test]
    fn known_colours_convert_to_their_lab_values() {
        // Reference values from the CIE formulas in double precision.
        assert_eq!(rgb_to_lab8([0, 0, 0]), [0, 128, 128]);
        assert_eq!(rgb_to_lab8([255, 255, 255]), [255, 128, 128]);
        // sRGB red: L 53.24, a 80.09, b 67.20.
        assert_eq!(rgb_to_lab8([255, 0, 0]), [136, 208, 195]);
        // sRGB blue: L 32.30, a 79.19, b -107.86.
        assert_eq!(rgb_to_lab8([0, 0, 255]), [82, 207, 20]);
        // Mid grey 128: L 53.59.
        assert_eq!(rgb_to_lab8([128, 128, 128]), [137, 128, 128]);
    }

    #[test]
    fn padding_replicates_the_border() {
        let img = RgbImage::from_fn(4, 3, |x, y| {
            image::Rgb([(x * 60) as u8, (y * 100) as u8, 0])
        });
        let lab = LabPlanes::from_rgb(&img);
        for c in 0..3 {
            let p = &lab.data()[c * lab.plane_len()..(c + 1) * lab.plane_len()];
            for y in -(PAD as i64)..3 + PAD as i64 {
                for x in -(PAD as i64)..4 + PAD as i64 {
                    let idx = (y + PAD as i64) as usize * lab.stride() + (x + PAD as i64) as usize;
                    let cx = x.clamp(0, 3) as u32;
                    let cy = y.clamp(0, 2) as u32;
                    assert_eq!(p[idx], rgb_to_lab8(img.get_pixel(cx, cy).0)[c]);
                }
            }
        }
    }
}
