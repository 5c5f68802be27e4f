//! The training set: images converted once to Lab, and their labelled pixels.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use vp_scene::raster::{Label, LabelImage, RgbImage};

use crate::error::{ForestError, Result};
use crate::lab::LabPlanes;

/// One labelled pixel of one label image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sample {
    /// Index of the image in the set.
    pub image: u32,
    /// [`LabPlanes::base`] of the pixel.
    pub base: u32,
    /// Triangulation angle in degrees.
    pub angle: f32,
    /// Whether the MVS succeeded here.
    pub positive: bool,
}

/// Images with their label images, ready for [`crate::train`]. The same
/// image may come with several label images (one per triplet it was part of);
/// each labelled pixel of each label image becomes one sample.
#[derive(Debug, Clone, Default)]
pub struct TrainingSet {
    pub(crate) images: Vec<LabPlanes>,
    pub(crate) samples: Vec<Sample>,
    n_label_images: usize,
    cap: Option<(usize, u64)>,
}

impl TrainingSet {
    /// An empty set that keeps every labelled pixel.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty set that keeps at most `max_pixels` labelled pixels of each
    /// label image, a uniform random subset (seeded by `seed` and the label
    /// image's position): bounds memory when label images are large and
    /// many. Uniform keeps each image's class ratio, so the leaves' rates
    /// stay calibrated probabilities; a cap per class would pull every
    /// confidence towards 0.5 wherever both classes exceed it.
    pub fn with_cap_per_label_image(max_pixels: usize, seed: u64) -> Self {
        TrainingSet {
            cap: Some((max_pixels, seed)),
            ..Self::default()
        }
    }

    /// Adds an image and its label images (each of the image's size).
    pub fn add_image(&mut self, image: &RgbImage, labels: &[LabelImage]) -> Result<()> {
        let (w, h) = image.dimensions();
        if w == 0 || h == 0 {
            return Err(ForestError::InvalidInput(format!(
                "training image {} is empty",
                self.images.len()
            )));
        }
        if let Some((i, l)) = labels
            .iter()
            .enumerate()
            .find(|(_, l)| (l.width(), l.height()) != (w, h))
        {
            return Err(ForestError::InvalidInput(format!(
                "training image {}: label image {i} is {}x{}, the image {w}x{h}",
                self.images.len(),
                l.width(),
                l.height()
            )));
        }
        let planes = LabPlanes::from_rgb(image);
        if planes.plane_len() > u32::MAX as usize || self.images.len() >= u32::MAX as usize {
            return Err(ForestError::InvalidInput(format!(
                "training image {} of {w}x{h} is too large",
                self.images.len()
            )));
        }
        let image_index = self.images.len() as u32;
        for l in labels {
            let mut all: Vec<Sample> = l
                .labelled()
                .map(|(x, y, label, angle)| Sample {
                    image: image_index,
                    base: planes.base(x, y) as u32,
                    angle,
                    positive: label == Label::Positive,
                })
                .collect();
            if let Some((cap, seed)) = self.cap {
                if all.len() > cap {
                    let mut rng = ChaCha8Rng::seed_from_u64(
                        seed ^ (self.n_label_images as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15),
                    );
                    let mut keep = rand::seq::index::sample(&mut rng, all.len(), cap).into_vec();
                    keep.sort_unstable();
                    all = keep.into_iter().map(|i| all[i]).collect();
                }
            }
            all.sort_by_key(|s| s.base);
            self.samples.extend(all);
            self.n_label_images += 1;
        }
        self.images.push(planes);
        Ok(())
    }

    /// Number of images.
    pub fn n_images(&self) -> usize {
        self.images.len()
    }

    /// Number of label images.
    pub fn n_label_images(&self) -> usize {
        self.n_label_images
    }

    /// Number of samples (labelled pixels kept).
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether the set has no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Number of positive samples.
    pub fn n_positive(&self) -> usize {
        self.samples.iter().filter(|s| s.positive).count()
    }

    /// Number of negative samples.
    pub fn n_negative(&self) -> usize {
        self.len() - self.n_positive()
    }

    /// A 64-bit digest of the set (every image's Lab pixels, every sample),
    /// stored with each tree of a distributed training run so that trees
    /// trained on different data refuse to be assembled into one forest.
    ///
    /// # Performance
    /// One pass over the Lab planes, 8 bytes per step: far below the cost
    /// of converting the images, and of training one tree.
    pub fn fingerprint(&self) -> u64 {
        use crate::train::mix;
        let mut h = mix(self.images.len() as u64, self.n_label_images as u64);
        for img in &self.images {
            h = mix(h, u64::from(img.width()) << 32 | u64::from(img.height()));
            h = img.digest(h);
        }
        for s in &self.samples {
            let packed = u64::from(s.image) << 32 | u64::from(s.base);
            h = mix(h, packed);
            h = mix(h, u64::from(s.angle.to_bits()) << 1 | u64::from(s.positive));
        }
        h
    }
}
