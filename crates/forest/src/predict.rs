//! Prediction: dense on a grid, or at given pixels.
//!
//! Trees are compiled per image stride into 16-byte nodes. Every split test
//! becomes "is v1 + v2' within [lo, lo + span]", where v2' is v2 or its
//! complement 255 - v2 (one XOR with 0xff, chosen per node): a difference
//! v1 - v2 is v1 + (255 - v2) - 255, an absolute difference |d| <= t is a
//! window 255 - t..=255 + t, a value v1 is v1 + v1. A leaf becomes a node
//! that points to itself with a window holding every response. A whole row
//! of grid points then walks a tree in lockstep for exactly the tree's
//! depth, without a branch per visit: the walks of different points are
//! independent, so the CPU keeps many node and pixel loads in flight
//! instead of waiting on each.
//!
//! # What limits it
//! A 16 Mpx image at step 8 is 250k points x 20 trees x up to 20 levels:
//! 78.6M visits on the bench fixture, about 6.5 cycles each. It is not
//! bound by instructions nor by the trees' size; its loads (about 7 and 3
//! stores per visit over the two passes) account for about 2.5 cycles, and
//! their latency most likely for the rest. Measured without
//! gains (issue 19, docs/performance.md): AVX2 gathers (slower than scalar
//! loads on this Zen 4), the arithmetic on AVX2 with 4x fewer instructions,
//! a forest of one repeated tree that stays in L2, leaf sums point-major,
//! 2D tiles or bands of rows walked tree by tree, walks of 16 points fused
//! into one pass, a step pass that also fetches the next node (both lose
//! the memory parallelism of the separate gather pass), and huge pages.
//! Unchecked indexing saved about 12%. Dropping finished walks at three
//! levels (`compacts`) cut the visits by 21% on the bench image, and the
//! instructions by 9% (a compacting step costs twice a plain one).

use rayon::prelude::*;
use vp_scene::raster::{ConfidenceImage, RgbImage};

use crate::error::{ForestError, Result};
use crate::lab::{self, LabPlanes};
use crate::patch::TestOp;
use crate::tree::Node;
use crate::Forest;

/// Pixels per parallel task of [`Forest::predict_pixels`].
const BATCH: usize = 512;

/// Grid rows per band of [`Forest::predict_image`]: at step 8, 121 image
/// rows and 26 of margin, a scratch of about 2 MB for a 4912-pixel-wide
/// image (two tasks' fit in this machine's L3, not in L2); 8 and 16 measured
/// the same within noise (docs/performance.md, "Stop 50").
const BAND: usize = 16;

/// A node compiled for one plane stride: go left iff
/// `(v1 + v2') - lo`, as an unsigned number, is at most `span`, where v2'
/// is v2, or 255 - v2 if the top bit of `child` is set.
#[derive(Debug, Clone, Copy, Default)]
struct CNode {
    off1: i32,
    off2: i32,
    /// Left child index (the right one follows), top bit: complement v2.
    child: u32,
    lo: i16,
    span: u16,
}

/// The complement flag in [`CNode::child`].
const COMPLEMENT: u32 = 1 << 31;

impl CNode {
    /// The child this node sends a sample with values `v1`, `v2` to.
    #[inline]
    fn next(&self, v1: u8, v2: u8) -> u32 {
        // 0xff if the complement flag is set, else 0: v2 ^ mask is v2 or 255 - v2.
        let mask = ((self.child as i32) >> 31) as u8;
        let sum = i32::from(v1) + i32::from(v2 ^ mask);
        let right = (sum - i32::from(self.lo)) as u32 > u32::from(self.span);
        (self.child & !COMPLEMENT) + u32::from(right)
    }

    /// The child this node sends the sample at `base` in `data` to.
    #[inline]
    fn next_at(&self, data: &[u8], base: usize) -> u32 {
        self.next(
            data[base.wrapping_add_signed(self.off1 as isize)],
            data[base.wrapping_add_signed(self.off2 as isize)],
        )
    }
}

/// The window of sums v1 + v2' (each 0..=255, so 0..=510) that go left.
fn window(lo: i32, hi: i32) -> (i16, u16) {
    // Sums are never below 0 nor above 510: clamp the window to that range.
    let (lo, hi) = (lo.max(-1), hi.min(600));
    if lo > hi {
        (1000, 0) // empty: every sum minus 1000 is negative, i.e. huge unsigned
    } else {
        (lo as i16, (hi - lo) as u16)
    }
}

fn compile_node(i: usize, n: &Node, (stride, plane_len): (usize, usize)) -> CNode {
    if n.is_leaf {
        let (lo, span) = window(i32::MIN, i32::MAX);
        return CNode {
            off1: 0,
            off2: 0,
            child: i as u32,
            lo,
            span,
        };
    }
    let (o1, o2) = n.test.offsets_in(stride, plane_len);
    let t = i32::from(n.threshold);
    let (off2, complement, (lo, span)) = match n.test.op {
        TestOp::Value => (o1, false, window(i32::MIN, 2 * t)),
        TestOp::Sum => (o2, false, window(i32::MIN, t)),
        TestOp::Difference => (o2, true, window(i32::MIN, t + 255)),
        TestOp::AbsDifference => (o2, true, window(255 - t, 255 + t)),
    };
    CNode {
        off1: o1 as i32,
        off2: off2 as i32,
        child: n.child | if complement { COMPLEMENT } else { 0 },
        lo,
        span,
    }
}

/// A tree compiled for one plane stride.
struct Compiled {
    nodes: Vec<CNode>,
    /// Leaf index of each leaf node (0 for splits).
    leaf: Vec<u32>,
    depth: usize,
}

/// Every tree compiled for planes of this row and plane length.
fn compile(forest: &Forest, layout: (usize, usize)) -> Vec<Compiled> {
    forest
        .trees()
        .iter()
        .map(|tree| Compiled {
            nodes: tree
                .nodes()
                .iter()
                .enumerate()
                .map(|(i, n)| compile_node(i, n, layout))
                .collect(),
            leaf: tree
                .nodes()
                .iter()
                .map(|n| if n.is_leaf { n.child } else { 0 })
                .collect(),
            depth: tree.node_depths().into_iter().max().unwrap_or(0) as usize,
        })
        .collect()
}

/// Walks `bases` through every tree and writes the mean leaf confidences
/// to `acc` (`bases.len()` x b).
///
/// Each level is two passes over the points: first gather every point's
/// node, then read its two values and step. Fused, each step waited for
/// its node load (a cache miss for most points below the top levels)
/// before it could even issue its pixel loads; split, the gather pass has
/// no dependent work, so the CPU keeps dozens of node loads in flight, and
/// the step pass finds its nodes in L1 and overlaps the pixel loads.
///
/// Walks that reached a leaf are dropped from the lockstep at the levels
/// [`compacts`] picks: a leaf points to itself, so a walk whose step left
/// it in place stays there, and its node is final. Trees are as deep as
/// their deepest leaf, but most walks end a few levels earlier (mean
/// sample depth 16 of 20 on the bench fixture).
fn accumulate(
    forest: &Forest,
    compiled: &[Compiled],
    data: &[u8],
    bases: &[usize],
    acc: &mut [f32],
) {
    let b = forest.bins().len();
    let n = bases.len();
    let mut cur = vec![0u32; n];
    let mut base = vec![0usize; n];
    let mut slot = vec![0u32; n];
    // Final node of each point, by its position in `bases`.
    let mut done = vec![0u32; n];
    let mut nodes = vec![CNode::default(); n];
    acc.fill(0.0);
    for (tree, c) in forest.trees().iter().zip(compiled) {
        let cn: &[CNode] = &c.nodes;
        let mut m = n;
        cur.fill(0);
        base.copy_from_slice(bases);
        for (i, s) in slot.iter_mut().enumerate() {
            *s = i as u32;
        }
        for level in 0..c.depth {
            let (cur, base, nodes) = (&mut cur[..m], &mut base[..m], &mut nodes[..m]);
            gather(cn, cur, nodes);
            if !compacts(level, c.depth) {
                step(data, base, nodes, cur);
                continue;
            }
            // Step, record each point's node, and keep (in place, in
            // order) only the walks that moved.
            let mut w = 0;
            for i in 0..m {
                let (node, p, s, old) = (&nodes[i], base[i], slot[i], cur[i]);
                let k = node.next_at(data, p);
                done[s as usize] = k;
                cur[w] = k;
                base[w] = p;
                slot[w] = s;
                w += usize::from(k != old);
            }
            m = w;
        }
        for (&k, &s) in cur[..m].iter().zip(&slot[..m]) {
            done[s as usize] = k;
        }
        let conf = tree.confidences();
        for (&k, out) in done.iter().zip(acc.chunks_exact_mut(b)) {
            let leaf = c.leaf[k as usize] as usize;
            for (o, v) in out.iter_mut().zip(&conf[leaf * b..(leaf + 1) * b]) {
                *o += v;
            }
        }
    }
    let scale = 1.0 / forest.trees().len() as f32;
    for v in acc.iter_mut() {
        *v *= scale;
    }
}

/// The gather pass: each walk's current node.
///
/// Not inlined, like [`step`]: alone, each loop keeps its pointers in
/// registers (inlined into [`accumulate`], both reloaded some from the stack
/// on every visit).
#[inline(never)]
fn gather(cn: &[CNode], cur: &[u32], nodes: &mut [CNode]) {
    for (n, k) in nodes.iter_mut().zip(cur) {
        *n = cn[*k as usize];
    }
}

/// The step pass: each walk's next node.
#[inline(never)]
fn step(data: &[u8], base: &[usize], nodes: &[CNode], cur: &mut [u32]) {
    for ((k, &base), n) in cur.iter_mut().zip(base).zip(nodes) {
        *k = n.next_at(data, base);
    }
}

/// Whether the walks are compacted after step `level` (0-based) of a tree
/// of depth `depth`: after steps 2/5, 3/5 and 4/5 of the way down
/// (levels 8, 12 and 16 of 20).
///
/// A compacting step costs about twice a plain one (it also moves each
/// walk's base and slot), so it pays only once many walks have ended. On
/// the bench fixture (20 trees of depth 20) this schedule ran 13.7% fewer
/// instructions than none; compacting after every level from 8 on saved
/// 4.7%, every second level from 12 on 9.8%, every third from 8 on 13.0%.
fn compacts(level: usize, depth: usize) -> bool {
    level + 1 < depth && (2..5).any(|q| level == q * depth / 5)
}

impl Forest {
    /// Dense prediction: converts `image` to Lab and evaluates the forest on
    /// a grid with step `step` pixels (the paper uses 8), giving a b-channel
    /// confidence image.
    ///
    /// # Performance
    /// Bands of [`BAND`] grid rows run in parallel: each converts the rows
    /// its walks read into a scratch of its own (about 2 MB for a 16 Mpx
    /// image, reused band after band), then walks them; see the module docs
    /// for the traversal. Cost is about (pixels / step^2) x trees x depth
    /// node visits plus the Lab conversion of every pixel and of each
    /// band's 2 x [`crate::lab::PAD`] rows of margin. Whole-image planes
    /// (48 MB for 16 Mpx) cost their 12,000 pages' faults on every call,
    /// a third of the conversion's time; the bands' stay mapped, and in
    /// cache while their walks read them. Bit for bit the same as
    /// [`Forest::predict_lab`] on the whole image's planes (tested).
    pub fn predict_image(&self, image: &RgbImage, step: u32) -> Result<ConfidenceImage> {
        if image.width() == 0 || image.height() == 0 {
            return Err(ForestError::InvalidInput(
                "cannot predict on an empty image".into(),
            ));
        }
        self.predict_bands(image, step, BAND)
    }

    /// [`Forest::predict_image`] with bands of `band` grid rows.
    fn predict_bands(&self, image: &RgbImage, step: u32, band: usize) -> Result<ConfidenceImage> {
        let mut out =
            ConfidenceImage::zeros(image.width(), image.height(), step, self.bins().clone())?;
        let b = self.bins().len();
        let (gw, gh) = out.grid_size();
        let xs: Vec<u32> = (0..gw).map(|i| out.node_pixel(i, 0).0).collect();
        let ys: Vec<u32> = (0..gh).map(|j| out.node_pixel(0, j).1).collect();
        // Every band's planes have the same shape (the last band's rows
        // below the image repeat its last row), so the trees compile once.
        let rows = (band - 1) * step as usize + 1;
        let compiled = compile(self, lab::layout(image.width() as usize, rows));
        out.values_mut()
            .par_chunks_mut(gw * b * band)
            .zip(ys.par_chunks(band))
            .for_each_init(LabPlanes::default, |planes, (chunk, band_ys)| {
                let y0 = band_ys[0];
                planes.convert_band_into(image, y0 as usize, rows);
                for (row, &y) in chunk.chunks_mut(gw * b).zip(band_ys) {
                    let bases: Vec<usize> = xs.iter().map(|&x| planes.base(x, y - y0)).collect();
                    accumulate(self, &compiled, planes.data(), &bases, row);
                }
            });
        Ok(out)
    }

    /// [`Forest::predict_image`] on an image already converted to Lab
    /// (complemented planes, if present, are not needed).
    pub fn predict_lab(&self, planes: &LabPlanes, step: u32) -> Result<ConfidenceImage> {
        let mut out =
            ConfidenceImage::zeros(planes.width(), planes.height(), step, self.bins().clone())?;
        let b = self.bins().len();
        let compiled = compile(self, (planes.stride(), planes.plane_len()));
        let (gw, gh) = out.grid_size();
        let xs: Vec<u32> = (0..gw).map(|i| out.node_pixel(i, 0).0).collect();
        let ys: Vec<u32> = (0..gh).map(|j| out.node_pixel(0, j).1).collect();
        out.values_mut()
            .par_chunks_mut(gw * b)
            .zip(ys.par_iter())
            .for_each(|(row, &y)| {
                let bases: Vec<usize> = xs.iter().map(|&x| planes.base(x, y)).collect();
                accumulate(self, &compiled, planes.data(), &bases, row);
            });
        Ok(out)
    }

    /// Mean leaf confidences (b per pixel, pixel-major) at the given pixels.
    /// Pixels outside the image are an error.
    pub fn predict_pixels(&self, planes: &LabPlanes, pixels: &[(u32, u32)]) -> Result<Vec<f32>> {
        if let Some(p) = pixels
            .iter()
            .find(|p| p.0 >= planes.width() || p.1 >= planes.height())
        {
            return Err(ForestError::InvalidInput(format!(
                "pixel {p:?} outside the {}x{} image",
                planes.width(),
                planes.height()
            )));
        }
        let b = self.bins().len();
        let compiled = compile(self, (planes.stride(), planes.plane_len()));
        let mut out = vec![0.0f32; pixels.len() * b];
        out.par_chunks_mut(BATCH * b)
            .zip(pixels.par_chunks(BATCH))
            .for_each(|(acc, chunk)| {
                let bases: Vec<usize> = chunk.iter().map(|&(x, y)| planes.base(x, y)).collect();
                accumulate(self, &compiled, planes.data(), &bases, acc);
            });
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::TrainingSet;
    use crate::params::{TrainParams, TrainingSummary};
    use crate::patch::SplitTest;
    use crate::tree::Tree;
    use rand::{Rng, SeedableRng};
    use vp_scene::raster::{Label, LabelImage};

    /// A random, unbalanced tree of at most `max_depth` levels, every test
    /// op and threshold range, random leaf counts.
    fn random_tree(rng: &mut impl Rng, max_depth: u32, n_bins: usize) -> Tree {
        let leaf = Node {
            test: SplitTest::random(rng),
            threshold: 0,
            child: 0,
            is_leaf: true,
        };
        let mut nodes = vec![leaf];
        let mut open = vec![(0usize, 0u32)];
        let mut leaves = 0;
        while let Some((i, depth)) = open.pop() {
            if depth < max_depth && rng.random_bool(0.85) {
                let c = nodes.len();
                nodes[i] = Node {
                    test: SplitTest::random(rng),
                    threshold: rng.random_range(-300..600),
                    child: c as u32,
                    is_leaf: false,
                };
                nodes.extend([leaf, leaf]);
                open.extend([(c + 1, depth + 1), (c, depth + 1)]);
            } else {
                nodes[i] = Node {
                    child: leaves,
                    ..leaf
                };
                leaves += 1;
            }
        }
        let counts = (0..leaves as usize * (2 + 2 * n_bins))
            .map(|_| rng.random_range(0..50))
            .collect();
        Tree::from_parts(nodes, counts, n_bins, [1.0, 1.5], 1.0).unwrap()
    }

    /// The mean leaf confidences by walking each tree node by node, summed
    /// in tree order and scaled as the lockstep walk does.
    fn per_point(forest: &Forest, planes: &LabPlanes, x: u32, y: u32) -> Vec<u32> {
        let mut sum = vec![0.0f32; forest.bins().len()];
        for t in forest.trees() {
            let conf = t.leaf_confidence(t.leaf_of(planes, planes.base(x, y)));
            for (s, v) in sum.iter_mut().zip(conf) {
                *s += v;
            }
        }
        let scale = 1.0 / forest.trees().len() as f32;
        sum.iter().map(|s| (s * scale).to_bits()).collect()
    }

    /// The lockstep walk, which drops finished walks at some levels, gives
    /// bit for bit what walking each point node by node gives: random
    /// unbalanced forests of 1 to 15 levels (so the compaction levels
    /// vary), random images, grid steps and pixel lists longer than a batch.
    #[test]
    fn lockstep_walk_equals_per_point_walk_on_random_forests() {
        for seed in 0..8 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let params = TrainParams::default();
            let n_bins = params.bins.len();
            let trees = (0..rng.random_range(1..5))
                .map(|_| {
                    let depth = rng.random_range(1..16);
                    random_tree(&mut rng, depth, n_bins)
                })
                .collect();
            let summary = TrainingSummary {
                seed,
                n_images: 0,
                n_label_images: 0,
                n_positive_available: 0,
                n_negative_available: 0,
                n_positive: 0,
                n_negative: 0,
                n_beyond_gamma_max: 0,
                class_weights: [1.0, 1.5],
                n_nodes: 0,
                n_leaves: 0,
                max_depth_reached: 0,
                mean_sample_depth: 0.0,
                train_accuracy: 0.0,
            };
            let forest = Forest::from_parts(params, summary, trees);
            let (w, h) = (rng.random_range(1..90), rng.random_range(1..60));
            let pixels: Vec<[u8; 3]> = (0..w * h).map(|_| rng.random()).collect();
            let img = RgbImage::from_fn(w, h, |x, y| image::Rgb(pixels[(y * w + x) as usize]));
            let planes = LabPlanes::from_rgb(&img);
            let step = rng.random_range(1..9);
            let conf = forest.predict_lab(&planes, step).unwrap();
            for band in [1, 2, 3, 8, BAND] {
                let banded = forest.predict_bands(&img, step, band).unwrap();
                let bits = |c: &ConfidenceImage| {
                    c.values().iter().map(|v| v.to_bits()).collect::<Vec<_>>()
                };
                assert_eq!(bits(&banded), bits(&conf), "seed {seed} band {band}");
            }
            let (gw, gh) = conf.grid_size();
            for j in 0..gh {
                for i in 0..gw {
                    let (x, y) = conf.node_pixel(i, j);
                    let got: Vec<u32> = conf.node(i, j).iter().map(|v| v.to_bits()).collect();
                    assert_eq!(
                        got,
                        per_point(&forest, &planes, x, y),
                        "seed {seed} ({x}, {y})"
                    );
                }
            }
            let at: Vec<(u32, u32)> = (0..700)
                .map(|_| (rng.random_range(0..w), rng.random_range(0..h)))
                .collect();
            let fast = forest.predict_pixels(&planes, &at).unwrap();
            for (&(x, y), got) in at.iter().zip(fast.chunks_exact(n_bins)) {
                let got: Vec<u32> = got.iter().map(|v| v.to_bits()).collect();
                assert_eq!(
                    got,
                    per_point(&forest, &planes, x, y),
                    "seed {seed} ({x}, {y})"
                );
            }
        }
    }

    /// The compiled window test decides exactly like `response <= threshold`,
    /// for every op and any threshold a model file may hold.
    #[test]
    fn compiled_nodes_decide_like_the_split_test() {
        let img = RgbImage::from_fn(30, 30, |x, y| {
            image::Rgb([(x * 9) as u8, (y * 8) as u8, ((x * y) % 256) as u8])
        });
        let planes = LabPlanes::from_rgb(&img);
        let d = planes.data();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for _ in 0..3000 {
            let test = crate::patch::SplitTest::random(&mut rng);
            let threshold = match rng.random_range(0..4) {
                0 => i16::MIN,
                1 => i16::MAX,
                _ => rng.random_range(-300..600),
            };
            let node = Node {
                test,
                threshold,
                child: 1,
                is_leaf: false,
            };
            let c = compile_node(0, &node, (planes.stride(), planes.plane_len()));
            let base = planes.base(rng.random_range(0..30), rng.random_range(0..30));
            let left = c.next_at(d, base) == 1;
            let want = test.response(&planes, base) <= i32::from(threshold);
            assert_eq!(left, want, "{test:?} threshold {threshold}");
        }
    }

    /// Lockstep compiled traversal must equal plain per-node traversal.
    #[test]
    fn compiled_prediction_equals_plain_traversal() {
        let img = RgbImage::from_fn(48, 40, |x, y| {
            image::Rgb([
                ((x * 37 + y * 11) % 256) as u8,
                ((x * y) % 256) as u8,
                (x * 5) as u8,
            ])
        });
        let mut labels = LabelImage::new(48, 40);
        for y in 0..40 {
            for x in 0..48 {
                let label = if (x * 37 + y * 11) % 256 > 128 {
                    Label::Positive
                } else {
                    Label::Negative
                };
                labels.set(x, y, label, (x % 45) as f32).unwrap();
            }
        }
        let mut set = TrainingSet::new();
        set.add_image(&img, &[labels]).unwrap();
        let params = TrainParams {
            n_trees: 3,
            max_depth: 7,
            min_samples_split: 4,
            n_tests: 40,
            n_thresholds: 10,
            n_node_samples: 64,
            ..TrainParams::default()
        };
        let forest = crate::train(&set, &params, 5).unwrap();
        let planes = LabPlanes::from_rgb(&img);
        let pixels: Vec<(u32, u32)> = (0..40).flat_map(|y| (0..48).map(move |x| (x, y))).collect();
        let fast = forest.predict_pixels(&planes, &pixels).unwrap();
        let b = forest.bins().len();
        for (p, got) in pixels.iter().zip(fast.chunks_exact(b)) {
            let base = planes.base(p.0, p.1);
            let mut want = vec![0.0f32; b];
            for t in forest.trees() {
                for (w, v) in want
                    .iter_mut()
                    .zip(t.leaf_confidence(t.leaf_of(&planes, base)))
                {
                    *w += v;
                }
            }
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (g - w / 3.0).abs() < 1e-6,
                    "pixel {p:?}: {g} vs {}",
                    w / 3.0
                );
            }
        }
        // The grid prediction reads the same values at its nodes.
        let conf = forest.predict_image(&img, 8).unwrap();
        assert_eq!(conf.grid_size(), (6, 5));
        let (x, y) = conf.node_pixel(2, 3);
        let k = (y * 48 + x) as usize * b;
        assert_eq!(conf.node(2, 3), &fast[k..k + b]);
        // Planes that carry the complemented copies (as metrics converts
        // them) predict the same: the complement is taken per node.
        let with = forest
            .predict_lab(&LabPlanes::from_rgb_with_complement(&img), 8)
            .unwrap();
        assert_eq!(with, conf);
        assert!(forest.predict_pixels(&planes, &[(48, 0)]).is_err());
    }
}
