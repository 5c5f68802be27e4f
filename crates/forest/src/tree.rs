//! One tree as flat arrays: nodes, and per leaf the angle-binned counts with
//! the confidences derived from them.

use crate::lab::LabPlanes;
use crate::patch::SplitTest;

/// One node in a tree's flat node array. Children of a split are stored
/// next to each other, the left one first; a child always comes after its
/// parent, so every traversal ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Node {
    /// The test of a split node (unused in a leaf).
    pub test: SplitTest,
    /// Samples with response <= threshold go left.
    pub threshold: i16,
    /// Split: index of the left child (the right child is `child + 1`).
    /// Leaf: index of the leaf.
    pub child: u32,
    /// Whether this node is a leaf.
    pub is_leaf: bool,
}

/// The training counts that reached one leaf.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeafCounts<'a> {
    /// All positive samples, including those at or above gamma_max.
    pub positive: u32,
    /// All negative samples, including those at or above gamma_max.
    pub negative: u32,
    /// Per angle bin: (positive, negative), interleaved.
    pub per_bin: &'a [u32],
}

/// A trained tree.
#[derive(Debug, Clone, PartialEq)]
pub struct Tree {
    nodes: Vec<Node>,
    /// Per leaf: positive total, negative total, then (pos, neg) per bin.
    counts: Vec<u32>,
    /// Per leaf: b confidences, derived from `counts`.
    confidence: Vec<f32>,
    n_bins: usize,
}

/// Smoothed confidence per bin, as [`crate::Forest`] documents:
/// `(w+ pos + k p) / (w+ pos + w- neg + k)`, p the leaf's overall weighted
/// positive ratio, `weights` = [w-, w+].
pub(crate) fn leaf_confidence(counts: &LeafCounts, weights: [f64; 2], k: f64, out: &mut [f32]) {
    let wp = weights[1] * f64::from(counts.positive);
    let wn = weights[0] * f64::from(counts.negative);
    let p = if wp + wn > 0.0 { wp / (wp + wn) } else { 0.5 };
    for (o, pn) in out.iter_mut().zip(counts.per_bin.chunks_exact(2)) {
        let pos = weights[1] * f64::from(pn[0]);
        let neg = weights[0] * f64::from(pn[1]);
        let denominator = pos + neg + k;
        *o = if denominator > 0.0 {
            (pos + k * p) / denominator
        } else {
            p
        } as f32;
    }
}

/// Sibling pairs per block level in [`blocked_layout`]: blocks of at most
/// 2 + 4 + ... + 128 = 254 nodes, 4064 bytes compiled, one memory page.
const BLOCK_LEVELS: u32 = 7;

/// Reorders a tree so that every node is stored with its descendants down
/// to [`BLOCK_LEVELS`] levels: a block starts at a pair of siblings and
/// holds their descendants breadth first; the child pairs below its last
/// level start new blocks. A root-to-leaf walk of 20 levels then touches
/// about 3 pages and few cache lines instead of up to 20 scattered nodes,
/// which is what prediction waits on. Siblings stay adjacent and parents
/// come before children, so the result is a valid flat tree; leaf indices
/// are unchanged.
pub(crate) fn blocked_layout(nodes: &[Node]) -> Vec<Node> {
    use std::collections::VecDeque;
    let mut order: Vec<usize> = vec![0];
    // Pairs (left child index in `nodes`) that start a block, in block order.
    let mut blocks: VecDeque<usize> = VecDeque::new();
    if !nodes[0].is_leaf {
        blocks.push_back(nodes[0].child as usize);
    }
    let mut level: VecDeque<(usize, u32)> = VecDeque::new();
    while let Some(pair) = blocks.pop_front() {
        level.push_back((pair, 0));
        level.push_back((pair + 1, 0));
        while let Some((i, depth)) = level.pop_front() {
            order.push(i);
            let n = &nodes[i];
            if !n.is_leaf {
                let c = n.child as usize;
                if depth + 1 < BLOCK_LEVELS {
                    level.push_back((c, depth + 1));
                    level.push_back((c + 1, depth + 1));
                } else {
                    blocks.push_back(c);
                }
            }
        }
    }
    let mut new_index = vec![0u32; nodes.len()];
    for (new, &old) in order.iter().enumerate() {
        new_index[old] = new as u32;
    }
    order
        .iter()
        .map(|&old| {
            let n = nodes[old];
            if n.is_leaf {
                n
            } else {
                Node {
                    child: new_index[n.child as usize],
                    ..n
                }
            }
        })
        .collect()
}

impl Tree {
    /// Builds a tree from its parts, checking every index, and derives the
    /// leaf confidences. Errors describe the first inconsistency.
    pub(crate) fn from_parts(
        nodes: Vec<Node>,
        counts: Vec<u32>,
        n_bins: usize,
        weights: [f64; 2],
        pseudo_count: f64,
    ) -> Result<Tree, String> {
        let per_leaf = 2 + 2 * n_bins;
        if nodes.is_empty() {
            return Err("tree without nodes".into());
        }
        if n_bins == 0 || !counts.len().is_multiple_of(per_leaf) {
            return Err(format!(
                "{} leaf counts do not fill leaves of {per_leaf}",
                counts.len()
            ));
        }
        let n_leaves = counts.len() / per_leaf;
        for (i, n) in nodes.iter().enumerate() {
            let c = n.child as usize;
            if n.is_leaf && c >= n_leaves {
                return Err(format!("node {i}: leaf {c} of {n_leaves}"));
            }
            if !n.is_leaf && (c <= i || c + 1 >= nodes.len()) {
                return Err(format!(
                    "node {i}: children {c}, {} out of order or range",
                    c + 1
                ));
            }
            if !n.is_leaf && !n.test.is_valid() {
                return Err(format!("node {i}: invalid split test {:?}", n.test));
            }
        }
        // Every node but the root has exactly one parent: a true tree, so
        // depths are well defined and traversals bounded by them.
        let mut parents = vec![0u8; nodes.len()];
        for n in nodes.iter().filter(|n| !n.is_leaf) {
            for c in [n.child as usize, n.child as usize + 1] {
                parents[c] = parents[c].saturating_add(1);
            }
        }
        if let Some(i) = (1..nodes.len()).find(|&i| parents[i] != 1) {
            return Err(format!("node {i} has {} parents", parents[i]));
        }
        let mut tree = Tree {
            nodes,
            counts,
            confidence: vec![0.0; n_leaves * n_bins],
            n_bins,
        };
        for leaf in 0..n_leaves {
            let c = tree.leaf_counts(leaf);
            let mut out = vec![0.0; n_bins];
            leaf_confidence(&c, weights, pseudo_count, &mut out);
            tree.confidence[leaf * n_bins..(leaf + 1) * n_bins].copy_from_slice(&out);
        }
        Ok(tree)
    }

    /// The flat node array; node 0 is the root.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Number of leaves.
    pub fn n_leaves(&self) -> usize {
        self.counts.len() / (2 + 2 * self.n_bins)
    }

    /// Raw counts of leaf `leaf`, flat (see [`Tree::leaf_counts`]).
    pub(crate) fn raw_counts(&self) -> &[u32] {
        &self.counts
    }

    /// Training counts of leaf `leaf`.
    pub fn leaf_counts(&self, leaf: usize) -> LeafCounts<'_> {
        let per_leaf = 2 + 2 * self.n_bins;
        let c = &self.counts[leaf * per_leaf..(leaf + 1) * per_leaf];
        LeafCounts {
            positive: c[0],
            negative: c[1],
            per_bin: &c[2..],
        }
    }

    /// The b confidences of leaf `leaf`.
    pub fn leaf_confidence(&self, leaf: usize) -> &[f32] {
        &self.confidence[leaf * self.n_bins..(leaf + 1) * self.n_bins]
    }

    /// All leaf confidences, leaf-major.
    pub(crate) fn confidences(&self) -> &[f32] {
        &self.confidence
    }

    /// The leaf reached by the sample at `base` in `planes`.
    pub fn leaf_of(&self, planes: &LabPlanes, base: usize) -> usize {
        let mut i = 0;
        loop {
            let n = &self.nodes[i];
            if n.is_leaf {
                return n.child as usize;
            }
            let go_right = n.test.response(planes, base) > i32::from(n.threshold);
            i = n.child as usize + usize::from(go_right);
        }
    }

    /// Depth of every node (root 0), in node order.
    pub fn node_depths(&self) -> Vec<u32> {
        let mut depth = vec![0u32; self.nodes.len()];
        // Parents come before children, so one forward pass suffices.
        for (i, n) in self.nodes.iter().enumerate() {
            if !n.is_leaf {
                let c = n.child as usize;
                depth[c] = depth[i] + 1;
                depth[c + 1] = depth[i] + 1;
            }
        }
        depth
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patch::TestOp;

    fn test() -> SplitTest {
        SplitTest {
            channel: 0,
            op: TestOp::Value,
            offset1: (0, 0),
            offset2: (0, 0),
        }
    }

    #[test]
    fn empty_bins_fall_back_to_the_leaf_ratio() {
        let per_bin = [3, 1, 0, 0, 0, 4];
        let c = LeafCounts {
            positive: 3,
            negative: 5,
            per_bin: &per_bin,
        };
        let mut out = [0.0f32; 3];
        leaf_confidence(&c, [1.0, 1.0], 2.0, &mut out);
        let p = 3.0 / 8.0;
        assert!((out[0] - (3.0 + 2.0 * p) / 6.0).abs() < 1e-6);
        assert!((out[1] - p).abs() < 1e-6);
        assert!((out[2] - (2.0 * p) / 6.0).abs() < 1e-6);
    }

    /// Re-laying a tree out in blocks changes where nodes live, not where samples go.
    #[test]
    fn blocked_layout_keeps_every_decision() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        // A random, unbalanced tree grown depth-first (children appended in pairs).
        let mut nodes = vec![Node {
            test: test(),
            threshold: 0,
            child: 0,
            is_leaf: true,
        }];
        let mut open = vec![(0usize, 0u32)];
        let mut leaves = 0;
        while let Some((i, depth)) = open.pop() {
            if depth < 14 && rng.random_bool(0.8) {
                let c = nodes.len();
                let t = SplitTest::random(&mut rng);
                nodes[i] = Node {
                    test: t,
                    threshold: rng.random_range(0..300),
                    child: c as u32,
                    is_leaf: false,
                };
                nodes.push(nodes[0]);
                nodes.push(nodes[0]);
                open.push((c + 1, depth + 1));
                open.push((c, depth + 1));
            } else {
                nodes[i] = Node {
                    test: test(),
                    threshold: 0,
                    child: leaves,
                    is_leaf: true,
                };
                leaves += 1;
            }
        }
        let counts = vec![1; leaves as usize * 4];
        let plain = Tree::from_parts(nodes.clone(), counts.clone(), 1, [1.0, 1.0], 1.0).unwrap();
        let blocked = Tree::from_parts(blocked_layout(&nodes), counts, 1, [1.0, 1.0], 1.0).unwrap();
        assert!(nodes.len() > 500, "{} nodes", nodes.len());
        let img = vp_scene::raster::RgbImage::from_fn(40, 40, |_, _| {
            image::Rgb([rng.random(), rng.random(), rng.random()])
        });
        let planes = LabPlanes::from_rgb(&img);
        for y in 0..40 {
            for x in 0..40 {
                let base = planes.base(x, y);
                assert_eq!(plain.leaf_of(&planes, base), blocked.leaf_of(&planes, base));
            }
        }
    }

    #[test]
    fn inconsistent_trees_are_rejected() {
        let leaf = |i| Node {
            test: test(),
            threshold: 0,
            child: i,
            is_leaf: true,
        };
        let split = |c| Node {
            test: test(),
            threshold: 0,
            child: c,
            is_leaf: false,
        };
        let counts = vec![1, 0, 1, 0, 0, 1, 0, 0];
        assert!(Tree::from_parts(
            vec![split(1), leaf(0), leaf(1)],
            counts.clone(),
            1,
            [1.0, 1.0],
            1.0
        )
        .is_ok());
        // A child pointing back to its parent would loop forever.
        assert!(Tree::from_parts(
            vec![split(0), leaf(0), leaf(1)],
            counts.clone(),
            1,
            [1.0, 1.0],
            1.0
        )
        .is_err());
        assert!(Tree::from_parts(
            vec![split(1), leaf(0), leaf(2)],
            counts.clone(),
            1,
            [1.0, 1.0],
            1.0
        )
        .is_err());
        assert!(Tree::from_parts(
            vec![split(2), leaf(0), leaf(1)],
            counts.clone(),
            1,
            [1.0, 1.0],
            1.0
        )
        .is_err());
        assert!(Tree::from_parts(vec![], counts.clone(), 1, [1.0, 1.0], 1.0).is_err());
        // Two parents sharing children: not a tree.
        let shared = vec![split(1), split(3), split(3), leaf(0), leaf(1)];
        assert!(Tree::from_parts(shared, counts, 1, [1.0, 1.0], 1.0).is_err());
    }
}
