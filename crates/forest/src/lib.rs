//! `vp-forest`: predicts, per pixel and per triangulation angle, how likely
//! a multi-view stereo algorithm succeeds, with a Semantic Texton Forest
//! whose leaves keep angle-binned counts (Mostegel et al., Sections 2.2 and 3.1).
//!
//! Entry points:
//! - [`TrainingSet::add_image`] + [`train`] (or [`train_with_progress`]):
//!   images and label images to a [`Forest`], with [`TrainParams`] (the paper's
//!   defaults) and a seed; same inputs and seed give the same model bytes on
//!   any number of threads.
//! - Distributed training: [`train_tree`] (or [`TrainingPlan::train_tree`])
//!   grows one tree by index, [`TrainedTree::to_bytes`] carries it to
//!   another process, and [`assemble`] makes the forest: the same model
//!   bytes as [`train`] with the same set, parameters and seed, wherever the
//!   trees were trained ([`train`] itself takes this path).
//! - Bounded-memory training: [`write_patch_store`] writes a set's drawn
//!   samples as chunked patches once; [`PatchStore::train_tree`] grows any
//!   tree from it chunk by chunk within a [`StoreBudget`], the same tree as
//!   [`train_tree`] on the set.
//! - [`load_label_dir`]: label images as `vpctl labelgen run` writes them,
//!   paired with their images (scaled for pyramid levels).
//! - [`Forest::predict_image`]: an RGB image to a b-channel
//!   [`ConfidenceImage`] on a grid (paper: step 8).
//! - [`Forest::save`] / [`Forest::load`]: versioned, checksummed model files
//!   ([`model_io`]).
//! - [`metrics`]: accuracy and sparsification (AUSC, relative and random),
//!   with [`Forest::score_labels`] to score held-out label images.
//!
//! The forest: each split test reads one CIE Lab channel at one or two
//! offsets in the 27x27 patch around the pixel (value, sum, difference or
//! absolute difference) against a threshold; splits maximise Shannon
//! information gain. Each leaf counts the positive and negative training
//! samples per angle bin (default 9 bins of 5 deg below gamma_max = 45 deg;
//! samples at or above gamma_max shape splits but enter no bin; the angle
//! never influences a split). A leaf's confidence in bin i is
//! `(pos_i + k p) / (pos_i + neg_i + k)` with class-weighted counts, p the
//! leaf's overall positive ratio (over all its samples, gamma_max or not) and k = [`TrainParams::pseudo_count`]
//! (default 2): an empty bin reads p. Prediction averages the trees.
#![warn(missing_docs, unreachable_pub)]
// A library tells its caller (returned warnings, reports, progress callbacks);
// only the CLI and the Python bindings print (docs/design.md).
#![deny(clippy::print_stderr, clippy::print_stdout)]

pub mod batch;
mod dataset;
pub mod error;
mod grow;
pub mod lab;
pub mod label_dir;
pub mod metrics;
pub mod model_io;
mod params;
pub mod patch;
pub mod patch_store;
mod predict;
pub mod split;
mod store_train;
pub mod synthetic;
mod train;
pub mod tree;

pub use batch::{predict_files, predict_files_with_progress, BatchOptions, Predicted};
pub use dataset::TrainingSet;
pub use error::{ForestError, Result};
pub use lab::LabPlanes;
pub use label_dir::{load_label_dir, LabelledImage};
pub use metrics::{accuracy, sparsification, Scored, Sparsification};
pub use params::{Preset, TrainParams, TrainingSummary};
pub use patch_store::{write_patch_store, Manifest, PatchStore};
pub use store_train::{StoreBudget, StoreReads};
pub use train::{assemble, train, train_tree, train_with_progress, TrainedTree, TrainingPlan};
pub use tree::Tree;
pub use vp_scene::raster::{AngleBins, ConfidenceImage, RgbImage};

/// A trained forest: parameters, training summary, trees.
#[derive(Debug, Clone, PartialEq)]
pub struct Forest {
    params: TrainParams,
    summary: TrainingSummary,
    trees: Vec<Tree>,
}

impl Forest {
    pub(crate) fn from_parts(
        params: TrainParams,
        summary: TrainingSummary,
        trees: Vec<Tree>,
    ) -> Self {
        Forest {
            params,
            summary,
            trees,
        }
    }

    /// The parameters it was trained with.
    pub fn params(&self) -> &TrainParams {
        &self.params
    }

    /// What it was trained on and how the trees came out.
    pub fn summary(&self) -> &TrainingSummary {
        &self.summary
    }

    /// The trees.
    pub fn trees(&self) -> &[Tree] {
        &self.trees
    }

    /// The angle bins of its confidences.
    pub fn bins(&self) -> &AngleBins {
        &self.params.bins
    }
}
