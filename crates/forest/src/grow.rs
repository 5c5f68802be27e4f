//! Depth-first growth of one tree into flat arrays, over any
//! [`SampleSource`]: the training set's Lab images in memory
//! ([`crate::TrainingSet`]) or a patch store read chunk by chunk
//! ([`crate::patch_store`]). Both give the same bytes: the same samples,
//! random draws and node ids; only where a patch's bytes come from differs.

use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::dataset::TrainingSet;
use crate::error::{ForestError, Result};
use crate::params::TrainParams;
use crate::patch::{gather_columns, gather_rows, SplitTest, PATCH_LEN};
use crate::split::{best_split, NodeData};
use crate::train::{mix, TreeStats};
use crate::tree::{Node, Tree};

/// Below this many response evaluations per node the tests run on one thread.
const PARALLEL_WORK: usize = 1 << 18;

/// Where a tree's samples and their patches come from. Sample ids are
/// whatever the source numbers them by; the ids the tree draws from are
/// sorted, and a node's ids stay sorted (the partition is stable).
pub(crate) trait SampleSource {
    /// Whether sample `i` is positive.
    fn positive(&self, i: u32) -> bool;
    /// Sample `i`'s triangulation angle in degrees.
    fn angle(&self, i: u32) -> f32;
    /// Called before a node at `range` of the tree's id array (holding
    /// `ids`) searches a split; every later call until the next `enter`
    /// concerns this node or, after its partition, its descendants.
    fn enter(&mut self, range: (usize, usize), ids: &[u32]) -> Result<()>;
    /// Gathers the patches of `ids` (in order, repeats allowed) as
    /// [`gather_columns`] does, or only `positions` as [`gather_rows`] does.
    fn gather(&mut self, ids: &[u32], positions: Option<&[usize]>, out: &mut Vec<u8>)
        -> Result<()>;
    /// Appends the response of `test` at each of `ids` (in order) to `out`.
    fn responses(&mut self, ids: &[u32], test: SplitTest, out: &mut Vec<i32>) -> Result<()>;
}

impl SampleSource for &TrainingSet {
    fn positive(&self, i: u32) -> bool {
        self.samples[i as usize].positive
    }

    fn angle(&self, i: u32) -> f32 {
        self.samples[i as usize].angle
    }

    fn enter(&mut self, _: (usize, usize), _: &[u32]) -> Result<()> {
        Ok(())
    }

    fn gather(
        &mut self,
        ids: &[u32],
        positions: Option<&[usize]>,
        out: &mut Vec<u8>,
    ) -> Result<()> {
        let at: Vec<_> = ids
            .iter()
            .map(|&i| {
                let s = &self.samples[i as usize];
                (&self.images[s.image as usize], s.base as usize)
            })
            .collect();
        match positions {
            None => gather_columns(&at, out),
            Some(p) => gather_rows(&at, p, out),
        }
        Ok(())
    }

    fn responses(&mut self, ids: &[u32], test: SplitTest, out: &mut Vec<i32>) -> Result<()> {
        out.extend(ids.iter().map(|&i| {
            let s = &self.samples[i as usize];
            test.response(&self.images[s.image as usize], s.base as usize)
        }));
        Ok(())
    }
}

/// Buffers reused across the nodes of one tree.
#[derive(Default)]
struct Work {
    columns: Vec<u8>,
    row_of: Vec<u16>,
    labels: Vec<u8>,
    responses: Vec<i32>,
    scratch: Vec<u32>,
}

/// A node waiting to be grown: id, sample range in the tree's index array, depth.
struct Pending {
    id: usize,
    start: usize,
    end: usize,
    depth: usize,
}

/// Grows one tree on a bootstrap sample of `selected` (sorted ids of
/// `source`), every random choice seeded by `seed` and the node ids.
pub(crate) fn grow_tree<S: SampleSource>(
    source: &mut S,
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
        let split = if p.depth < params.max_depth && p.end - p.start >= params.min_samples_split {
            source.enter((p.start, p.end), &idx[p.start..p.end])?;
            find_split(
                source,
                &idx[p.start..p.end],
                params,
                weights,
                mix(seed, p.id as u64),
                &mut work,
            )?
        } else {
            None
        };
        let mid = match split {
            Some((test, threshold)) => Some(
                partition(source, &mut idx[p.start..p.end], test, threshold, &mut work)? + p.start,
            ),
            None => None,
        };
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
                add_leaf(&idx[p.start..p.end], source, params, &mut counts);
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
fn add_leaf<S: SampleSource>(idx: &[u32], source: &S, params: &TrainParams, counts: &mut Vec<u32>) {
    let at = counts.len();
    counts.resize(at + 2 + 2 * params.bins.len(), 0);
    let c = &mut counts[at..];
    for &i in idx {
        let class = usize::from(!source.positive(i));
        c[class] += 1;
        if let Some(b) = params.bins.bin_of(source.angle(i)) {
            c[2 + 2 * b + class] += 1;
        }
    }
}

/// Draws the node's evaluation samples (per class: half each, the rest to
/// the other class when one runs short), gathers their patches, draws the
/// tests and returns the best split, if any.
fn find_split<S: SampleSource>(
    source: &mut S,
    idx: &[u32],
    params: &TrainParams,
    weights: [f64; 2],
    seed: u64,
    work: &mut Work,
) -> Result<Option<(SplitTest, i16)>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n_pos = idx.iter().filter(|&&i| source.positive(i)).count();
    let n = [idx.len() - n_pos, n_pos];
    if n[0] == 0 || n[1] == 0 {
        return Ok(None);
    }
    let m = params.n_node_samples;
    let mut take = [n[0].min(m / 2), n[1].min(m / 2)];
    take[0] = n[0].min(m - take[1]);
    take[1] = n[1].min(m - take[0]);
    // Positions of the drawn samples within idx, in idx order.
    let mut chosen: Vec<usize> = Vec::with_capacity(take[0] + take[1]);
    for (class, &k) in take.iter().enumerate() {
        let members: Vec<usize> = (0..idx.len())
            .filter(|&j| usize::from(source.positive(idx[j])) == class)
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
    let ids: Vec<u32> = chosen.iter().map(|&j| idx[j]).collect();
    work.labels.clear();
    work.labels
        .extend(ids.iter().map(|&i| u8::from(source.positive(i))));
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
        source.gather(&ids, None, &mut work.columns)?;
        None
    } else {
        source.gather(&ids, Some(&positions), &mut work.columns)?;
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
    let parallel = ids.len() * tests.len() >= PARALLEL_WORK;
    Ok(best_split(&data, &tests, params.n_thresholds, parallel).map(|s| (s.test, s.threshold)))
}

/// Stable partition of `idx` by the split (left: response <= threshold);
/// returns the number of left samples.
fn partition<S: SampleSource>(
    source: &mut S,
    idx: &mut [u32],
    test: SplitTest,
    threshold: i16,
    work: &mut Work,
) -> Result<usize> {
    work.responses.clear();
    source.responses(idx, test, &mut work.responses)?;
    let right = &mut work.scratch;
    right.clear();
    let mut left = 0;
    for k in 0..idx.len() {
        let i = idx[k];
        if work.responses[k] <= i32::from(threshold) {
            idx[left] = i;
            left += 1;
        } else {
            right.push(i);
        }
    }
    idx[left..].copy_from_slice(right);
    Ok(left)
}
