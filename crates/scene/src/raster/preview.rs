//! A picture of a confidence image a person can read: the photo beside one
//! colour-mapped panel per angle bin at the photo's aspect ratio, each
//! labelled with its angle range and mean, under a title and above a colour
//! key. `vpctl predict` writes one per image (`<image name>.preview.png`).

use image::imageops::{overlay, resize, FilterType};
use image::Rgb;

use super::{draw_text, text_width, ConfidenceImage, RgbImage};

/// Width of each panel (the photo and every bin), pixels.
pub const PANEL_WIDTH: u32 = 240;
/// Panels per row.
const COLUMNS: usize = 5;
const MARGIN: u32 = 8;
/// Height of a line of text, pixels (8 px glyphs and spacing).
const LINE: u32 = 12;
const KEY_WIDTH: u32 = 200;
const BACKGROUND: Rgb<u8> = Rgb([20, 20, 30]);
const TEXT: Rgb<u8> = Rgb([235, 235, 235]);

/// Where the panels of a preview are: panel 0 is the photo, panel 1 + i is
/// angle bin i; the colour key spans `key` (x, y, width, height).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PreviewLayout {
    /// Size of the whole preview (width, height).
    pub size: (u32, u32),
    /// Size of every panel (width, height).
    pub panel: (u32, u32),
    /// Top-left corner of each panel.
    pub origins: Vec<(u32, u32)>,
    /// The colour key's bar (x, y, width, height): confidence 0 at the left, 1 at the right.
    pub key: (u32, u32, u32, u32),
}

impl PreviewLayout {
    /// The layout of the preview of `conf` under a title of `title_chars` characters.
    pub fn of(conf: &ConfidenceImage, title_chars: usize) -> Self {
        let n = conf.bins().len() + 1;
        let ph = ((f64::from(PANEL_WIDTH) * f64::from(conf.height()) / f64::from(conf.width()))
            .round() as u32)
            .clamp(40, 2 * PANEL_WIDTH);
        let cols = n.min(COLUMNS);
        let rows = n.div_ceil(cols);
        let (cell_w, cell_h) = (PANEL_WIDTH + MARGIN, LINE + ph + MARGIN);
        let top = MARGIN + 2 * LINE;
        let origins = (0..n)
            .map(|k| {
                let (c, r) = ((k % cols) as u32, (k / cols) as u32);
                (MARGIN + c * cell_w, top + r * cell_h + LINE)
            })
            .collect();
        let grid_w = MARGIN + cols as u32 * cell_w;
        let title_w = text_width(&"x".repeat(title_chars)) as u32 + 2 * MARGIN;
        let width = grid_w.max(title_w).max(KEY_WIDTH + 200);
        let key_y = top + rows as u32 * cell_h + 4;
        let height = key_y + 10 + 4 + LINE + MARGIN;
        PreviewLayout {
            size: (width, height),
            panel: (PANEL_WIDTH, ph),
            origins,
            key: (MARGIN + 96, key_y, KEY_WIDTH, 10),
        }
    }
}

/// The viridis colour map (dark purple 0, teal 0.5, yellow 1; lightness
/// rises with the value, so it reads in greyscale too), clamped to [0, 1].
pub fn viridis(v: f32) -> Rgb<u8> {
    const STOPS: [[f32; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let x = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) } * 4.0;
    let i = (x.floor() as usize).min(3);
    let t = x - i as f32;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    Rgb([0, 1, 2].map(|c| (a[c] + t * (b[c] - a[c])).round() as u8))
}

/// Renders the preview of `conf` predicted on `photo` (any size; shown
/// scaled to the panel), titled `title`: see the module docs and
/// [`PreviewLayout`]. Each bin's panel samples the confidence at the bin's
/// centre angle, bilinear between grid nodes.
pub fn confidence_preview(conf: &ConfidenceImage, photo: &RgbImage, title: &str) -> RgbImage {
    let layout = PreviewLayout::of(conf, title.chars().count());
    let (pw, ph) = layout.panel;
    let mut img = RgbImage::from_pixel(layout.size.0, layout.size.1, BACKGROUND);
    draw_text(&mut img, i64::from(MARGIN), i64::from(MARGIN), title, TEXT);
    draw_text(
        &mut img,
        i64::from(MARGIN),
        i64::from(MARGIN + LINE),
        "predicted confidence of MVS success, per triangulation angle",
        TEXT,
    );
    let label = |img: &mut RgbImage, (x, y): (u32, u32), s: &str| {
        draw_text(img, i64::from(x), i64::from(y - LINE), s, TEXT);
    };
    let thumb = resize(photo, pw, ph, FilterType::Triangle);
    overlay(
        &mut img,
        &thumb,
        i64::from(layout.origins[0].0),
        i64::from(layout.origins[0].1),
    );
    label(
        &mut img,
        layout.origins[0],
        &format!("photo {}x{}", photo.width(), photo.height()),
    );
    let (sx, sy) = (
        f64::from(conf.width()) / f64::from(pw),
        f64::from(conf.height()) / f64::from(ph),
    );
    let bins = conf.bins();
    let (gw, gh) = conf.grid_size();
    for (i, &(x0, y0)) in layout.origins[1..].iter().enumerate() {
        let centre = f64::from(bins.centre(i));
        for y in 0..ph {
            for x in 0..pw {
                let px = ((f64::from(x) + 0.5) * sx, (f64::from(y) + 0.5) * sy);
                img.put_pixel(x0 + x, y0 + y, viridis(conf.sample(px, centre)));
            }
        }
        let mean = (0..gh)
            .flat_map(|j| (0..gw).map(move |k| (k, j)))
            .map(|(k, j)| f64::from(conf.node(k, j)[i]))
            .sum::<f64>()
            / (gw * gh) as f64;
        let (lo, hi) = (bins.edges()[i], bins.edges()[i + 1]);
        label(
            &mut img,
            (x0, y0),
            &format!("{lo}-{hi} deg, mean {mean:.2}"),
        );
    }
    let (kx, ky, kw, kh) = layout.key;
    draw_text(
        &mut img,
        i64::from(MARGIN),
        i64::from(ky + 1),
        "confidence",
        TEXT,
    );
    for x in 0..kw {
        let c = viridis(x as f32 / (kw - 1) as f32);
        for y in 0..kh {
            img.put_pixel(kx + x, ky + y, c);
        }
    }
    let below = i64::from(ky + kh + 4);
    draw_text(&mut img, i64::from(kx), below, "0", TEXT);
    let mid = i64::from(kx + kw / 2) - text_width("0.5") / 2;
    draw_text(&mut img, mid, below, "0.5", TEXT);
    draw_text(
        &mut img,
        i64::from(kx + kw) - text_width("1"),
        below,
        "1",
        TEXT,
    );
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::AngleBins;

    fn luma(c: Rgb<u8>) -> f32 {
        0.299 * f32::from(c[0]) + 0.587 * f32::from(c[1]) + 0.114 * f32::from(c[2])
    }

    #[test]
    fn viridis_brightens_from_0_to_1_and_clamps() {
        let l: Vec<f32> = (0..=20).map(|i| luma(viridis(i as f32 / 20.0))).collect();
        assert!(l.windows(2).all(|w| w[0] < w[1]), "{l:?}");
        assert_eq!(viridis(-1.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(f32::NAN), viridis(0.0));
    }

    /// Left half confident at small angles, right half at large ones.
    fn split_confidence() -> ConfidenceImage {
        let bins = AngleBins::paper();
        let mut c = ConfidenceImage::zeros(320, 240, 8, bins).unwrap();
        let (gw, _) = c.grid_size();
        let b = c.bins().len();
        for (k, v) in c.values_mut().iter_mut().enumerate() {
            let (node, bin) = (k / b, k % b);
            let left = node % gw < gw / 2;
            *v = if left == (bin < b / 2) { 0.9 } else { 0.1 };
        }
        c
    }

    #[test]
    fn preview_is_readable_and_shows_each_bin_where_it_is_confident() {
        let conf = split_confidence();
        let photo = RgbImage::from_pixel(320, 240, Rgb([200, 30, 30]));
        let title = "site/img_0001.png: mean 0.50";
        let img = confidence_preview(&conf, &photo, title);
        let layout = PreviewLayout::of(&conf, title.len());
        assert_eq!(img.dimensions(), layout.size);
        // Ten panels of 240 x 180 in two rows of five.
        assert_eq!(layout.panel, (240, 180));
        assert_eq!(layout.origins.len(), 10);
        assert!(
            img.width() >= 5 * 240 && img.height() >= 2 * 180,
            "{:?}",
            img.dimensions()
        );
        // The photo panel shows the photo.
        let (px, py) = layout.origins[0];
        assert_eq!(*img.get_pixel(px + 120, py + 90), Rgb([200, 30, 30]));
        // Bin 0: the left half bright, the right half dark; the last bin the reverse.
        let at = |panel: usize, fx: u32| {
            let (x, y) = layout.origins[panel];
            luma(*img.get_pixel(x + fx, y + 90))
        };
        assert!(
            at(1, 30) > at(1, 210) + 100.0,
            "{} {}",
            at(1, 30),
            at(1, 210)
        );
        assert!(
            at(9, 210) > at(9, 30) + 100.0,
            "{} {}",
            at(9, 210),
            at(9, 30)
        );
        assert_eq!(
            *img.get_pixel(layout.origins[1].0 + 30, layout.origins[1].1 + 90),
            viridis(0.9)
        );
        // The key runs from viridis(0) to viridis(1).
        let (kx, ky, kw, _) = layout.key;
        assert_eq!(*img.get_pixel(kx, ky), viridis(0.0));
        assert_eq!(*img.get_pixel(kx + kw - 1, ky), viridis(1.0));
    }

    #[test]
    fn long_titles_widen_the_preview_and_tall_photos_keep_their_shape() {
        let conf =
            ConfidenceImage::zeros(100, 400, 8, AngleBins::uniform(2, 30.0).unwrap()).unwrap();
        let layout = PreviewLayout::of(&conf, 300);
        assert!(layout.size.0 >= 300 * 8);
        // Three panels in one row, 240 wide and as tall as the photo's shape allows.
        assert_eq!(layout.origins.len(), 3);
        assert_eq!(layout.panel, (240, 480));
        assert!(layout.origins.iter().all(|o| o.1 == layout.origins[0].1));
    }
}
