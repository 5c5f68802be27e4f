//! Training parameters (vpctl's measured default size and the paper's
//! configuration) and the training summary kept in every model file.

use serde::{Deserialize, Serialize};
use vp_scene::raster::AngleBins;

use crate::error::{ForestError, Result};

/// Parameters of [`crate::train`]. [`TrainParams::paper`] is the paper's
/// configuration (Section 4): 20 trees of depth 20, 5000 tests and 100
/// thresholds per node evaluated on 1000 samples, nodes with fewer than 50
/// samples not split, about 4 million patches per class, 9 angle bins of
/// 5 deg over [0, 45). The default differs only in size, 10 trees of depth
/// 16, chosen by measured held-out accuracy (see [`TrainParams::default`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainParams {
    /// Number of trees.
    pub n_trees: usize,
    /// Maximum depth; the root has depth 0, so a tree has at most
    /// 2^max_depth leaves.
    pub max_depth: usize,
    /// Nodes with fewer (bagged) samples become leaves.
    pub min_samples_split: usize,
    /// Random split tests drawn per node.
    pub n_tests: usize,
    /// Thresholds tried per test (all distinct responses when there are fewer).
    pub n_thresholds: usize,
    /// Samples a node draws (per class, half each when both have enough) to
    /// score its tests; the chosen split then partitions all its samples.
    pub n_node_samples: usize,
    /// At most this many training samples of each class are drawn from the
    /// training set (the paper's "about 4 million patches per class").
    /// Without `balance_classes`, up to twice as many are drawn uniformly
    /// over both classes instead, so the class ratio and with it the
    /// calibration of the confidences hold.
    pub samples_per_class: usize,
    /// Each tree trains on a bootstrap sample (with replacement) of this
    /// fraction of the drawn samples.
    pub bag_fraction: f64,
    /// Weigh the classes so both count equally in splits and leaf
    /// confidences, whatever their numbers.
    pub balance_classes: bool,
    /// Triangulation-angle bins of the leaves; the last edge is gamma_max.
    pub bins: AngleBins,
    /// Pseudo-count k of the leaf confidence
    /// `(pos + k p) / (pos + neg + k)`: an empty bin reads the leaf's
    /// overall ratio p, a bin with many samples its own ratio.
    pub pseudo_count: f64,
}

impl Default for TrainParams {
    /// The paper's configuration at 10 trees of depth 16: the smallest size
    /// within 1 point of 20x20's held-out accuracy and within 0.01 of its
    /// Brier skill over the angle-only baseline, in the leave-one-site-out
    /// evaluation of eight simulated sites (`vpctl sim evaluate`,
    /// docs/campaign-findings.md: 20x20 75.9 % / +0.047, 10x16 75.8 % /
    /// +0.042, 6x16 75.7 % / +0.032). Half the trees and a sixteenth of the
    /// leaves per tree: training and prediction cost about half.
    fn default() -> Self {
        TrainParams {
            n_trees: 10,
            max_depth: 16,
            ..Self::paper()
        }
    }
}

/// A named set of training parameters: `vpctl train --preset`,
/// `vpctl forest defaults --preset`, Python `default_params(preset)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Preset {
    /// vpctl's default: the paper's parameters at the measured size (10x16).
    #[default]
    Default,
    /// The paper's configuration (20 trees of depth 20).
    Paper,
}

impl std::str::FromStr for Preset {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "default" => Ok(Preset::Default),
            "paper" => Ok(Preset::Paper),
            _ => Err(format!(
                "unknown forest preset {s:?}: expected \"default\" or \"paper\""
            )),
        }
    }
}

impl TrainParams {
    /// The parameters of a preset.
    pub fn preset(p: Preset) -> Self {
        match p {
            Preset::Default => Self::default(),
            Preset::Paper => Self::paper(),
        }
    }

    /// The paper's configuration (Mostegel et al. 2016, Section 4).
    pub fn paper() -> Self {
        TrainParams {
            n_trees: 20,
            max_depth: 20,
            min_samples_split: 50,
            n_tests: 5000,
            n_thresholds: 100,
            n_node_samples: 1000,
            samples_per_class: 4_000_000,
            bag_fraction: 1.0,
            balance_classes: true,
            bins: AngleBins::paper(),
            pseudo_count: 2.0,
        }
    }
}

/// Deepest tree vpctl trains or loads; far beyond the paper's 20.
pub(crate) const MAX_DEPTH_LIMIT: usize = 40;

/// `vpctl forest train --params` (the whole file) and a campaign's
/// `[training.forest]`; missing keys take [`TrainParams::default`].
impl vp_scene::config_file::ConfigSection for TrainParams {
    type Error = ForestError;

    fn check(&self, place: &str) -> Result<()> {
        self.validate().map_err(|e| match e {
            ForestError::InvalidParams(m) => ForestError::InvalidParams(format!("{place}: {m}")),
            other => other,
        })
    }
}

impl TrainParams {
    /// Checks every parameter, naming the first one out of range.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(ForestError::InvalidParams(what.to_string()));
        if self.n_trees == 0 || self.n_trees > 10_000 {
            return bad("n_trees must be in 1..=10000");
        }
        if self.max_depth > MAX_DEPTH_LIMIT {
            return bad("max_depth must be at most 40");
        }
        if self.min_samples_split < 2 {
            return bad("min_samples_split must be at least 2");
        }
        if self.n_tests == 0 || self.n_thresholds == 0 {
            return bad("n_tests and n_thresholds must be positive");
        }
        if self.n_node_samples < 2 {
            return bad("n_node_samples must be at least 2");
        }
        if self.samples_per_class == 0 {
            return bad("samples_per_class must be positive");
        }
        if !(self.bag_fraction > 0.0 && self.bag_fraction <= 10.0) {
            return bad("bag_fraction must be in (0, 10]");
        }
        if !(self.pseudo_count >= 0.0 && self.pseudo_count.is_finite()) {
            return bad("pseudo_count must be a finite non-negative number");
        }
        Ok(())
    }
}

/// What went into a model and what came out; stored in the model header
/// (`vpctl forest info` prints it). Deterministic: no times, no thread counts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingSummary {
    /// Seed the forest was trained with.
    pub seed: u64,
    /// RGB images in the training set.
    pub n_images: usize,
    /// Label images in the training set.
    pub n_label_images: usize,
    /// Positive samples available in the training set.
    pub n_positive_available: u64,
    /// Negative samples available in the training set.
    pub n_negative_available: u64,
    /// Positive samples drawn for training.
    pub n_positive: u64,
    /// Negative samples drawn for training.
    pub n_negative: u64,
    /// Drawn samples at or above gamma_max (they shape splits, not leaf bins).
    pub n_beyond_gamma_max: u64,
    /// Class weights [negative, positive] used in splits and confidences.
    pub class_weights: [f64; 2],
    /// Nodes over all trees.
    pub n_nodes: u64,
    /// Leaves over all trees.
    pub n_leaves: u64,
    /// Deepest leaf.
    pub max_depth_reached: usize,
    /// Mean depth of a leaf, weighted by the training samples reaching it.
    pub mean_sample_depth: f64,
    /// Mean over trees of the (class-weighted) accuracy of each tree on its
    /// own bagged samples: how well the leaves separate the training data.
    pub train_accuracy: f64,
}
