//! Training: class-balanced draw, bagging, and depth-first growth of each
//! tree into flat arrays.
//!
//! Determinism: every random choice comes from a ChaCha8 stream seeded by
//! (seed, tree) or (seed, tree, node id), and node ids follow the tree's own
//! sequential growth order. Threads only ever run whole trees or disjoint
//! chunks of one node's tests, whose results are reduced with a fixed
//! tie-break, so the model bytes do not depend on the number of threads.

use std::sync::atomic::{AtomicUsize, Ordering};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use vp_scene::hash::{finalise, GOLDEN_GAMMA};

use crate::dataset::TrainingSet;
use crate::error::{ForestError, Result};
use crate::grow::grow_tree;
use crate::params::{TrainParams, TrainingSummary};
use crate::tree::Tree;
use crate::Forest;

/// Mixes two numbers into a seed (the SplitMix64 finaliser of `a` and an
/// odd multiple of `b`'s SplitMix64 state).
pub(crate) fn mix(a: u64, b: u64) -> u64 {
    finalise(
        a ^ b
            .wrapping_add(GOLDEN_GAMMA)
            .wrapping_mul(0xd6e8_feb8_6659_fd93),
    )
}

/// Trains a forest on `set`. Same set, parameters and seed give the same
/// model, bit for bit, on any number of threads.
pub fn train(set: &TrainingSet, params: &TrainParams, seed: u64) -> Result<Forest> {
    train_with_progress(set, params, seed, &|_| {})
}

/// [`train`], calling `progress(trees_done)` as trees finish (from worker threads).
///
/// The same path as a distributed run: [`TrainingPlan::new`], then
/// [`TrainingPlan::train_tree`] for every index (here in parallel with
/// rayon), then [`assemble`].
pub fn train_with_progress(
    set: &TrainingSet,
    params: &TrainParams,
    seed: u64,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Forest> {
    let plan = TrainingPlan::new(set, params, seed)?;
    let done = AtomicUsize::new(0);
    let trees: Vec<TrainedTree> = (0..params.n_trees)
        .into_par_iter()
        .map(|t| {
            let tree = plan.train_tree(t);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            tree
        })
        .collect::<Result<_>>()?;
    assemble(trees)
}

/// Trains tree `index` of the forest [`train`] would make from `set`,
/// `params` and `seed`: the same tree, bit for bit, wherever it runs.
/// Trees from separate processes or machines become that forest with
/// [`assemble`]. Each call repeats the class draw (one pass over the
/// samples); to train several trees in one process, make one
/// [`TrainingPlan`] and call [`TrainingPlan::train_tree`].
pub fn train_tree(
    set: &TrainingSet,
    params: &TrainParams,
    seed: u64,
    index: usize,
) -> Result<TrainedTree> {
    TrainingPlan::new(set, params, seed)?.train_tree(index)
}

/// What every tree of one forest shares: the class-balanced draw of the
/// training samples and the class weights, fixed by the set, the
/// parameters and the seed.
pub struct TrainingPlan<'a> {
    set: &'a TrainingSet,
    selected: Vec<u32>,
    header: PlanHeader,
}

impl<'a> TrainingPlan<'a> {
    /// Validates `params`, draws the samples every tree bags from and
    /// fixes the class weights.
    pub fn new(set: &'a TrainingSet, params: &TrainParams, seed: u64) -> Result<Self> {
        params.validate()?;
        let mut classes: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
        for (i, s) in set.samples.iter().enumerate() {
            classes[usize::from(s.positive)].push(i as u32);
        }
        let available = [classes[0].len() as u64, classes[1].len() as u64];
        if available.contains(&0) {
            return Err(ForestError::InvalidInput(format!(
                "the training set needs both classes, it has {} positive and {} negative samples",
                available[1], available[0]
            )));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(mix(seed, 0x5e1e_c7ed));
        let mut draw = |v: &mut Vec<u32>, n: usize| {
            if v.len() > n {
                let mut keep = rand::seq::index::sample(&mut rng, v.len(), n).into_vec();
                keep.sort_unstable();
                *v = keep.into_iter().map(|i| v[i]).collect();
            }
        };
        if params.balance_classes {
            for class in &mut classes {
                draw(class, params.samples_per_class);
            }
        } else {
            // Uniform over both classes: the drawn set keeps the labels' class
            // ratio, so the leaves estimate calibrated probabilities (drawing
            // per class would pull them towards 0.5).
            let mut all: Vec<u32> = (0..set.samples.len() as u32).collect();
            draw(&mut all, 2 * params.samples_per_class);
            let (pos, neg): (Vec<u32>, Vec<u32>) = all
                .into_iter()
                .partition(|&i| set.samples[i as usize].positive);
            classes = [neg, pos];
        }
        let mut selected: Vec<u32> = classes[0].iter().chain(&classes[1]).copied().collect();
        selected.sort_unstable();
        let n_beyond_gamma_max = selected
            .iter()
            .filter(|&&i| params.bins.bin_of(set.samples[i as usize].angle).is_none())
            .count() as u64;
        let header = PlanHeader::new(
            params,
            seed,
            DrawnFrom {
                n_images: set.n_images(),
                n_label_images: set.n_label_images(),
                available,
                set_fingerprint: set.fingerprint(),
            },
            [classes[0].len() as u64, classes[1].len() as u64],
            n_beyond_gamma_max,
        );
        Ok(TrainingPlan {
            set,
            selected,
            header,
        })
    }

    /// The training set.
    pub(crate) fn set(&self) -> &TrainingSet {
        self.set
    }

    /// The drawn samples (sorted indices into the set's samples).
    pub(crate) fn selected(&self) -> &[u32] {
        &self.selected
    }

    /// What every tree of the plan shares.
    pub(crate) fn header(&self) -> &PlanHeader {
        &self.header
    }

    /// Grows tree `index` (0-based, below `params.n_trees`); its random
    /// choices are seeded by the forest seed and `index` only.
    pub fn train_tree(&self, index: usize) -> Result<TrainedTree> {
        check_index(&self.header.params, index)?;
        let (tree, stats) = grow_tree(
            &mut &*self.set,
            &self.selected,
            &self.header.params,
            self.header.class_weights,
            mix(self.header.seed, index as u64),
        )?;
        Ok(TrainedTree {
            index,
            tree,
            stats,
            plan: self.header.clone(),
        })
    }
}

/// Refuses a tree index outside the forest.
pub(crate) fn check_index(params: &TrainParams, index: usize) -> Result<()> {
    let n_trees = params.n_trees;
    if index >= n_trees {
        return Err(ForestError::InvalidInput(format!(
            "tree index {index}: the forest has {n_trees} trees (0..{n_trees})"
        )));
    }
    Ok(())
}

/// Assembles a forest from its trees, each trained by [`train_tree`] or
/// [`TrainingPlan::train_tree`] (here or elsewhere, in any order): the same
/// model as [`train`] with the same set, parameters and seed. Refuses trees
/// of different plans (parameters, seed, training set fingerprint), a
/// missing or repeated index, and a wrong number of trees.
pub fn assemble(mut trees: Vec<TrainedTree>) -> Result<Forest> {
    let Some(first) = trees.first() else {
        return Err(ForestError::InvalidInput(
            "no trees to assemble a forest from".into(),
        ));
    };
    let plan = first.plan.clone();
    if let Some(other) = trees.iter().find(|t| t.plan != plan) {
        return Err(ForestError::InvalidInput(format!(
            "tree {} comes from another training run than tree {} \
             (parameters, seed or training set differ)",
            other.index, first.index
        )));
    }
    trees.sort_by_key(|t| t.index);
    let n = plan.params.n_trees;
    for (expected, t) in trees.iter().enumerate() {
        if t.index != expected {
            let what = if t.index < expected {
                format!("tree {} is given twice", t.index)
            } else {
                format!("tree {expected} is missing")
            };
            return Err(ForestError::InvalidInput(format!(
                "{what} (a forest of {n} trees needs each of 0..{n} once)"
            )));
        }
    }
    if trees.len() != n {
        return Err(ForestError::InvalidInput(format!(
            "{} trees given, the forest has {n}",
            trees.len()
        )));
    }
    let grown: Vec<(Tree, TreeStats)> = trees.into_iter().map(|t| (t.tree, t.stats)).collect();
    let summary = summarise(&grown, &plan);
    let trees = grown.into_iter().map(|(t, _)| t).collect();
    Ok(Forest::from_parts(plan.params, summary, trees))
}

/// One trained tree of a forest, with what [`assemble`] needs to check
/// that trees belong together and to write the model's summary. Bytes:
/// [`TrainedTree::to_bytes`].
#[derive(Debug, Clone, PartialEq)]
pub struct TrainedTree {
    pub(crate) index: usize,
    pub(crate) tree: Tree,
    pub(crate) stats: TreeStats,
    pub(crate) plan: PlanHeader,
}

impl TrainedTree {
    /// Its index in the forest.
    pub fn index(&self) -> usize {
        self.index
    }

    /// The tree.
    pub fn tree(&self) -> &Tree {
        &self.tree
    }
}

/// The part of the training summary every tree of a forest shares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct PlanHeader {
    pub params: TrainParams,
    pub seed: u64,
    pub n_images: usize,
    pub n_label_images: usize,
    /// [negative, positive] samples in the set.
    pub available: [u64; 2],
    /// [negative, positive] samples drawn.
    pub drawn: [u64; 2],
    pub n_beyond_gamma_max: u64,
    pub class_weights: [f64; 2],
    /// [`TrainingSet::fingerprint`]: trees of different data do not mix.
    pub set_fingerprint: u64,
}

/// What the class-balanced draw was made from (a [`PlanHeader`]'s record
/// of the training set, kept by a patch store for the trees it trains).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct DrawnFrom {
    pub n_images: usize,
    pub n_label_images: usize,
    /// [negative, positive] samples in the set.
    pub available: [u64; 2],
    /// [`TrainingSet::fingerprint`].
    pub set_fingerprint: u64,
}

impl PlanHeader {
    /// The header of a plan that drew `drawn` [negative, positive] samples
    /// from `from`; the class weights follow from `drawn`.
    pub(crate) fn new(
        params: &TrainParams,
        seed: u64,
        from: DrawnFrom,
        drawn: [u64; 2],
        n_beyond_gamma_max: u64,
    ) -> Self {
        let counts = [drawn[0] as f64, drawn[1] as f64];
        let class_weights = if params.balance_classes {
            let total = counts[0] + counts[1];
            [total / (2.0 * counts[0]), total / (2.0 * counts[1])]
        } else {
            [1.0, 1.0]
        };
        PlanHeader {
            params: params.clone(),
            seed,
            n_images: from.n_images,
            n_label_images: from.n_label_images,
            available: from.available,
            drawn,
            n_beyond_gamma_max,
            class_weights,
            set_fingerprint: from.set_fingerprint,
        }
    }
}

/// Per-tree statistics for the summary.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TreeStats {
    pub max_depth: usize,
    pub sample_depth_sum: f64,
    pub n_samples: f64,
    pub correct_weight: f64,
    pub total_weight: f64,
}

fn summarise(grown: &[(Tree, TreeStats)], plan: &PlanHeader) -> TrainingSummary {
    let n = grown.len() as f64;
    TrainingSummary {
        seed: plan.seed,
        n_images: plan.n_images,
        n_label_images: plan.n_label_images,
        n_positive_available: plan.available[1],
        n_negative_available: plan.available[0],
        n_positive: plan.drawn[1],
        n_negative: plan.drawn[0],
        n_beyond_gamma_max: plan.n_beyond_gamma_max,
        class_weights: plan.class_weights,
        n_nodes: grown.iter().map(|(t, _)| t.nodes().len() as u64).sum(),
        n_leaves: grown.iter().map(|(t, _)| t.n_leaves() as u64).sum(),
        max_depth_reached: grown.iter().map(|(_, s)| s.max_depth).max().unwrap_or(0),
        mean_sample_depth: grown
            .iter()
            .map(|(_, s)| s.sample_depth_sum / s.n_samples)
            .sum::<f64>()
            / n,
        train_accuracy: grown
            .iter()
            .map(|(_, s)| s.correct_weight / s.total_weight)
            .sum::<f64>()
            / n,
    }
}
