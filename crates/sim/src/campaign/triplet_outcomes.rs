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
use rayon::prelude::*;
use serde::Serialize;
use vp_scene::colmap::DepthMap;
use vp_scene::{Aabb, Camera, Material};

use vp_scene::raycast::FACE_VISIBILITY_EPSILON;
use vp_scene::triangulation::{point_covariance, sigma_along};

use crate::render::Rendered;
use crate::virtual_mvs::{PixelStatus, PixelTruth};
use crate::world::Scene;

/// What came out of one reconstruction, counted over its views' pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct OutputStats {
    /// Pixels whose true surface point lies in the region counted (the
    /// ROI for flights, anywhere for training).
    pub pixels: usize,
    /// Of them, pixels with any depth.
    pub output: usize,
    /// Of them, pixels whose depth is within `eval.depth_tolerance_m` of the
    /// true depth (the paper's 24 cm rule).
    pub measured: usize,
}

impl OutputStats {
    /// Share of the pixels measured within the tolerance (0 without pixels).
    pub fn measured_share(&self) -> f64 {
        self.measured as f64 / self.pixels.max(1) as f64
    }
}

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
/// Resolution of the 1 sigma figures, metres: 1 mm bins keep the report
/// small and its quantiles exact to 1 mm.
const MM: f64 = 0.001;
/// Lengths are binned up to 2 m; above, one overflow bin.
const N_MM_BINS: usize = 2000;

/// Non-negative lengths in 1 mm bins up to 2 m, the last bin open-ended.
#[derive(Debug, Clone, PartialEq)]
struct MmHistogram(Vec<u64>);

impl MmHistogram {
    fn new() -> Self {
        MmHistogram(vec![0; N_MM_BINS + 1])
    }

    fn add(&mut self, v: f64) {
        self.0[((v.max(0.0) / MM).floor() as usize).min(N_MM_BINS)] += 1;
    }

    fn merge(&mut self, other: &MmHistogram) {
        for (a, b) in self.0.iter_mut().zip(&other.0) {
            *a += b;
        }
    }

    /// The `q` quantile of the `n` values added: the centre of the bin
    /// holding the `ceil(q n)`-th smallest (at least the first); infinite
    /// above 2 m, None without values.
    fn quantile(&self, q: f64, n: u64) -> Option<f64> {
        if n == 0 {
            return None;
        }
        let rank = ((q * n as f64).ceil() as u64).clamp(1, n);
        let mut seen = 0;
        for (b, &c) in self.0.iter().enumerate() {
            seen += c;
            if seen >= rank {
                return Some(if b == N_MM_BINS {
                    f64::INFINITY
                } else {
                    (b as f64 + 0.5) * MM
                });
            }
        }
        None
    }
}

/// The share of a normal distribution within 1 sigma of its mean: the
/// paper's Fig. 6 draws the error bound that holds this share of the
/// measurements.
pub const ONE_SIGMA_SHARE: f64 = 0.683;

/// The paper's Fig. 6 for one strategy: the signed depth error
/// (reconstructed minus true depth, along the true camera's axis: positive
/// behind the surface) of the rock pixels in the ROI that have a depth,
/// binned, with two 1 sigma bounds: the paper's, the |error| that 68.3 %
/// of the pixels stay within (measured), and the first-order one that
/// labelgen predicts per pixel (`sigma_px` pixels of image noise through
/// the cameras that see the point).
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
    /// 1 sigma of the `with_sigma` pixels (for the median; not in
    /// `report.json`).
    #[serde(skip)]
    sigma_mm: MmHistogram,
    /// |error| of the pixels (for the measured bound; not in `report.json`).
    #[serde(skip)]
    abs_error_mm: MmHistogram,
}

impl Default for DepthErrorHistogram {
    fn default() -> Self {
        DepthErrorHistogram {
            pixels: 0,
            counts: vec![0; N_ERROR_BINS + 2],
            with_sigma: 0,
            within_sigma: 0,
            sigma_mm: MmHistogram::new(),
            abs_error_mm: MmHistogram::new(),
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
        self.abs_error_mm
            .add(if e.is_nan() { f64::INFINITY } else { e.abs() });
        if let Some(s) = sigma.filter(|s| s.is_finite() && *s > 0.0) {
            self.with_sigma += 1;
            self.within_sigma += u64::from(e.abs() <= s);
            self.sigma_mm.add(s);
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
        self.sigma_mm.merge(&other.sigma_mm);
        self.abs_error_mm.merge(&other.abs_error_mm);
    }

    /// Median predicted 1 sigma of the pixels that have one, metres: the
    /// centre of the 1 mm bin holding the middle pixel (the lower one of an
    /// even count); infinite when it lies above 2 m, None without such pixels.
    pub fn median_sigma_m(&self) -> Option<f64> {
        self.sigma_mm.quantile(0.5, self.with_sigma)
    }

    /// The paper's 1 sigma bound, metres: the |error| that
    /// [`ONE_SIGMA_SHARE`] of the pixels stay within (the centre of its
    /// 1 mm bin; infinite above 2 m, None without pixels).
    pub fn measured_bound_m(&self) -> Option<f64> {
        self.abs_error_mm.quantile(ONE_SIGMA_SHARE, self.pixels)
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

/// The rock pixels of one Grid reference (true camera `cams[0]`, its
/// sources `cams[1..]`) whose true surface (the render `truth`) lies in
/// `region` and that have a depth (`depth`, expressed in the true camera),
/// as a [`DepthErrorHistogram`]. A pixel's 1 sigma: `sigma_px` pixels
/// through the reference and the sources that see its true point (in
/// frame, not occluded), as for a triplet; none when no source sees it.
///
/// # Performance
/// Parallel over rows (rayon; the counts add up the same in any order):
/// up to one occlusion ray per source and rock pixel.
pub fn reference_rock_errors(
    scene: &Scene<'_>,
    truth: &Rendered,
    depth: &DepthMap,
    cams: &[Camera],
    region: &Aabb,
    sigma_px: f64,
) -> DepthErrorHistogram {
    let Some((reference, sources)) = cams.split_first() else {
        return DepthErrorHistogram::default();
    };
    let w = (depth.width as usize).max(1);
    // The error and 1 sigma of pixel i, if it is a rock pixel to count.
    let pixel = |i: usize| -> Option<(f64, Option<f64>)> {
        let (z, t) = (depth.data[i], *truth.depth.data.get(i)?);
        let face = *truth.face_id.get(i)?;
        if z <= 0.0
            || t <= 0.0
            || face == u32::MAX
            || scene.mesh.material(face as usize) != Some(Material::Rock)
        {
            return None;
        }
        let px = Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        let p = reference.unproject(&px, f64::from(t));
        if !region.contains(&p) {
            return None;
        }
        let (_, d) = reference.ray(&px);
        let mut n = scene.mesh.face_normal(face as usize);
        if n.dot(&d) > 0.0 {
            n = -n;
        }
        // Lifted off the face towards the reference, as the triplets' truth.
        let lifted = p + n * FACE_VISIBILITY_EPSILON;
        let seeing = sources.iter().filter(|c| {
            c.project_in_frame(&p).is_some() && !scene.caster.occluded(&c.center(), &lifted)
        });
        let cams: Vec<&Camera> = std::iter::once(reference).chain(seeing).collect();
        let sigma = (cams.len() >= 2)
            .then(|| point_covariance(cams, &p, sigma_px))
            .flatten()
            .map(|cov| sigma_along(&cov, &d) * d.dot(&reference.axis()));
        Some((f64::from(z) - f64::from(t), sigma))
    };
    (0..depth.data.len().div_ceil(w))
        .into_par_iter()
        .with_min_len(8)
        .fold(DepthErrorHistogram::default, |mut h, y| {
            for i in y * w..((y + 1) * w).min(depth.data.len()) {
                if let Some((e, sigma)) = pixel(i) {
                    h.add(e, sigma);
                }
            }
            h
        })
        .reduce(DepthErrorHistogram::default, |mut a, b| {
            a.merge(&b);
            a
        })
}

#[cfg(test)]
#[path = "triplet_outcomes_tests.rs"]
mod tests;
