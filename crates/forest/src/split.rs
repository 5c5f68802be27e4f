//! Choosing a node's split: many random tests, each with many thresholds,
//! scored by Shannon information gain, thresholds found from a response
//! histogram (responses are small integers) instead of by sorting.

use rayon::prelude::*;
use vp_scene::hash::SplitMix64;

use crate::patch::{SplitTest, TestOp, RESPONSE_MIN, RESPONSE_RANGE};

/// The chosen split of a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Split {
    /// The test.
    pub test: SplitTest,
    /// Samples with response <= threshold go left.
    pub threshold: i16,
    /// Information gain in nats.
    pub gain: f64,
    /// Position of the test in the node's test list (the tie-breaker).
    index: usize,
}

impl Split {
    /// Higher gain wins; equal gains go to the earlier test, so the choice
    /// never depends on how the tests were split among threads.
    fn better(self, other: Split) -> Split {
        match other.gain.total_cmp(&self.gain) {
            std::cmp::Ordering::Greater => other,
            std::cmp::Ordering::Equal if other.index < self.index => other,
            _ => self,
        }
    }
}

/// Samples gathered for one node: patches position-major
/// ([`crate::patch::gather_columns`]), labels (1 positive, 0 negative) and
/// the weight of a sample of each class (index 0 negative, 1 positive).
pub struct NodeData<'a> {
    /// Rows of m bytes, one per gathered patch position: sample s at `row * m + s`.
    pub columns: &'a [u8],
    /// Row of each patch position when only some were gathered
    /// ([`crate::patch::gather_rows`]); `None` when row = position
    /// ([`crate::patch::gather_columns`]).
    pub row_of: Option<&'a [u16]>,
    /// m labels: 1 positive, 0 negative.
    pub labels: &'a [u8],
    /// Weight of one sample of each class: [negative, positive].
    pub weights: [f64; 2],
}

/// Per-node entropy tables: `class_term[c][k] = w_c k ln(w_c k)`.
struct Entropy {
    weights: [f64; 2],
    class_term: [Vec<f64>; 2],
    /// `w k ln(w k)` when both weights are equal, so that the sum term needs no logarithm either.
    equal_term: Option<Vec<f64>>,
}

fn xlnx(x: f64) -> f64 {
    if x > 0.0 {
        x * x.ln()
    } else {
        0.0
    }
}

impl Entropy {
    fn new(weights: [f64; 2], m: usize) -> Self {
        let table = |w: f64| (0..=m).map(|k| xlnx(w * k as f64)).collect::<Vec<_>>();
        let equal_term = (weights[0].to_bits() == weights[1].to_bits()).then(|| table(weights[0]));
        Entropy {
            weights,
            class_term: [table(weights[0]), table(weights[1])],
            equal_term,
        }
    }

    /// S * H(S) for a set with `neg` negatives and `pos` positives (weighted, nats).
    #[inline]
    fn weighted(&self, neg: u32, pos: u32) -> f64 {
        let (n, p) = (neg as usize, pos as usize);
        let total = match &self.equal_term {
            Some(t) => t[n + p],
            None => xlnx(self.weights[0] * neg as f64 + self.weights[1] * pos as f64),
        };
        total - self.class_term[0][n] - self.class_term[1][p]
    }
}

/// Histogram slots per class: a power of two above [`RESPONSE_RANGE`], so
/// that class and response pack into one index without a multiply.
const CLASS_SLOTS: usize = 1024;

/// Reusable buffers of one worker; `hist` is all zeros between tests.
struct Scratch {
    /// Negative counts at `r`, positive counts at `CLASS_SLOTS + r`.
    hist: Vec<u32>,
    /// Per sample: shifted response with the class in bit 10.
    index: Vec<u16>,
    cum: Vec<[u32; 2]>,
}

impl Scratch {
    fn new(m: usize) -> Self {
        Scratch {
            hist: vec![0; 2 * CLASS_SLOTS],
            index: vec![0; m],
            cum: Vec::with_capacity(RESPONSE_RANGE),
        }
    }
}

/// Fills the class histograms of one test; returns the shifted response range.
fn histogram(data: &NodeData, test: SplitTest, scratch: &mut Scratch) -> (usize, usize) {
    let (p1, p2) = test.patch_indices();
    let row = |p: usize| data.row_of.map_or(p, |rows| usize::from(rows[p]));
    let (i1, i2) = (row(p1), row(p2));
    // One loop per op so the combination is inlined, not matched per sample.
    match test.op {
        TestOp::Value => fill(data, i1, i2, scratch, |a, _| i32::from(a)),
        TestOp::Sum => fill(data, i1, i2, scratch, |a, b| i32::from(a) + i32::from(b)),
        TestOp::Difference => fill(data, i1, i2, scratch, |a, b| i32::from(a) - i32::from(b)),
        TestOp::AbsDifference => fill(data, i1, i2, scratch, |a, b| {
            (i32::from(a) - i32::from(b)).abs()
        }),
    }
}

/// Two passes: responses, class bits and range first (a loop the compiler
/// vectorises), then the bare histogram increments.
#[inline]
fn fill<F: Fn(u8, u8) -> i32>(
    data: &NodeData,
    i1: usize,
    i2: usize,
    scratch: &mut Scratch,
    f: F,
) -> (usize, usize) {
    let m = data.labels.len();
    let (row1, row2) = (
        &data.columns[i1 * m..(i1 + 1) * m],
        &data.columns[i2 * m..(i2 + 1) * m],
    );
    let index = &mut scratch.index[..m];
    let (mut lo, mut hi) = (u16::MAX, 0u16);
    for (((o, &v1), &v2), &label) in index.iter_mut().zip(row1).zip(row2).zip(data.labels) {
        let r = (f(v1, v2) - RESPONSE_MIN) as u16;
        lo = lo.min(r);
        hi = hi.max(r);
        *o = r | (u16::from(label) << 10);
    }
    let hist = &mut scratch.hist;
    for &i in index.iter() {
        hist[usize::from(i) & (2 * CLASS_SLOTS - 1)] += 1;
    }
    (usize::from(lo), usize::from(hi))
}

/// Best threshold of one test: (threshold, S_L H_L + S_R H_R), or `None`
/// when all responses are equal.
fn score_test(
    data: &NodeData,
    test: SplitTest,
    seed: u64,
    n_thresholds: usize,
    entropy: &Entropy,
    scratch: &mut Scratch,
) -> Option<(i16, f64)> {
    let (lo, hi) = histogram(data, test, scratch);
    let (neg_hist, pos_hist) = scratch.hist.split_at_mut(CLASS_SLOTS);
    if lo >= hi {
        if lo < RESPONSE_RANGE {
            neg_hist[lo] = 0;
            pos_hist[lo] = 0;
        }
        return None;
    }
    // cum[k] = class counts with shifted response <= lo + k; clears the histogram on the way.
    scratch.cum.clear();
    let mut acc = [0u32; 2];
    for r in lo..=hi {
        acc[0] += std::mem::take(&mut neg_hist[r]);
        acc[1] += std::mem::take(&mut pos_hist[r]);
        scratch.cum.push(acc);
    }
    let total = acc;
    let score = |k: usize| {
        let left = scratch.cum[k];
        entropy.weighted(left[0], left[1])
            + entropy.weighted(total[0] - left[0], total[1] - left[1])
    };
    // Candidate thresholds lo..hi-1 (shifted). Few: try all. Many: one per
    // stratum of equal width, jittered, so the range is covered evenly.
    let count = hi - lo;
    let mut best = (usize::MAX, f64::INFINITY);
    let mut consider = |k: usize| {
        let s = score(k);
        if s < best.1 {
            best = (k, s);
        }
    };
    if count <= n_thresholds {
        (0..count).for_each(&mut consider);
    } else {
        // SplitMix64 for the jitter: seeding a ChaCha stream per test would
        // cost more than scoring the test.
        let mut jitter = SplitMix64::new(seed);
        for i in 0..n_thresholds {
            let u = jitter.next_f64();
            let k = (((i as f64 + u) * count as f64 / n_thresholds as f64) as usize).min(count - 1);
            consider(k);
        }
    }
    let threshold = (lo + best.0) as i32 + RESPONSE_MIN;
    Some((threshold as i16, best.1))
}

/// Tests per parallel task: large enough to amortise the scratch buffers.
const CHUNK: usize = 64;

/// The split with the highest information gain among `tests` (each with a
/// threshold seed), or `None` if no test separates anything. Runs the tests
/// in parallel when `parallel`; the result is the same either way.
pub fn best_split(
    data: &NodeData,
    tests: &[(SplitTest, u64)],
    n_thresholds: usize,
    parallel: bool,
) -> Option<Split> {
    let m = data.labels.len();
    let entropy = Entropy::new(data.weights, m);
    let pos: usize = data.labels.iter().map(|&l| usize::from(l)).sum();
    let neg = (m - pos) as u32;
    let parent = entropy.weighted(neg, m as u32 - neg);
    let total_weight =
        data.weights[0] * f64::from(neg) + data.weights[1] * f64::from(m as u32 - neg);
    let run_chunk = |(c, chunk): (usize, &[(SplitTest, u64)])| {
        let mut scratch = Scratch::new(m);
        let mut best: Option<Split> = None;
        for (i, (test, seed)) in chunk.iter().enumerate() {
            if let Some((threshold, children)) =
                score_test(data, *test, *seed, n_thresholds, &entropy, &mut scratch)
            {
                let split = Split {
                    test: *test,
                    threshold,
                    gain: (parent - children) / total_weight,
                    index: c * CHUNK + i,
                };
                best = Some(best.map_or(split, |b| b.better(split)));
            }
        }
        best
    };
    let reduce = |a: Option<Split>, b: Option<Split>| match (a, b) {
        (Some(a), Some(b)) => Some(a.better(b)),
        (a, b) => a.or(b),
    };
    let best = if parallel {
        tests
            .par_chunks(CHUNK)
            .enumerate()
            .map(run_chunk)
            .reduce(|| None, reduce)
    } else {
        tests
            .chunks(CHUNK)
            .enumerate()
            .map(run_chunk)
            .fold(None, reduce)
    };
    // Rounding can leave a useless split a gain of +1e-16; demand a real one.
    best.filter(|s| s.gain > 1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::patch::{PATCH, PATCH_LEN, RADIUS};
    use rand::SeedableRng;

    /// Patches whose centre L value is the sample index; label = index >= 30.
    fn ramp(m: usize) -> (Vec<u8>, Vec<u8>) {
        let mut columns = vec![0u8; m * PATCH_LEN];
        let centre = RADIUS * PATCH + RADIUS;
        for s in 0..m {
            columns[centre * m + s] = s as u8;
        }
        let labels = (0..m).map(|s| u8::from(s >= 30)).collect();
        (columns, labels)
    }

    #[test]
    fn finds_the_separating_threshold_with_full_gain() {
        let (columns, labels) = ramp(100);
        let data = NodeData {
            columns: &columns,
            row_of: None,
            labels: &labels,
            weights: [1.0, 1.0],
        };
        let centre = SplitTest {
            channel: 0,
            op: TestOp::Value,
            offset1: (0, 0),
            offset2: (0, 0),
        };
        let corner = SplitTest {
            channel: 1,
            op: TestOp::Value,
            offset1: (3, 3),
            offset2: (0, 0),
        };
        let s = best_split(&data, &[(corner, 1), (centre, 2)], 100, false).unwrap();
        assert_eq!(s.test, centre);
        assert_eq!(s.threshold, 29);
        let h = -(0.3f64 * 0.3f64.ln() + 0.7 * 0.7f64.ln());
        assert!((s.gain - h).abs() < 1e-9, "gain {} vs entropy {h}", s.gain);
        // A constant test separates nothing.
        assert!(best_split(&data, &[(corner, 1)], 100, false).is_none());
    }

    #[test]
    fn weights_and_sampled_thresholds_keep_the_best_split_close() {
        let (columns, labels) = ramp(200);
        let data = NodeData {
            columns: &columns,
            row_of: None,
            labels: &labels,
            weights: [3.0, 0.5],
        };
        let centre = SplitTest {
            channel: 0,
            op: TestOp::Value,
            offset1: (0, 0),
            offset2: (0, 0),
        };
        // 199 candidate thresholds, 20 sampled: the best lies in the stratum holding 29.
        let s = best_split(&data, &[(centre, 7)], 20, false).unwrap();
        assert!(
            (19..=39).contains(&s.threshold),
            "threshold {}",
            s.threshold
        );
    }

    #[test]
    fn parallel_and_serial_search_agree() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let m = 300;
        let columns: Vec<u8> = (0..m * PATCH_LEN).map(|i| (i * 31 % 251) as u8).collect();
        let labels: Vec<u8> = (0..m).map(|i| u8::from(i % 3 == 0)).collect();
        let tests: Vec<_> = (0..500).map(|i| (SplitTest::random(&mut rng), i)).collect();
        let data = NodeData {
            columns: &columns,
            row_of: None,
            labels: &labels,
            weights: [1.0, 2.0],
        };
        let a = best_split(&data, &tests, 30, false);
        let b = best_split(&data, &tests, 30, true);
        assert_eq!(a, b);
    }
}
