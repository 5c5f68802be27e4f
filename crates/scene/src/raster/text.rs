//! Text on images in the 8 x 8 bitmap font of `font8x8` (no font files, no
//! rasteriser): titles, legends and axis labels of vpctl's plots.

use font8x8::{UnicodeFonts, BASIC_FONTS};
use image::Rgb;

use super::RgbImage;

/// Side of a glyph, pixels.
pub const GLYPH_PX: i64 = 8;

/// Writes `s` with its top-left corner at (x, y), clipped to the image;
/// characters outside basic Latin are drawn as `?`.
pub fn draw_text(img: &mut RgbImage, x: i64, y: i64, s: &str, c: Rgb<u8>) {
    let (w, h) = (i64::from(img.width()), i64::from(img.height()));
    for (k, ch) in s.chars().enumerate() {
        let glyph = BASIC_FONTS
            .get(ch)
            .or_else(|| BASIC_FONTS.get('?'))
            .unwrap_or([0; 8]);
        let left = x + GLYPH_PX * k as i64;
        for (row, bits) in (0..).zip(glyph) {
            for col in 0..GLYPH_PX {
                let (px, py) = (left + col, y + row);
                if bits >> col & 1 == 1 && px >= 0 && py >= 0 && px < w && py < h {
                    img.put_pixel(px as u32, py as u32, c);
                }
            }
        }
    }
}

/// Width of `s` in pixels.
pub fn text_width(s: &str) -> i64 {
    GLYPH_PX * s.chars().count() as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_draws_the_glyphs_bits_left_to_right() {
        let mut img = RgbImage::from_pixel(20, 10, Rgb([255, 255, 255]));
        draw_text(&mut img, 1, 1, "1", Rgb([0, 0, 0]));
        let inked: Vec<(u32, u32)> = (0..10)
            .flat_map(|y| (0..20).map(move |x| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y) == &Rgb([0, 0, 0]))
            .collect();
        let glyph = BASIC_FONTS.get('1').unwrap();
        let bits: u32 = glyph.iter().map(|b| b.count_ones()).sum();
        assert_eq!(inked.len() as u32, bits);
        // Every inked pixel is inside the glyph cell at (1, 1).
        assert!(inked
            .iter()
            .all(|&(x, y)| (1..9).contains(&x) && (1..9).contains(&y)));
        // Off-image text is clipped, not a panic.
        draw_text(&mut img, 15, 8, "WWW", Rgb([0, 0, 0]));
        draw_text(&mut img, -30, -30, "x", Rgb([0, 0, 0]));
    }
}
