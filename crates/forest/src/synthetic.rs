//! Seeded synthetic textures for tests, benchmarks and demos: images made of
//! square blocks that are either smooth (slow shading) or noisy (strong
//! per-pixel noise), each block with its own random base colour, so that
//! only texture, not colour, tells the classes apart.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_scene::raster::{Label, LabelImage, RgbImage};

/// A synthetic image and which of its pixels are noisy.
#[derive(Debug, Clone)]
pub struct TextureImage {
    /// The image.
    pub image: RgbImage,
    /// Per pixel, row-major: whether it lies in a noisy block.
    pub noisy: Vec<bool>,
    /// Block side in pixels.
    pub block: u32,
}

impl TextureImage {
    /// Whether pixel (x, y) lies in a noisy block.
    pub fn is_noisy(&self, x: u32, y: u32) -> bool {
        self.noisy[(y * self.image.width() + x) as usize]
    }

    /// Distance in pixels from (x, y) to the nearest block border.
    pub fn border_distance(&self, x: u32, y: u32) -> u32 {
        let d = |v: u32| {
            let r = v % self.block;
            r.min(self.block - 1 - r)
        };
        d(x).min(d(y))
    }
}

/// A `width` x `height` image of `block`-sized squares, each smooth or
/// noisy with probability 1/2.
pub fn texture_image(width: u32, height: u32, block: u32, seed: u64) -> TextureImage {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (bw, bh) = (width.div_ceil(block), height.div_ceil(block));
    let blocks: Vec<(bool, [f32; 3], f32)> = (0..bw * bh)
        .map(|_| {
            let colour = [0, 1, 2].map(|_| rng.random_range(60.0..196.0));
            (
                rng.random_bool(0.5),
                colour,
                rng.random_range(0.0..std::f32::consts::TAU),
            )
        })
        .collect();
    let mut noisy = Vec::with_capacity((width * height) as usize);
    let mut image = RgbImage::new(width, height);
    for y in 0..height {
        for x in 0..width {
            let (is_noisy, colour, phase) = blocks[((y / block) * bw + x / block) as usize];
            let shade = 20.0 * ((x as f32 * 0.11 + y as f32 * 0.07 + phase).sin());
            let px = colour.map(|c| {
                let v = if is_noisy {
                    c + rng.random_range(-60.0..60.0)
                } else {
                    c + shade
                };
                v.clamp(0.0, 255.0) as u8
            });
            image.put_pixel(x, y, image::Rgb(px));
            noisy.push(is_noisy);
        }
    }
    TextureImage {
        image,
        noisy,
        block,
    }
}

/// Labels every `stride`-th pixel in x and y with a random angle, uniform
/// in [0, `max_angle`), and the label `rule(noisy, angle)`.
pub fn label_image(
    img: &TextureImage,
    stride: u32,
    max_angle: f32,
    seed: u64,
    rule: impl Fn(bool, f32) -> Label,
) -> LabelImage {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (w, h) = img.image.dimensions();
    let mut labels = LabelImage::new(w, h);
    for y in (0..h).step_by(stride as usize) {
        for x in (0..w).step_by(stride as usize) {
            let angle = rng.random_range(0.0..max_angle);
            // Angles are finite and non-negative by construction.
            let _ = labels.set(x, y, rule(img.is_noisy(x, y), angle), angle);
        }
    }
    labels
}
