//! Training: class-balanced draw, bagging, and depth-first growth of each
//! tree into flat arrays.
//!
//! Determinism: every random choice comes from a ChaCha8 stream seeded by
//! (seed, tree) or (seed, tree, node id), and node ids follow the tree's own
//! sequential growth order. Threads only ever run whole trees or disjoint
//! chunks of one node's tests, whose results are reduced with a fixed
//! tie-break, so the model bytes do not depend on the number of threads.

use std::sync::atomic::{AtomicUsize, Ordering};

use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use vp_scene::hash::{finalise, GOLDEN_GAMMA};

use crate::dataset::{Sample, TrainingSet};
use crate::error::{ForestError, Result};
use crate::params::{TrainParams, TrainingSummary};
use crate::patch::{gather_columns, gather_rows, SplitTest, PATCH_LEN};
use crate::split::{best_split, NodeData};
use crate::tree::{Node, Tree};
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

/// Below this many response evaluations per node the tests run on one thread.
const PARALLEL_WORK: usize = 1 << 18;

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
        let counts = [classes[0].len() as f64, classes[1].len() as f64];
        let class_weights = if params.balance_classes {
            let total = counts[0] + counts[1];
            [total / (2.0 * counts[0]), total / (2.0 * counts[1])]
        } else {
            [1.0, 1.0]
        };
        let mut selected: Vec<u32> = classes[0].iter().chain(&classes[1]).copied().collect();
        selected.sort_unstable();
        let n_beyond_gamma_max = selected
            .iter()
            .filter(|&&i| params.bins.bin_of(set.samples[i as usize].angle).is_none())
            .count() as u64;
        let header = PlanHeader {
            params: params.clone(),
            seed,
            n_images: set.n_images(),
            n_label_images: set.n_label_images(),
            available,
            drawn: [counts[0] as u64, counts[1] as u64],
            n_beyond_gamma_max,
            class_weights,
            set_fingerprint: set.fingerprint(),
        };
        Ok(TrainingPlan {
            set,
            selected,
            header,
        })
    }

    /// Grows tree `index` (0-based, below `params.n_trees`); its random
    /// choices are seeded by the forest seed and `index` only.
    pub fn train_tree(&self, index: usize) -> Result<TrainedTree> {
        let n_trees = self.header.params.n_trees;
        if index >= n_trees {
            return Err(ForestError::InvalidInput(format!(
                "tree index {index}: the forest has {n_trees} trees (0..{n_trees})"
            )));
        }
        let (tree, stats) = grow_tree(
            self.set,
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

/// Buffers reused across the nodes of one tree.
#[derive(Default)]
struct Work {
    columns: Vec<u8>,
    row_of: Vec<u16>,
    labels: Vec<u8>,
    scratch: Vec<u32>,
}

/// A node waiting to be grown: id, sample range in the tree's index array, depth.
struct Pending {
    id: usize,
    start: usize,
    end: usize,
    depth: usize,
}

fn grow_tree(
    set: &TrainingSet,
    selected: &[u32],
    params: &TrainParams,
    weights: [f64; 2],
    seed: u64,
) -> Result<(Tree, TreeStats)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n_bag = ((params.bag_fraction * selected.len() as f64).round() as usize).max(1);
    let mut idx: Vec<u32> = (0..n_bag)
        .map(|_| selected[rng.random_range(0..selected.len())])
        .collect();
    // Sorted indices keep a node's samples in image and row order: cache-friendly gathers.
    idx.sort_unstable();
    let n_bins = params.bins.len();
    let mut nodes = vec![placeholder()];
    let mut counts: Vec<u32> = Vec::new();
    let mut stats = TreeStats::default();
    let mut work = Work::default();
    let mut stack = vec![Pending {
        id: 0,
        start: 0,
        end: idx.len(),
        depth: 0,
    }];
    while let Some(p) = stack.pop() {
        let samples = &set.samples;
        let split = if p.depth < params.max_depth && p.end - p.start >= params.min_samples_split {
            find_split(
                set,
                &idx[p.start..p.end],
                params,
                weights,
                mix(seed, p.id as u64),
                &mut work,
            )
        } else {
            None
        };
        let mid = split.map(|(test, threshold)| {
            partition(
                set,
                &mut idx[p.start..p.end],
                test,
                threshold,
                &mut work.scratch,
            ) + p.start
        });
        match (split, mid) {
            (Some((test, threshold)), Some(mid)) if mid > p.start && mid < p.end => {
                let child = nodes.len();
                nodes[p.id] = Node {
                    test,
                    threshold,
                    child: child as u32,
                    is_leaf: false,
                };
                nodes.push(placeholder());
                nodes.push(placeholder());
                stack.push(Pending {
                    id: child + 1,
                    start: mid,
                    end: p.end,
                    depth: p.depth + 1,
                });
                stack.push(Pending {
                    id: child,
                    start: p.start,
                    end: mid,
                    depth: p.depth + 1,
                });
            }
            _ => {
                let leaf = counts.len() / (2 + 2 * n_bins);
                add_leaf(&idx[p.start..p.end], samples, params, &mut counts);
                nodes[p.id] = Node {
                    child: leaf as u32,
                    is_leaf: true,
                    ..placeholder()
                };
                let at = leaf * (2 + 2 * n_bins);
                let (pos, neg) = (f64::from(counts[at]), f64::from(counts[at + 1]));
                let n = pos + neg;
                stats.max_depth = stats.max_depth.max(p.depth);
                stats.sample_depth_sum += n * p.depth as f64;
                stats.n_samples += n;
                stats.correct_weight += (weights[1] * pos).max(weights[0] * neg);
                stats.total_weight += weights[1] * pos + weights[0] * neg;
            }
        }
    }
    let nodes = crate::tree::blocked_layout(&nodes);
    let tree =
        Tree::from_parts(nodes, counts, n_bins, weights, params.pseudo_count).map_err(|e| {
            ForestError::InvalidInput(format!("internal: grown tree inconsistent: {e}"))
        })?;
    Ok((tree, stats))
}

fn placeholder() -> Node {
    Node {
        test: SplitTest {
            channel: 0,
            op: crate::patch::TestOp::Value,
            offset1: (0, 0),
            offset2: (0, 0),
        },
        threshold: 0,
        child: 0,
        is_leaf: true,
    }
}

/// Appends a leaf's counts: totals, then (pos, neg) per angle bin. Samples
/// outside the bins (at or above gamma_max) count only in the totals.
fn add_leaf(idx: &[u32], samples: &[Sample], params: &TrainParams, counts: &mut Vec<u32>) {
    let at = counts.len();
    counts.resize(at + 2 + 2 * params.bins.len(), 0);
    let c = &mut counts[at..];
    for &i in idx {
        let s = &samples[i as usize];
        let class = usize::from(!s.positive);
        c[class] += 1;
        if let Some(b) = params.bins.bin_of(s.angle) {
            c[2 + 2 * b + class] += 1;
        }
    }
}

/// Draws the node's evaluation samples (per class: half each, the rest to
/// the other class when one runs short), gathers their patches, draws the
/// tests and returns the best split, if any.
fn find_split(
    set: &TrainingSet,
    idx: &[u32],
    params: &TrainParams,
    weights: [f64; 2],
    seed: u64,
    work: &mut Work,
) -> Option<(SplitTest, i16)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let positive = |i: u32| set.samples[i as usize].positive;
    let n_pos = idx.iter().filter(|&&i| positive(i)).count();
    let n = [idx.len() - n_pos, n_pos];
    if n[0] == 0 || n[1] == 0 {
        return None;
    }
    let m = params.n_node_samples;
    let mut take = [n[0].min(m / 2), n[1].min(m / 2)];
    take[0] = n[0].min(m - take[1]);
    take[1] = n[1].min(m - take[0]);
    // Positions of the drawn samples within idx, in idx order.
    let mut chosen: Vec<usize> = Vec::with_capacity(take[0] + take[1]);
    for (class, &k) in take.iter().enumerate() {
        let members: Vec<usize> = (0..idx.len())
            .filter(|&j| usize::from(positive(idx[j])) == class)
            .collect();
        if k == members.len() {
            chosen.extend(members);
        } else {
            chosen.extend(
                rand::seq::index::sample(&mut rng, members.len(), k)
                    .into_iter()
                    .map(|j| members[j]),
            );
        }
    }
    chosen.sort_unstable();
    // Each drawn sample stands for n_c / take_c samples of its class.
    let node_weights = [
        weights[0] * n[0] as f64 / take[0] as f64,
        weights[1] * n[1] as f64 / take[1] as f64,
    ];
    let chosen: Vec<&Sample> = chosen
        .iter()
        .map(|&j| &set.samples[idx[j] as usize])
        .collect();
    let at: Vec<_> = chosen
        .iter()
        .map(|s| (&set.images[s.image as usize], s.base as usize))
        .collect();
    work.labels.clear();
    work.labels
        .extend(chosen.iter().map(|s| u8::from(s.positive)));
    let tests: Vec<(SplitTest, u64)> = (0..params.n_tests)
        .map(|_| (SplitTest::random(&mut rng), rng.next_u64()))
        .collect();
    // Gather only the positions the tests read, unless that is most of them.
    let mut used = vec![false; PATCH_LEN];
    for (t, _) in &tests {
        let (p1, p2) = t.patch_indices();
        used[p1] = true;
        used[p2] = true;
    }
    let positions: Vec<usize> = (0..PATCH_LEN).filter(|&p| used[p]).collect();
    let row_of = if positions.len() * 2 > PATCH_LEN {
        gather_columns(&at, &mut work.columns);
        None
    } else {
        gather_rows(&at, &positions, &mut work.columns);
        work.row_of.clear();
        work.row_of.resize(PATCH_LEN, u16::MAX);
        for (r, &p) in positions.iter().enumerate() {
            work.row_of[p] = r as u16;
        }
        Some(work.row_of.as_slice())
    };
    let data = NodeData {
        columns: &work.columns,
        row_of,
        labels: &work.labels,
        weights: node_weights,
    };
    let parallel = chosen.len() * tests.len() >= PARALLEL_WORK;
    best_split(&data, &tests, params.n_thresholds, parallel).map(|s| (s.test, s.threshold))
}

/// Stable partition of `idx` by the split (left: response <= threshold);
/// returns the number of left samples.
fn partition(
    set: &TrainingSet,
    idx: &mut [u32],
    test: SplitTest,
    threshold: i16,
    right: &mut Vec<u32>,
) -> usize {
    right.clear();
    let mut left = 0;
    for k in 0..idx.len() {
        let i = idx[k];
        let s = &set.samples[i as usize];
        if test.response(&set.images[s.image as usize], s.base as usize) <= i32::from(threshold) {
            idx[left] = i;
            left += 1;
        } else {
            right.push(i);
        }
    }
    idx[left..].copy_from_slice(right);
    left
}
