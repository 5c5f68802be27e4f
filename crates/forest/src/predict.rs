//! Prediction: dense on a grid, or at given pixels.
//!
//! Trees are compiled per image stride into 16-byte nodes holding absolute
//! plane offsets, and a leaf becomes a node that points to itself with a
//! threshold no response exceeds. A whole row of grid points then walks a
//! tree in lockstep for exactly the tree's depth, without a branch per
//! visit: the walks of different points are independent, so the CPU keeps
//! many node and pixel loads in flight instead of waiting on each.

use rayon::prelude::*;
use vp_scene::raster::{ConfidenceImage, RgbImage};

use crate::error::{ForestError, Result};
use crate::lab::LabPlanes;
use crate::patch::TestOp;
use crate::Forest;

/// Pixels per parallel task of [`Forest::predict_pixels`].
const BATCH: usize = 512;

/// A node compiled for one plane stride.
#[derive(Debug, Clone, Copy)]
struct CNode {
    off1: i32,
    off2: i32,
    child: u32,
    threshold: i16,
    /// v1 + sign * v2.
    sign: i8,
    /// 1 to take the absolute value.
    abs: u8,
}

/// A tree compiled for one plane stride.
struct Compiled {
    nodes: Vec<CNode>,
    /// Leaf index of each leaf node (0 for splits).
    leaf: Vec<u32>,
    depth: usize,
}

fn compile(forest: &Forest, planes: &LabPlanes) -> Vec<Compiled> {
    forest
        .trees()
        .iter()
        .map(|tree| {
            let nodes: Vec<CNode> = tree
                .nodes()
                .iter()
                .enumerate()
                .map(|(i, n)| {
                    if n.is_leaf {
                        return CNode {
                            off1: 0,
                            off2: 0,
                            child: i as u32,
                            threshold: i16::MAX,
                            sign: 0,
                            abs: 0,
                        };
                    }
                    let (o1, o2) = n.test.plane_offsets(planes);
                    let (sign, abs) = match n.test.op {
                        TestOp::Value => (0, 0),
                        TestOp::Sum => (1, 0),
                        TestOp::Difference => (-1, 0),
                        TestOp::AbsDifference => (-1, 1),
                    };
                    CNode {
                        off1: o1 as i32,
                        off2: o2 as i32,
                        child: n.child,
                        threshold: n.threshold,
                        sign,
                        abs,
                    }
                })
                .collect();
            let leaf = tree
                .nodes()
                .iter()
                .map(|n| if n.is_leaf { n.child } else { 0 })
                .collect();
            let depth = tree.node_depths().into_iter().max().unwrap_or(0) as usize;
            Compiled { nodes, leaf, depth }
        })
        .collect()
}

/// Walks `bases` through every tree and adds the mean leaf confidences to
/// `acc` (`bases.len()` x b). `cur` is scratch of `bases.len()`.
fn accumulate(
    forest: &Forest,
    compiled: &[Compiled],
    data: &[u8],
    bases: &[usize],
    cur: &mut [u32],
    acc: &mut [f32],
) {
    let b = forest.bins().len();
    let scale = 1.0 / forest.trees().len() as f32;
    acc.fill(0.0);
    for (tree, c) in forest.trees().iter().zip(compiled) {
        cur.fill(0);
        for _ in 0..c.depth {
            for (k, &base) in cur.iter_mut().zip(bases) {
                let n = c.nodes[*k as usize];
                let v1 = i32::from(data[(base as isize + n.off1 as isize) as usize]);
                let v2 = i32::from(data[(base as isize + n.off2 as isize) as usize]);
                let r = v1 + i32::from(n.sign) * v2;
                // Branch-free |r| when abs = 1: mask is all ones for negative r.
                let mask = -i32::from(n.abs) & (r >> 31);
                let r = (r ^ mask) - mask;
                *k = n.child + u32::from(r > i32::from(n.threshold));
            }
        }
        let conf = tree.confidences();
        for (k, out) in cur.iter().zip(acc.chunks_exact_mut(b)) {
            let leaf = c.leaf[*k as usize] as usize;
            for (o, v) in out.iter_mut().zip(&conf[leaf * b..(leaf + 1) * b]) {
                *o += v;
            }
        }
    }
    for v in acc.iter_mut() {
        *v *= scale;
    }
}

impl Forest {
    /// Dense prediction: converts `image` to Lab and evaluates the forest on
    /// a grid with step `step` pixels (the paper uses 8), giving a b-channel
    /// confidence image.
    ///
    /// # Performance
    /// Rows of grid points run in parallel; see the module docs for the
    /// traversal. Cost is about (pixels / step^2) x trees x depth node visits
    /// plus the Lab conversion of every pixel.
    pub fn predict_image(&self, image: &RgbImage, step: u32) -> Result<ConfidenceImage> {
        if image.width() == 0 || image.height() == 0 {
            return Err(ForestError::InvalidInput(
                "cannot predict on an empty image".into(),
            ));
        }
        self.predict_lab(&LabPlanes::from_rgb(image), step)
    }

    /// [`Forest::predict_image`] on an image already converted to Lab.
    pub fn predict_lab(&self, planes: &LabPlanes, step: u32) -> Result<ConfidenceImage> {
        let mut out =
            ConfidenceImage::zeros(planes.width(), planes.height(), step, self.bins().clone())?;
        let b = self.bins().len();
        let compiled = compile(self, planes);
        let (gw, gh) = out.grid_size();
        let xs: Vec<u32> = (0..gw).map(|i| out.node_pixel(i, 0).0).collect();
        let ys: Vec<u32> = (0..gh).map(|j| out.node_pixel(0, j).1).collect();
        out.values_mut()
            .par_chunks_mut(gw * b)
            .zip(ys.par_iter())
            .for_each(|(row, &y)| {
                let bases: Vec<usize> = xs.iter().map(|&x| planes.base(x, y)).collect();
                let mut cur = vec![0u32; gw];
                accumulate(self, &compiled, planes.data(), &bases, &mut cur, row);
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
        let compiled = compile(self, planes);
        let mut out = vec![0.0f32; pixels.len() * b];
        out.par_chunks_mut(BATCH * b)
            .zip(pixels.par_chunks(BATCH))
            .for_each(|(acc, chunk)| {
                let bases: Vec<usize> = chunk.iter().map(|&(x, y)| planes.base(x, y)).collect();
                let mut cur = vec![0u32; chunk.len()];
                accumulate(self, &compiled, planes.data(), &bases, &mut cur, acc);
            });
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::TrainingSet;
    use crate::params::TrainParams;
    use vp_scene::raster::{Label, LabelImage};

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
        assert!(forest.predict_pixels(&planes, &[(48, 0)]).is_err());
    }
}
