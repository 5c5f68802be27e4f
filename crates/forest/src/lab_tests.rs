//! Tests of [`super`]: the conversion against the CIE formulas, the fast
//! paths against the per-pixel one, padding and bands.

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

/// The fast conversion against the CIE formulas in double precision:
/// off by at most one quantisation step (at rounding boundaries), rarely.
#[test]
fn conversion_matches_the_double_precision_reference() {
    let lin = |c: u8| {
        let c = f64::from(c) / 255.0;
        if c <= 0.040_45 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let f = |t: f64| {
        if t > 0.008_856_452 {
            t.cbrt()
        } else {
            t * 7.787_037 + 4.0 / 29.0
        }
    };
    let mut off = 0;
    let mut n = 0;
    for r in (0..=255u8).step_by(5) {
        for g in (0..=255u8).step_by(5) {
            for b in (0..=255u8).step_by(5) {
                let (lr, lg, lb) = (lin(r), lin(g), lin(b));
                let x = (0.412_456_4 * lr + 0.357_576_1 * lg + 0.180_437_5 * lb) / 0.950_47;
                let y = 0.212_672_9 * lr + 0.715_152_2 * lg + 0.072_175 * lb;
                let z = (0.019_333_9 * lr + 0.119_192 * lg + 0.950_304_1 * lb) / 1.088_83;
                let q = |v: f64| v.round().clamp(0.0, 255.0) as i32;
                let want = [
                    q((116.0 * f(y) - 16.0) * 2.55),
                    q(500.0 * (f(x) - f(y)) + 128.0),
                    q(200.0 * (f(y) - f(z)) + 128.0),
                ];
                let got = rgb_to_lab8([r, g, b]);
                for (g, w) in got.iter().zip(want) {
                    assert!(
                        (i32::from(*g) - w).abs() <= 1,
                        "rgb {r} {g} {b}: {got:?} vs {want:?}"
                    );
                    off += usize::from(i32::from(*g) != w);
                    n += 1;
                }
            }
        }
    }
    assert!(off * 100 < n, "{off} of {n} values off by one");
}

/// [`cie_f`] as it was with a saturating cast: the reference the
/// bit-exact rewrite is held to.
fn cie_f_with_cast(t: f32) -> f32 {
    let x = t.max(EPSILON);
    let bits = x.to_bits() as i32 as f32;
    let mut y = f32::from_bits((1_419_789_131.0 - bits * (1.0 / 3.0)) as i32 as u32);
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

/// Every f32 from 0 to 2 (X, Y, Z of sRGB lie in [0, 1.0001]) gives
/// the same bits as with the cast, so the Lab planes, and every
/// prediction made from them, are unchanged.
#[test]
fn cube_root_is_bit_identical_to_the_saturating_cast() {
    let mut bits = 0u32;
    while f32::from_bits(bits) < 2.0 {
        let t = f32::from_bits(bits);
        assert_eq!(
            cie_f(t).to_bits(),
            cie_f_with_cast(t).to_bits(),
            "t = {t:e}"
        );
        // Below EPSILON every t reads the same estimate: stride there.
        bits += if t < EPSILON { 4099 } else { 1 };
    }
}

/// Whole-image conversion (chunks of a row, the last one partial) equals
/// the per-pixel function.
#[test]
fn image_conversion_equals_per_pixel_conversion() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let img = RgbImage::from_fn(301, 41, |_, _| image::Rgb(rng.random()));
    let lab = LabPlanes::from_rgb(&img);
    for (x, y, p) in img.enumerate_pixels() {
        let want = rgb_to_lab8(p.0);
        for (c, w) in want.iter().enumerate() {
            assert_eq!(lab.at(i64::from(x), i64::from(y), c), *w);
        }
    }
}

/// The row conversion runs with the instruction set picked at run time
/// (AVX2 on most x86-64), `rgb_to_lab8` with the baseline one: equal
/// on every colour with b in steps of 3 (5.6M colours), so the
/// wider vectors change no Lab value.
#[test]
fn dispatched_conversion_equals_the_baseline_per_pixel_path() {
    let colour = |i: u32| {
        [
            (i % 256) as u8,
            (i / 256 % 256) as u8,
            (3 * (i / 65_536)).min(255) as u8,
        ]
    };
    let img = RgbImage::from_fn(4096, 1376, |x, y| image::Rgb(colour(y * 4096 + x)));
    let lab = LabPlanes::from_rgb(&img);
    for y in 0..1376 {
        for x in 0..4096 {
            let want = rgb_to_lab8(colour(y * 4096 + x));
            let base = lab.base(x, y);
            let got = [0, 1, 2].map(|c| lab.data()[c * lab.plane_len() + base]);
            assert_eq!(got, want, "pixel ({x}, {y})");
        }
    }
}

/// A band's planes hold, at every pixel of the band and every offset
/// up to PAD from it, what the whole image's planes hold, whatever the
/// scratch held before (larger and smaller bands, other images).
#[test]
fn a_band_reads_like_the_whole_image() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let mut scratch = LabPlanes::default();
    for (w, h, y0, rows) in [
        (40, 30, 0, 30),
        (90, 70, 13, 20),
        (7, 3, 1, 40),
        (120, 11, 10, 1),
        (3, 2, 0, 2),
    ] {
        let img = RgbImage::from_fn(w, h, |_, _| image::Rgb(rng.random()));
        let whole = LabPlanes::from_rgb(&img);
        scratch.convert_band_into(&img, y0, rows);
        let pad = PAD as i64;
        for y in y0 as i64..(y0 + rows).min(h as usize) as i64 {
            for x in 0..i64::from(w) {
                for (dx, dy) in [
                    (0, 0),
                    (-pad, -pad),
                    (pad, pad),
                    (-pad, pad),
                    (3, -pad),
                    (pad, 1),
                ] {
                    let at = |p: &LabPlanes, row: i64| {
                        let i = (row + dy + pad) as usize * p.stride() + (x + dx + pad) as usize;
                        [0, 1, 2].map(|c| p.data()[c * p.plane_len() + i])
                    };
                    assert_eq!(
                        at(&scratch, y - y0 as i64),
                        at(&whole, y),
                        "{w}x{h}, band {y0}+{rows}, ({x}, {y}) + ({dx}, {dy})"
                    );
                }
            }
        }
    }
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
