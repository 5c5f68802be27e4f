//! What a user's SfM has instead of the truth: where a feature detector
//! fires on the rendered images, and the depth range COLMAP derives from
//! the sparse points an image sees.
//!
//! The detector is FAST-9 (a pixel is a corner when 9 contiguous pixels of
//! the 16 on a radius-3 circle are all brighter, or all darker, than it by
//! more than a threshold) with OpenCV's default threshold of 10 grey
//! levels, on the rendered 8-bit image. It fires on texture and contrast:
//! a flat, untextured surface under the renderer's sensor noise (2 grey
//! levels) gives no corners, so SfM has no points there, as a real SfM
//! would not. The threshold is the library default, not fitted to any
//! figure of the campaign.

use nalgebra::Point2;
use vp_scene::raster::RgbImage;

/// FAST's intensity threshold, 8-bit grey levels (OpenCV's
/// `FastFeatureDetector` default).
pub const FAST_THRESHOLD: i16 = 10;
/// FAST-9: contiguous circle pixels that must all be brighter or darker.
const FAST_ARC: usize = 9;
/// The 16 pixels of the radius-3 Bresenham circle, in order around it.
const CIRCLE: [(i32, i32); 16] = [
    (0, -3),
    (1, -3),
    (2, -2),
    (3, -1),
    (3, 0),
    (3, 1),
    (2, 2),
    (1, 3),
    (0, 3),
    (-1, 3),
    (-2, 2),
    (-3, 1),
    (-3, 0),
    (-3, -1),
    (-2, -2),
    (-1, -3),
];

/// COLMAP's depth-range percentiles (`colmap/mvs/model.cc`,
/// `Model::ComputeDepthRanges`: `kMinPercentile`, `kMaxPercentile`).
const COLMAP_MIN_PERCENTILE: f64 = 0.01;
const COLMAP_MAX_PERCENTILE: f64 = 0.99;
/// COLMAP's stretch of the range (`kStretchRatio`): near end times 0.75,
/// far end times 1.25.
const COLMAP_STRETCH: f64 = 0.25;

/// Where FAST-9 fires on one image, grown by one pixel: a surface point is
/// a feature of the image when a corner lies within a pixel of where it
/// projects (detectors localise to about a pixel).
#[derive(Debug, Clone, PartialEq)]
pub struct FeatureMask {
    width: u32,
    height: u32,
    near: Vec<bool>,
    corners: usize,
}

/// 8-bit luma (Rec. 601 weights) of every pixel.
fn grey(img: &RgbImage) -> Vec<i16> {
    img.pixels()
        .map(|p| {
            let [r, g, b] = p.0;
            ((299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b) + 500) / 1000) as i16
        })
        .collect()
}

/// Whether `flags` (16 around the circle) hold `FAST_ARC` contiguous trues,
/// wrapping around.
fn has_arc(flags: &[bool; 16]) -> bool {
    let mut run = 0;
    for i in 0..16 + FAST_ARC {
        if flags[i % 16] {
            run += 1;
            if run >= FAST_ARC {
                return true;
            }
        } else {
            run = 0;
        }
    }
    false
}

impl FeatureMask {
    /// Runs FAST-9 on `img` (pixels closer than 3 to the border are never
    /// corners: the circle does not fit).
    pub fn detect(img: &RgbImage) -> Self {
        let (w, h) = (img.width() as i32, img.height() as i32);
        let g = grey(img);
        let at = |x: i32, y: i32| g[(y * w + x) as usize];
        let mut corner = vec![false; g.len()];
        let mut corners = 0;
        for y in 3..h - 3 {
            for x in 3..w - 3 {
                let c = at(x, y);
                let (mut bright, mut dark) = ([false; 16], [false; 16]);
                for (k, (dx, dy)) in CIRCLE.iter().enumerate() {
                    let v = at(x + dx, y + dy);
                    bright[k] = v > c + FAST_THRESHOLD;
                    dark[k] = v < c - FAST_THRESHOLD;
                }
                if has_arc(&bright) || has_arc(&dark) {
                    corner[(y * w + x) as usize] = true;
                    corners += 1;
                }
            }
        }
        let mut near = vec![false; g.len()];
        for y in 0..h {
            for x in 0..w {
                if !corner[(y * w + x) as usize] {
                    continue;
                }
                for ny in (y - 1).max(0)..=(y + 1).min(h - 1) {
                    for nx in (x - 1).max(0)..=(x + 1).min(w - 1) {
                        near[(ny * w + nx) as usize] = true;
                    }
                }
            }
        }
        FeatureMask {
            width: img.width(),
            height: img.height(),
            near,
            corners,
        }
    }

    /// Whether a corner lies within a pixel of image point `px`.
    pub fn fires_near(&self, px: &Point2<f64>) -> bool {
        if !(px.x >= 0.0 && px.y >= 0.0) {
            return false;
        }
        let (x, y) = (px.x as u32, px.y as u32);
        x < self.width && y < self.height && self.near[(y * self.width + x) as usize]
    }

    /// Number of corner pixels found.
    pub fn corners(&self) -> usize {
        self.corners
    }
}

/// The depth range COLMAP gives an image from the depths of the sparse
/// points it sees (`Model::ComputeDepthRanges` in `colmap/mvs/model.cc`):
/// the positive depths sorted, the near end at index `n * 0.01` and the far
/// end at `n * 0.99` (floored), then near times 0.75 and far times 1.25.
/// `None` without a positive depth (COLMAP marks the range invalid).
pub fn colmap_depth_range(mut depths: Vec<f64>) -> Option<(f64, f64)> {
    depths.retain(|&d| d > 0.0);
    if depths.is_empty() {
        return None;
    }
    depths.sort_by(f64::total_cmp);
    let n = depths.len() as f64;
    let lo = depths[(n * COLMAP_MIN_PERCENTILE) as usize];
    let hi = depths[(n * COLMAP_MAX_PERCENTILE) as usize];
    Some((lo * (1.0 - COLMAP_STRETCH), hi * (1.0 + COLMAP_STRETCH)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgb;

    /// Left half flat grey with the renderer's sensor noise (sigma 2),
    /// right half random 3-pixel blocks between 60 and 200 grey levels.
    fn half_flat_half_textured() -> RgbImage {
        let mut img = RgbImage::new(64, 32);
        for (x, y, p) in img.enumerate_pixels_mut() {
            let n = 2.0 * crate::noise::gaussian(7, i64::from(x), i64::from(y), 0);
            let block = crate::noise::unit(crate::noise::hash3(
                9,
                i64::from(x / 3),
                i64::from(y / 3),
                0,
            ));
            let base = if x < 32 { 128.0 } else { 60.0 + 140.0 * block };
            let v = (base + n).round().clamp(0.0, 255.0) as u8;
            *p = Rgb([v, v, v]);
        }
        img
    }

    #[test]
    fn fast_fires_on_texture_and_not_on_a_flat_noisy_surface() {
        let m = FeatureMask::detect(&half_flat_half_textured());
        let mut flat = 0;
        let mut textured = 0;
        for y in 0..32 {
            for x in 0..64 {
                if m.fires_near(&Point2::new(f64::from(x) + 0.5, f64::from(y) + 0.5)) {
                    if x < 28 {
                        flat += 1;
                    } else if x >= 36 {
                        textured += 1;
                    }
                }
            }
        }
        assert_eq!(flat, 0, "corners on the flat half");
        assert!(
            textured > 100,
            "{textured} pixels near corners on the checker"
        );
        assert!(!m.fires_near(&Point2::new(-1.0, 3.0)));
        assert!(!m.fires_near(&Point2::new(64.5, 3.0)));
    }

    #[test]
    fn depth_range_is_colmaps_percentiles_stretched() {
        // 1..=200: index 2 (value 3) and index 198 (value 199).
        let d: Vec<f64> = (1..=200).map(f64::from).collect();
        let (lo, hi) = colmap_depth_range(d).unwrap();
        assert!((lo - 3.0 * 0.75).abs() < 1e-12, "{lo}");
        assert!((hi - 199.0 * 1.25).abs() < 1e-12, "{hi}");
        // Few points: the extremes.
        let (lo, hi) = colmap_depth_range(vec![20.0, 10.0, -1.0, 30.0]).unwrap();
        assert!((lo - 7.5).abs() < 1e-12 && (hi - 37.5).abs() < 1e-12);
        assert!(colmap_depth_range(vec![0.0, -2.0]).is_none());
    }
}
