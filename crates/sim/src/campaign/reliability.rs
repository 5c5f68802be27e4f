//! Reliability diagrams of the confidence forest (issue 34, item 2): is a
//! pixel the forest gives 0.7 reconstructed about 70 % of the time?
//!
//! Accuracy and the Brier score summarise a forest in one number; the
//! planner reads its probabilities, so a reader needs to see where they are
//! too high or too low. Each held-out labelled pixel falls into one of ten
//! bins of predicted confidence (0-0.1, ..., 0.9-1); per bin the mean
//! predicted confidence is plotted against the observed success rate (the
//! share labelled positive, and the share truly positive by the renderer's
//! truth), with the pixel count. A calibrated forest lies on the diagonal.
//! The pixels are also split into three groups of the forest's angle bins
//! (e.g. 0-15, 15-30, 30-45 deg): the paper's mechanism lives in the angle,
//! and a forest can be calibrated overall and miscalibrated at wide angles.

use std::fmt::Write as _;

use image::Rgb;
use vp_scene::raster::{text_width, AngleBins, RgbImage};

use super::report::plot::{line, put, text, BLACK};

/// Bins of predicted confidence over [0, 1].
pub const CONF_BINS: usize = 10;
/// Groups of the forest's angle bins drawn as separate series.
pub const ANGLE_GROUPS: usize = 3;

/// Running sums of one (angle group, confidence bin) cell.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Cell {
    /// Pixels.
    pub n: u64,
    /// Sum of their predicted confidence.
    pub sum_confidence: f64,
    /// Labelled positive.
    pub positive: u64,
    /// Truly positive (the renderer's truth).
    pub truly: u64,
}

/// One forest's reliability diagram: cells per angle group and confidence bin.
#[derive(Debug, Clone, PartialEq)]
pub struct Reliability {
    /// The forest's size, trees x depth.
    pub forest: String,
    /// The angle groups' ranges, degrees.
    pub groups: Vec<(f32, f32)>,
    /// `cells[group][bin]`.
    pub cells: Vec<[Cell; CONF_BINS]>,
    /// Per angle bin of the forest, its group.
    group_of_bin: Vec<usize>,
}

/// The confidence bin of `c` (1.0 in the last bin).
pub fn conf_bin(c: f32) -> usize {
    ((c.clamp(0.0, 1.0) * CONF_BINS as f32) as usize).min(CONF_BINS - 1)
}

impl Reliability {
    /// Nothing counted yet, for a forest `forest` over `bins`: the bins are
    /// split into [`ANGLE_GROUPS`] consecutive groups of (nearly) equal count.
    pub fn new(forest: &str, bins: &AngleBins) -> Self {
        let n = bins.len();
        let g = ANGLE_GROUPS.min(n).max(1);
        let group_of_bin: Vec<usize> = (0..n).map(|b| b * g / n).collect();
        let edges = bins.edges();
        let groups = (0..g)
            .map(|k| {
                let first = group_of_bin.iter().position(|&x| x == k).unwrap_or(0);
                let last = group_of_bin.iter().rposition(|&x| x == k).unwrap_or(0);
                (edges[first], edges[last + 1])
            })
            .collect();
        Reliability {
            forest: forest.to_string(),
            groups,
            cells: vec![[Cell::default(); CONF_BINS]; g],
            group_of_bin,
        }
    }

    /// Counts one labelled pixel of angle bin `bin` scored `confidence`.
    pub fn add(&mut self, bin: usize, confidence: f32, positive: bool, truly: bool) {
        let Some(&g) = self.group_of_bin.get(bin) else {
            return;
        };
        let c = &mut self.cells[g][conf_bin(confidence)];
        c.n += 1;
        c.sum_confidence += f64::from(confidence);
        c.positive += u64::from(positive);
        c.truly += u64::from(truly);
    }

    /// Per confidence bin, the cells of every angle group together.
    pub fn pooled(&self) -> [Cell; CONF_BINS] {
        let mut out = [Cell::default(); CONF_BINS];
        for group in &self.cells {
            for (o, c) in out.iter_mut().zip(group) {
                o.n += c.n;
                o.sum_confidence += c.sum_confidence;
                o.positive += c.positive;
                o.truly += c.truly;
            }
        }
        out
    }

    /// The diagram's points of `cells`: (mean confidence, observed label
    /// success, observed true success, pixels) of each bin with pixels.
    pub fn points(cells: &[Cell; CONF_BINS]) -> Vec<(f64, f64, f64, u64)> {
        cells
            .iter()
            .filter(|c| c.n > 0)
            .map(|c| {
                let n = c.n as f64;
                (
                    c.sum_confidence / n,
                    c.positive as f64 / n,
                    c.truly as f64 / n,
                    c.n,
                )
            })
            .collect()
    }

    /// Expected calibration error against the labels: the pixel-weighted
    /// mean gap between mean confidence and observed success over the bins.
    pub fn ece(&self) -> f64 {
        let pooled = self.pooled();
        let total: u64 = pooled.iter().map(|c| c.n).sum();
        Self::points(&pooled)
            .iter()
            .map(|&(p, o, _, n)| n as f64 * (p - o).abs())
            .sum::<f64>()
            / total.max(1) as f64
    }

    /// PNG file name: `reliability_<matcher>_<forest>.png`.
    pub fn file_name(&self, matcher: &str) -> String {
        format!("reliability_{matcher}_{}.png", self.forest)
    }
}

/// `reliability.csv`: one line per forest, angle group and confidence bin
/// with pixels; the pixels of one forest add up to its labelled pixels.
pub fn csv(matcher: &str, diagrams: &[Reliability]) -> String {
    let mut s = String::from(
        "matcher,forest,angle_lo,angle_hi,conf_lo,conf_hi,pixels,mean_confidence,\
         label_success,truth_success\n",
    );
    for r in diagrams {
        for (&(lo, hi), cells) in r.groups.iter().zip(&r.cells) {
            for (b, c) in cells.iter().enumerate().filter(|(_, c)| c.n > 0) {
                let n = c.n as f64;
                let _ = writeln!(
                    s,
                    "{matcher},{},{lo},{hi},{:.1},{:.1},{},{:.4},{:.4},{:.4}",
                    r.forest,
                    b as f64 / CONF_BINS as f64,
                    (b + 1) as f64 / CONF_BINS as f64,
                    c.n,
                    c.sum_confidence / n,
                    c.positive as f64 / n,
                    c.truly as f64 / n,
                );
            }
        }
    }
    s
}

const W: u32 = 600;
const H: u32 = 420;
/// Plot area: left, top, right, bottom.
const AREA: (f64, f64, f64, f64) = (44.0, 30.0, 400.0, 386.0);
/// Height of the count bars at the most populated bin, pixels.
const BAR_MAX: f64 = 60.0;
const GROUP_COLOURS: [Rgb<u8>; 3] = [Rgb([40, 70, 220]), Rgb([30, 150, 60]), Rgb([220, 40, 40])];

/// A 5x5 square marker.
fn dot(img: &mut RgbImage, (x, y): (f64, f64), c: Rgb<u8>) {
    for dy in -2..=2 {
        for dx in -2..=2 {
            put(img, x as i64 + dx, y as i64 + dy, c);
        }
    }
}

/// Plot coordinates of (confidence, success).
fn to(p: f64, o: f64) -> (f64, f64) {
    let (x0, y1, x1, y0) = AREA;
    (
        x0 + (x1 - x0) * p.clamp(0.0, 1.0),
        y0 + (y1 - y0) * o.clamp(0.0, 1.0),
    )
}

/// The count bars of `pooled` (scaled to the most populated bin, whose
/// count is returned) and the axes' ticks and labels.
fn frame(img: &mut RgbImage, pooled: &[Cell; CONF_BINS]) -> u64 {
    let (x0, _, _, y0) = AREA;
    let max_n = pooled.iter().map(|c| c.n).max().unwrap_or(0).max(1);
    let bar = Rgb([225, 225, 225]);
    for (b, c) in pooled.iter().enumerate() {
        let h = BAR_MAX * c.n as f64 / max_n as f64;
        let (xa, xb) = (
            to(b as f64 / CONF_BINS as f64, 0.0).0 + 2.0,
            to((b + 1) as f64 / CONF_BINS as f64, 0.0).0 - 2.0,
        );
        for y in 0..h.round() as i64 {
            line(img, (xa, y0 - y as f64), (xb, y0 - y as f64), bar);
        }
    }
    for k in 0..=10 {
        let v = f64::from(k) / 10.0;
        let (x, _) = to(v, 0.0);
        let (_, y) = to(0.0, v);
        line(img, (x, y0), (x, y0 + 4.0), BLACK);
        line(img, (x0 - 4.0, y), (x0, y), BLACK);
        let l = match k {
            0 => "0",
            5 => ".5",
            10 => "1",
            _ => continue,
        };
        text(img, x as i64 - text_width(l) / 2, y0 as i64 + 8, l, BLACK);
        text(img, x0 as i64 - text_width(l) - 8, y as i64 - 4, l, BLACK);
    }
    max_n
}

/// The reliability diagram of `r` for `matcher`: mean predicted confidence
/// (x) against the share labelled positive (y) per confidence bin, pooled
/// over all angles (black) and per angle group (colours), the diagonal of a
/// calibrated forest (grey), and the pooled pixel count per bin as bars
/// along the bottom (tallest bar: the most populated bin, its count printed).
pub fn plot(matcher: &str, r: &Reliability) -> RgbImage {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let (x0, y1, x1, y0) = AREA;
    let grey = Rgb([200, 200, 200]);
    let pooled = r.pooled();
    let max_n = frame(&mut img, &pooled);
    line(&mut img, to(0.0, 0.0), to(1.0, 1.0), grey);
    line(&mut img, (x0, y0), (x1, y0), BLACK);
    line(&mut img, (x0, y0), (x0, y1), BLACK);
    let mut series: Vec<(String, Rgb<u8>, [Cell; CONF_BINS])> = r
        .groups
        .iter()
        .zip(&r.cells)
        .zip(GROUP_COLOURS.iter().cycle())
        .map(|((&(lo, hi), cells), &c)| (format!("{lo}-{hi} deg"), c, *cells))
        .collect();
    series.push(("all angles".into(), BLACK, pooled));
    for (i, (name, colour, cells)) in series.iter().enumerate() {
        let pts = Reliability::points(cells);
        for w in pts.windows(2) {
            line(&mut img, to(w[0].0, w[0].1), to(w[1].0, w[1].1), *colour);
        }
        for p in &pts {
            dot(&mut img, to(p.0, p.1), *colour);
        }
        let n: u64 = cells.iter().map(|c| c.n).sum();
        let ly = y1 as i64 + 14 * i as i64;
        text(&mut img, x1 as i64 + 12, ly, name, *colour);
        text(
            &mut img,
            x1 as i64 + 20,
            ly + 5 * 14,
            &format!("{n} px"),
            *colour,
        );
    }
    let total: u64 = pooled.iter().map(|c| c.n).sum();
    let title = format!(
        "{matcher} {}: reliability, {total} px, ECE {:.3}",
        r.forest,
        r.ece()
    );
    text(&mut img, 8, 8, &title, BLACK);
    let axis = "predicted confidence";
    text(
        &mut img,
        f64::midpoint(x0, x1) as i64 - text_width(axis) / 2,
        y0 as i64 + 22,
        axis,
        BLACK,
    );
    let notes = [
        "y: share labelled".to_string(),
        "positive".to_string(),
        "grey bars: px per".to_string(),
        format!("bin, max {max_n}"),
    ];
    for (i, n) in notes.iter().enumerate() {
        text(
            &mut img,
            x1 as i64 + 12,
            y1 as i64 + 14 * (10 + i as i64),
            n,
            BLACK,
        );
    }
    img
}

#[cfg(test)]
#[path = "reliability_tests.rs"]
mod tests;
