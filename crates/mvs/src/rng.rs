//! Per-pixel randomness: a counter-based generator keyed by (seed, view,
//! pixel, step), so every pixel draws the same numbers whichever thread
//! runs it and in whatever order.

use vp_scene::hash::{finalise as mix, SplitMix64, GOLDEN_GAMMA};

/// A small generator for one pixel and one step.
#[derive(Debug, Clone)]
pub(crate) struct PixelRng(SplitMix64);

impl PixelRng {
    /// The generator of `pixel` of view `view` at `step` under `seed`.
    #[inline]
    pub(crate) fn new(seed: u64, view: u64, pixel: u64, step: u64) -> Self {
        let mut s = mix(seed ^ GOLDEN_GAMMA);
        s = mix(s ^ view.wrapping_mul(0xd1b5_4a32_d192_ed03));
        s = mix(s ^ pixel.wrapping_mul(0x8cb9_2ba7_2f3d_8dd7));
        PixelRng(SplitMix64::new(mix(
            s ^ step.wrapping_mul(0xa076_1d64_78bd_642f)
        )))
    }

    /// Uniform in [0, 1).
    #[inline]
    pub(crate) fn next_f32(&mut self) -> f32 {
        (self.0.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// Uniform in [-1, 1).
    #[inline]
    pub(crate) fn symmetric(&mut self) -> f32 {
        2.0 * self.next_f32() - 1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_key_same_numbers_and_range() {
        let mut a = PixelRng::new(1, 2, 3, 4);
        let mut b = PixelRng::new(1, 2, 3, 4);
        let mut c = PixelRng::new(1, 2, 4, 4);
        let (mut sum, n) = (0.0f64, 10_000);
        for _ in 0..n {
            let x = a.next_f32();
            assert_eq!(x.to_bits(), b.next_f32().to_bits());
            assert!((0.0..1.0).contains(&x));
            sum += f64::from(c.next_f32());
        }
        assert!((sum / f64::from(n) - 0.5).abs() < 0.02);
    }
}
