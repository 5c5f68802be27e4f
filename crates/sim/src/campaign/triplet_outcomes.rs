//! The outcome of every flown triplet (issue 34, item 4): a strategy's
//! triplet success rate saturates (NP5x4 "succeeds" on every triplet), so
//! the report keeps each triplet's planned angle and its measured shares,
//! and, for the paper's Fig. 6, the signed depth error of the rock pixels
//! against the triplet's first-order 1 sigma bound.
//!
//! The statistics here (angle histogram, five-number summary, success at a
//! threshold, the error histogram) are the only arithmetic; the report
//! (`report/outcomes.rs`) formats them.

use nalgebra::Point2;
use serde::Serialize;
use vp_scene::colmap::DepthMap;
use vp_scene::{Aabb, Camera, Material};

use super::reconstruct::OutputStats;
use crate::virtual_mvs::{PixelStatus, PixelTruth};

/// One flown triplet of a strategy on a held-out site.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TripletOutcome {
    /// Strategy (`F5x4`, `NP5x4`, ...).
    pub strategy: String,
    /// The held-out site's seed.
    pub site: u64,
    /// Planning iteration, from 1.
    pub iteration: usize,
    /// The planner's triplet id within the iteration's plan.
    pub triplet: u32,
    /// Centre of the triangulation-angle bin the planner planned the
    /// triplet for, degrees (None: the plan does not say).
    pub planned_angle_deg: Option<f64>,
    /// Pixels of the three views whose true surface lies in the ROI, with
    /// a depth, and with a depth within the 24 cm rule.
    pub stats: OutputStats,
    /// Whether the triplet counted as producing 3D output (Table 1's
    /// triplet success).
    pub success: bool,
}

impl TripletOutcome {
    /// Share of the ROI pixels with any depth (0 without ROI pixels).
    pub fn depth_share(&self) -> f64 {
        self.stats.output as f64 / self.stats.pixels.max(1) as f64
    }

    /// Share of the ROI pixels within the 24 cm rule (0 without ROI pixels).
    pub fn within_share(&self) -> f64 {
        self.stats.measured_share()
    }
}

/// Width of the planned-angle histogram's bins, degrees.
pub const ANGLE_BIN_DEG: f64 = 5.0;

/// Counts of `angles` per [`ANGLE_BIN_DEG`] bin from 0: bin `b` holds
/// `[5 b, 5 b + 5)`; the last of `n_bins` bins also holds everything above.
/// Negative or non-finite angles are not counted.
pub fn angle_histogram(angles: impl IntoIterator<Item = f64>, n_bins: usize) -> Vec<u64> {
    let mut counts = vec![0u64; n_bins];
    if n_bins == 0 {
        return counts;
    }
    for a in angles {
        if !(a.is_finite() && a >= 0.0) {
            continue;
        }
        let b = ((a / ANGLE_BIN_DEG).floor() as usize).min(n_bins - 1);
        counts[b] += 1;
    }
    counts
}

/// The `q` quantile (0..=1) of ascending `sorted` values, interpolated
/// linearly between the closest ranks (the usual "type 7" rule: the
/// median of 1, 2, 3, 4 is 2.5). NaN for no values.
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let h = (sorted.len() - 1) as f64 * q.clamp(0.0, 1.0);
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// Minimum, 25 %, median, 75 % and maximum of `values` (None for none;
/// NaN values are left out).
pub fn five_numbers(values: &[f64]) -> Option<[f64; 5]> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some([0.0, 0.25, 0.5, 0.75, 1.0].map(|q| quantile(&v, q)))
}

/// The success thresholds of the report: a triplet succeeds at threshold
/// `t` when more than 0 of its ROI pixels (t = 0) or at least the share
/// `t` of them lie within the 24 cm rule.
pub const SUCCESS_THRESHOLDS: [f64; 4] = [0.0, 0.01, 0.10, 0.25];

/// Whether `o` succeeds at `threshold` (see [`SUCCESS_THRESHOLDS`]).
pub fn succeeds_at(o: &TripletOutcome, threshold: f64) -> bool {
    if threshold <= 0.0 {
        o.stats.measured > 0
    } else {
        o.stats.measured > 0 && o.within_share() >= threshold
    }
}

/// Share of `outcomes` that succeed at `threshold` (NaN for none).
pub fn success_share<'a>(
    outcomes: impl IntoIterator<Item = &'a TripletOutcome>,
    threshold: f64,
) -> f64 {
    let (mut n, mut ok) = (0usize, 0usize);
    for o in outcomes {
        n += 1;
        ok += usize::from(succeeds_at(o, threshold));
    }
    if n == 0 {
        f64::NAN
    } else {
        ok as f64 / n as f64
    }
}

/// Width of the depth-error bins, metres.
pub const ERROR_BIN_M: f64 = 0.02;
/// The error bins span `[-ERROR_RANGE_M, ERROR_RANGE_M)`; an overflow bin
/// on either side holds the rest.
pub const ERROR_RANGE_M: f64 = 0.5;
/// Bins inside the range.
pub const N_ERROR_BINS: usize = 50;
/// Resolution of the median 1 sigma, metres (a histogram of 1 mm bins
/// keeps the report small and the median exact to it).
const SIGMA_BIN_M: f64 = 0.001;
/// 1 sigma is binned up to 2 m; above, one overflow bin.
const N_SIGMA_BINS: usize = 2000;

/// The paper's Fig. 6 for one strategy: the signed depth error
/// (reconstructed minus true depth, along the true camera's axis: positive
/// behind the surface) of the rock pixels in the ROI that have a depth,
/// binned, with the pixels' first-order 1 sigma (`sigma_px` pixels of
/// image noise through the triplet's three cameras, as labelgen's bound).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DepthErrorHistogram {
    /// Pixels binned.
    pub pixels: u64,
    /// `N_ERROR_BINS + 2` counts: below `-ERROR_RANGE_M`, the bins of
    /// `ERROR_BIN_M` from `-ERROR_RANGE_M` up, at or above `ERROR_RANGE_M`.
    pub counts: Vec<u64>,
    /// Of `pixels`, those all three cameras see (they have a 1 sigma; a
    /// point one camera of the triplet misses has none).
    pub with_sigma: u64,
    /// Of `with_sigma`, those whose |error| is at most their 1 sigma.
    pub within_sigma: u64,
    /// 1 sigma of the `with_sigma` pixels in 1 mm bins, the last one
    /// open-ended (for the median; not in `report.json`).
    #[serde(skip)]
    sigma_counts: Vec<u64>,
}

impl Default for DepthErrorHistogram {
    fn default() -> Self {
        DepthErrorHistogram {
            pixels: 0,
            counts: vec![0; N_ERROR_BINS + 2],
            with_sigma: 0,
            within_sigma: 0,
            sigma_counts: vec![0; N_SIGMA_BINS + 1],
        }
    }
}

impl DepthErrorHistogram {
    /// The bin of a signed error `e`, metres (see [`Self::counts`]).
    pub fn bin_of(e: f64) -> usize {
        if e.is_nan() || e < -ERROR_RANGE_M {
            return 0;
        }
        if e >= ERROR_RANGE_M {
            return N_ERROR_BINS + 1;
        }
        1 + (((e + ERROR_RANGE_M) / ERROR_BIN_M).floor() as usize).min(N_ERROR_BINS - 1)
    }

    /// The range of bin `b`, metres (infinite ends for the overflow bins).
    pub fn bin_range(b: usize) -> (f64, f64) {
        match b {
            0 => (f64::NEG_INFINITY, -ERROR_RANGE_M),
            b if b > N_ERROR_BINS => (ERROR_RANGE_M, f64::INFINITY),
            b => {
                let lo = -ERROR_RANGE_M + (b - 1) as f64 * ERROR_BIN_M;
                (lo, lo + ERROR_BIN_M)
            }
        }
    }

    /// Adds a pixel with error `e` and its 1 sigma (None: no sigma).
    pub fn add(&mut self, e: f64, sigma: Option<f64>) {
        self.pixels += 1;
        self.counts[Self::bin_of(e)] += 1;
        if let Some(s) = sigma.filter(|s| s.is_finite() && *s > 0.0) {
            self.with_sigma += 1;
            self.within_sigma += u64::from(e.abs() <= s);
            let b = ((s / SIGMA_BIN_M).floor() as usize).min(N_SIGMA_BINS);
            self.sigma_counts[b] += 1;
        }
    }

    /// Adds `other`'s pixels.
    pub fn merge(&mut self, other: &DepthErrorHistogram) {
        self.pixels += other.pixels;
        self.with_sigma += other.with_sigma;
        self.within_sigma += other.within_sigma;
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        for (a, b) in self.sigma_counts.iter_mut().zip(&other.sigma_counts) {
            *a += b;
        }
    }

    /// Median 1 sigma of the pixels that have one, metres: the centre of
    /// the 1 mm bin holding the middle pixel (the lower one of an even
    /// count); infinite when it lies above 2 m, None without such pixels.
    pub fn median_sigma_m(&self) -> Option<f64> {
        if self.with_sigma == 0 {
            return None;
        }
        let middle = self.with_sigma.div_ceil(2);
        let mut seen = 0;
        for (b, &c) in self.sigma_counts.iter().enumerate() {
            seen += c;
            if seen >= middle {
                return Some(if b == N_SIGMA_BINS {
                    f64::INFINITY
                } else {
                    (b as f64 + 0.5) * SIGMA_BIN_M
                });
            }
        }
        None
    }

    /// Share of the pixels with a 1 sigma whose error is within it (NaN
    /// without such pixels).
    pub fn within_sigma_share(&self) -> f64 {
        if self.with_sigma == 0 {
            f64::NAN
        } else {
            self.within_sigma as f64 / self.with_sigma as f64
        }
    }

    /// Share of the pixels whose |error| is within `tol` metres, counted
    /// from whole bins (so `tol` should be a multiple of
    /// [`ERROR_BIN_M`]; NaN without pixels).
    pub fn share_within_bins(&self, tol: f64) -> f64 {
        if self.pixels == 0 {
            return f64::NAN;
        }
        let inside: u64 = (1..=N_ERROR_BINS)
            .filter(|&b| {
                let (lo, hi) = Self::bin_range(b);
                lo >= -tol - 1e-9 && hi <= tol + 1e-9
            })
            .map(|b| self.counts[b])
            .sum();
        inside as f64 / self.pixels as f64
    }
}

/// Whether pixel `i` of `cam` (row-major), whose true surface lies at
/// `true_depth`, is counted for `region` (None: every pixel).
pub(super) fn in_region(cam: &Camera, i: usize, true_depth: f32, region: Option<&Aabb>) -> bool {
    let Some(r) = region else {
        return true;
    };
    let w = cam.intrinsics.width as usize;
    let px = Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
    r.contains(&cam.unproject(&px, f64::from(true_depth)))
}

/// The rock pixels of a triplet's views (true cameras `cams`, depths
/// `depth` expressed in them, the renderer's `truth`) whose true surface
/// lies in `region` and that have a depth, as a [`DepthErrorHistogram`].
pub fn rock_errors(
    cams: &[Camera; 3],
    depth: &[DepthMap; 3],
    truth: &[Vec<PixelTruth>; 3],
    region: Option<&Aabb>,
) -> DepthErrorHistogram {
    let mut h = DepthErrorHistogram::default();
    for v in 0..3 {
        for (i, (t, &z)) in truth[v].iter().zip(&depth[v].data).enumerate() {
            if t.material != Some(Material::Rock) || t.status == PixelStatus::NoSurface || z <= 0.0
            {
                continue;
            }
            if !in_region(&cams[v], i, t.true_depth, region) {
                continue;
            }
            let sigma = (t.sigma_depth > 0.0).then_some(f64::from(t.sigma_depth));
            h.add(f64::from(z) - f64::from(t.true_depth), sigma);
        }
    }
    h
}

#[cfg(test)]
#[path = "triplet_outcomes_tests.rs"]
mod tests;
