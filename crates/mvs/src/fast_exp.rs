//! `exp` for the bilateral weights of the reference patch, in plain float
//! and integer arithmetic so that a loop over a window row vectorises.
//!
//! Why: `RefPatch::build` weighs every window sample by
//! `exp(-dc^2 / (2 sigma_c^2))`, once per pixel and PatchMatch update;
//! the standard library's `f32::exp` is a call into libm per sample, which
//! no loop around it can vectorise (about a tenth of PatchMatch's time in a
//! profile of the demo: the patch build and `expf`). This is Cephes'
//! `expf` (range reduction by `ln 2` in two parts, a degree-5 polynomial,
//! the power of two put into the exponent bits), within a few ulps of
//! `f32::exp` (tested), and the same bits on every machine: no FMA, no
//! table, no library call.

/// `log2(e)`.
const LOG2E: f32 = std::f32::consts::LOG2_E;
/// `ln 2` in two parts, so that `x - n ln 2` loses nothing for `|n| <= 127`.
const LN2_HI: f32 = 0.693_359_4;
const LN2_LO: f32 = -2.121_944_4e-4;
/// Adding then subtracting 1.5 * 2^23 rounds a float below 2^22 to the
/// nearest integer (and leaves that integer in the low mantissa bits).
const ROUND_MAGIC: f32 = 12_582_912.0;
/// Inputs are clamped here: below, `exp` is under `f32`'s normal range
/// (the weights there are 0 for any purpose); above, it overflows.
const MIN_X: f32 = -87.0;
const MAX_X: f32 = 88.0;

/// `e^x`, within a few ulps of `f32::exp` for `x` in `[-87, 88]`; `e^-87`
/// below that (about 1.6e-38), `e^88` above it, and NaN for NaN.
#[inline]
pub(crate) fn exp(x: f32) -> f32 {
    // `clamp` keeps a NaN input NaN through the arithmetic below.
    let x = x.clamp(MIN_X, MAX_X);
    let t = x * LOG2E + ROUND_MAGIC;
    let n = t - ROUND_MAGIC;
    let ni = (t.to_bits() as i32).wrapping_sub(ROUND_MAGIC.to_bits() as i32);
    let r = x - n * LN2_HI - n * LN2_LO;
    let mut p = 1.987_569_1e-4f32;
    p = p * r + 1.398_199_9e-3;
    p = p * r + 8.333_452e-3;
    p = p * r + 4.166_579_6e-2;
    p = p * r + 1.666_666_5e-1;
    p = p * r + 0.5; // Cephes' 5.0000001201e-1, the same f32
    let y = p * (r * r) + r + 1.0;
    // 2^n for n in [-126, 127]: the biased exponent alone.
    let scale = f32::from_bits((ni.wrapping_add(127) as u32) << 23);
    y * scale
}

#[cfg(test)]
mod tests {
    use super::exp;

    /// Distance in units in the last place between two positive floats.
    fn ulps(a: f32, b: f32) -> u32 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
    }

    #[test]
    fn matches_the_standard_exp_within_a_few_ulps() {
        let mut worst = 0;
        let mut x = -87.0f32;
        while x <= 88.0 {
            let u = ulps(exp(x), x.exp());
            assert!(
                u <= 4,
                "exp({x}) = {} against {}: {u} ulps",
                exp(x),
                x.exp()
            );
            worst = worst.max(u);
            x += 0.000_37;
        }
        assert!(worst >= 1, "the sweep compared nothing that differs");
        assert_eq!(exp(0.0).to_bits(), 1.0f32.to_bits());
    }

    #[test]
    fn clamps_outside_the_normal_range_and_keeps_nan() {
        assert_eq!(exp(-1000.0).to_bits(), exp(-87.0).to_bits());
        assert!(exp(-1000.0) > 0.0);
        assert_eq!(exp(1000.0).to_bits(), exp(88.0).to_bits());
        assert!(exp(1000.0).is_finite());
        assert!(exp(f32::NAN).is_nan());
        assert_eq!(exp(f32::NEG_INFINITY).to_bits(), exp(-87.0).to_bits());
    }
}
