//! The workspace's one seeded hash: SplitMix64 (Steele, Lea and Flood,
//! "Fast splittable pseudorandom number generators", 2014).
//!
//! Every random choice in vpctl takes a seed; where a stream or a per-item
//! value must not depend on thread count or evaluation order, the seed is
//! spread by this hash instead of a stateful generator. The procedural
//! scenes, the virtual MVS and SfM of the simulator, the MVS's per-pixel
//! randomness and the forest's threshold jitter all call it here, so one
//! set of constants decides every stream (their outputs are pinned by
//! tests and the demo).

/// SplitMix64's increment, 2^64 / phi rounded to odd: consecutive states of
/// a [`SplitMix64`] stream are this far apart.
pub const GOLDEN_GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

/// SplitMix64's output function alone (Stafford's "Mix13"): a bijective
/// avalanche of 64 bits; every input bit flips about half the output bits.
#[inline]
#[must_use]
pub fn finalise(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// One SplitMix64 step taken from state `z`: `finalise(z + GOLDEN_GAMMA)`.
/// Spreads nearby seeds (0, 1, 2, ...) over the whole u64 range; nested,
/// `mix64(seed ^ mix64(part))`, it derives independent seeds of parts.
#[inline]
#[must_use]
pub fn mix64(z: u64) -> u64 {
    finalise(z.wrapping_add(GOLDEN_GAMMA))
}

/// A SplitMix64 stream: a tiny seeded generator where seeding a ChaCha
/// stream per use would cost more than the work it randomises.
#[derive(Debug, Clone)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// The stream whose first output is `mix64(seed)`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        SplitMix64 { state: seed }
    }

    /// The next 64 random bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(GOLDEN_GAMMA);
        finalise(self.state)
    }

    /// The next value uniform in [0, 1), from the top 53 bits.
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The reference outputs of SplitMix64 seeded with 1234567 (the test
    /// vector of the authors' `SplittableRandom` and of Vigna's C code).
    #[test]
    fn stream_matches_the_reference_vector() {
        let mut s = SplitMix64::new(1_234_567);
        let got: Vec<u64> = (0..5).map(|_| s.next_u64()).collect();
        assert_eq!(
            got,
            [
                6_457_827_717_110_365_317,
                3_203_168_211_198_807_973,
                9_817_491_932_198_370_423,
                4_593_380_528_125_082_431,
                16_408_922_859_458_223_821,
            ]
        );
        assert_eq!(mix64(1_234_567), got[0]);
    }
}
