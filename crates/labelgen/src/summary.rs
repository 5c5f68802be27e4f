//! A summary of a labelling run: how much was labelled, and positives and
//! negatives per triangulation-angle bin (what the forest will see).

use serde::{Deserialize, Serialize};
use vp_scene::raster::Label;

use crate::ReconLabels;

/// Width of the summary's angle bins, degrees (the forest's bins).
pub const SUMMARY_BIN_DEG: f32 = 5.0;
/// Angles at or above this fall in the summary's last, open bin.
pub const SUMMARY_MAX_DEG: f32 = 45.0;

/// Positives and negatives with a triangulation angle in `[lo_deg, hi_deg)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BinSummary {
    /// Lower edge, degrees.
    pub lo_deg: f32,
    /// Upper edge, degrees (180 for the open last bin).
    pub hi_deg: f32,
    /// Positive labels.
    pub positive: usize,
    /// Negative labels (voting and missing parts).
    pub negative: usize,
}

/// Totals over all views of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LabelSummary {
    /// Reconstructions labelled.
    pub reconstructions: usize,
    /// Pixels of all views.
    pub pixels: usize,
    /// Pixels with a usable measurement.
    pub measured: usize,
    /// Positive labels.
    pub positive: usize,
    /// Negative labels from voting (stage 2).
    pub negative_voted: usize,
    /// Negative labels for missing parts (stage 3).
    pub negative_missing: usize,
    /// Labelled pixels / all pixels.
    pub labelled_share: f64,
    /// Labelled measurements / measured pixels.
    pub labelled_share_of_measured: f64,
    /// Per angle bin.
    pub per_bin: Vec<BinSummary>,
}

impl LabelSummary {
    /// Sums up the labels of a run.
    pub fn of(labels: &[ReconLabels]) -> Self {
        let n_bins = (SUMMARY_MAX_DEG / SUMMARY_BIN_DEG) as usize + 1;
        let mut per_bin: Vec<BinSummary> = (0..n_bins)
            .map(|i| BinSummary {
                lo_deg: i as f32 * SUMMARY_BIN_DEG,
                hi_deg: if i + 1 == n_bins {
                    180.0
                } else {
                    (i + 1) as f32 * SUMMARY_BIN_DEG
                },
                positive: 0,
                negative: 0,
            })
            .collect();
        let mut s = LabelSummary {
            reconstructions: labels.len(),
            pixels: 0,
            measured: 0,
            positive: 0,
            negative_voted: 0,
            negative_missing: 0,
            labelled_share: 0.0,
            labelled_share_of_measured: 0.0,
            per_bin: Vec::new(),
        };
        for rl in labels {
            for (img, c) in rl.labels.iter().zip(&rl.counts) {
                s.pixels += img.width() as usize * img.height() as usize;
                s.measured += c.measured;
                s.positive += c.positive;
                s.negative_voted += c.negative_voted;
                s.negative_missing += c.negative_missing;
                for (_, _, label, angle) in img.labelled() {
                    let bin = ((angle / SUMMARY_BIN_DEG) as usize).min(n_bins - 1);
                    match label {
                        Label::Positive => per_bin[bin].positive += 1,
                        Label::Negative => per_bin[bin].negative += 1,
                        Label::Unlabelled => {}
                    }
                }
            }
        }
        s.per_bin = per_bin;
        s.with_shares()
    }

    /// The summary of a run labelled in parts (e.g. chunks of queries on
    /// separate workers): counts add up, shares are recomputed from the
    /// totals, so it equals [`LabelSummary::of`] over all labels at once.
    pub fn combine(parts: &[LabelSummary]) -> Self {
        let mut s = LabelSummary::of(&[]);
        for p in parts {
            s.reconstructions += p.reconstructions;
            s.pixels += p.pixels;
            s.measured += p.measured;
            s.positive += p.positive;
            s.negative_voted += p.negative_voted;
            s.negative_missing += p.negative_missing;
            for (a, b) in s.per_bin.iter_mut().zip(&p.per_bin) {
                a.positive += b.positive;
                a.negative += b.negative;
            }
        }
        s.with_shares()
    }

    fn with_shares(mut self) -> Self {
        let labelled = self.positive + self.negative_voted + self.negative_missing;
        self.labelled_share = ratio(labelled, self.pixels);
        self.labelled_share_of_measured = ratio(self.positive + self.negative_voted, self.measured);
        self
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}
