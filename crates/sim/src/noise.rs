//! Counter-based randomness and 3D solid noise.
//!
//! The renderer and the virtual MVS evaluate randomness per pixel and per
//! world point from many threads. A stateful RNG would make the output depend
//! on the order of evaluation; here every random value is a pure hash of
//! (seed, coordinates), so the output is bit-identical for any thread count.
//! The noise is 3D and evaluated at world points, so all views of a surface
//! point agree on its texture and on whether the MVS fails there.

use std::sync::OnceLock;

use vp_scene::hash::mix64;

/// Hash of a seed and three integer coordinates: odd-constant products
/// folded together, then one avalanche (the texture hot path calls this eight
/// times per noise octave).
#[inline]
pub fn hash3(seed: u64, a: i64, b: i64, c: i64) -> u64 {
    mix64(
        seed ^ (a as u64).wrapping_mul(0x8cb9_2ba7_2f3d_8dd7)
            ^ (b as u64)
                .wrapping_mul(0xd6e8_feb8_6659_fd93)
                .rotate_left(21)
            ^ (c as u64)
                .wrapping_mul(0xa076_1d64_78bd_642f)
                .rotate_left(42),
    )
}

/// A uniform value in [0, 1) from a hash (53 random bits).
#[inline]
pub fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A standard normal value for (seed, a, b, c), by Box-Muller on two hashes.
pub fn gaussian(seed: u64, a: i64, b: i64, c: i64) -> f64 {
    let h = hash3(seed, a, b, c);
    let u1 = unit(h).max(1e-300);
    let u2 = unit(mix64(h ^ 0x5bd1_e995));
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Quintic fade: C2 interpolation weights, so no lattice creases show.
#[inline]
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Value noise at `p` in lattice units, in [-1, 1]: random values on the
/// integer lattice, interpolated with quintic weights.
pub fn value_noise(seed: u64, p: [f64; 3]) -> f64 {
    let f = p.map(f64::floor);
    let i = f.map(|v| v as i64);
    let t = [fade(p[0] - f[0]), fade(p[1] - f[1]), fade(p[2] - f[2])];
    let corner =
        |dx: i64, dy: i64, dz: i64| 2.0 * unit(hash3(seed, i[0] + dx, i[1] + dy, i[2] + dz)) - 1.0;
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), t[0]);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), t[0]);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), t[0]);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), t[0]);
    lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2])
}

/// A rotation that tilts the lattice against the world axes (orthonormal).
/// Value noise is not stationary: its variance peaks on lattice planes, and
/// a horizontal plane at a lattice height (terrain at z = 0) would see a
/// different distribution than elsewhere. Rotated, every plane cuts the
/// lattice obliquely.
const ROTATION: [[f64; 3]; 3] = [
    [0.00, 0.80, 0.60],
    [-0.80, 0.36, -0.48],
    [-0.60, -0.48, 0.64],
];

fn rotate(p: [f64; 3]) -> [f64; 3] {
    ROTATION.map(|r| r[0] * p[0] + r[1] * p[1] + r[2] * p[2])
}

/// Fractal sum of `octaves` octaves of [`value_noise`] at world point `p`
/// (metres) with the first octave's `wavelength` (metres); each further octave
/// halves wavelength and amplitude. Normalised to [-1, 1].
pub fn fbm(seed: u64, p: [f64; 3], wavelength: f64, octaves: u32) -> f64 {
    fbm_gain(seed, p, wavelength, octaves, 0.5)
}

/// [`fbm`] whose amplitude falls by `gain` per octave instead of halving.
/// A gain of 2^(1 - alpha) gives the amplitude spectrum 1/f^alpha of
/// natural images (alpha about 1 to 1.4: equal or slowly falling energy per
/// octave), the statistic a photo of rock or soil has and a matcher feeds on.
pub fn fbm_gain(seed: u64, p: [f64; 3], wavelength: f64, octaves: u32, gain: f64) -> f64 {
    let (mut amp, mut sum, mut norm) = (1.0, 0.0, 0.0);
    let mut q = rotate(p.map(|v| v / wavelength));
    for o in 0..octaves {
        // Offset each octave so their lattices do not line up at the origin.
        let s = 31.7 * f64::from(o);
        sum += amp * value_noise(seed ^ u64::from(o), [q[0] + s, q[1] - s, q[2] + 0.5 * s]);
        norm += amp;
        q = rotate(q.map(|v| 2.0 * v));
        amp *= gain;
    }
    sum / norm
}

/// Octaves of the [`uniform_field`].
const FIELD_OCTAVES: u32 = 3;
/// Quantiles in the CDF table of the [`uniform_field`].
const CDF_STEPS: usize = 512;

/// Quantiles of the raw field's marginal distribution, measured once on a
/// fixed sample (the distribution does not depend on the seed).
fn field_quantiles() -> &'static [f64] {
    static TABLE: OnceLock<Vec<f64>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let n = 1 << 17;
        let mut v: Vec<f64> = (0..n)
            .map(|i| {
                let h = hash3(0x00c0_ffee, i, 0, 0);
                let p = [
                    unit(h) * 500.0,
                    unit(mix64(h ^ 1)) * 500.0,
                    unit(mix64(h ^ 2)) * 500.0,
                ];
                fbm(h % 1024, p, 1.0, FIELD_OCTAVES)
            })
            .collect();
        v.sort_by(f64::total_cmp);
        (0..=CDF_STEPS)
            .map(|k| v[(k * (v.len() - 1)) / CDF_STEPS])
            .collect()
    })
}

/// A smooth random field over world space with an (approximately) uniform
/// marginal distribution on [0, 1]: `P(uniform_field(p) < q) = q` for a
/// random point p. Thresholding it against a probability therefore keeps the
/// success rate while making failures spatially coherent blobs of about
/// `wavelength` metres.
pub fn uniform_field(seed: u64, p: [f64; 3], wavelength: f64) -> f64 {
    let raw = fbm(seed, p, wavelength, FIELD_OCTAVES);
    let q = field_quantiles();
    let i = q.partition_point(|&x| x <= raw);
    if i == 0 {
        return 0.0;
    }
    if i > CDF_STEPS {
        return 1.0;
    }
    let (lo, hi) = (q[i - 1], q[i]);
    let frac = if hi > lo { (raw - lo) / (hi - lo) } else { 0.5 };
    ((i - 1) as f64 + frac) / CDF_STEPS as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_field_has_uniform_marginal() {
        let mut counts = [0usize; 10];
        let n = 40_000;
        for i in 0..n {
            let h = hash3(99, i, 7, 0);
            let p = [unit(h) * 300.0, unit(mix64(h)) * 300.0, 3.0];
            let u = uniform_field(1234, p, 0.7);
            counts[((u * 10.0) as usize).min(9)] += 1;
        }
        for c in counts {
            let share = c as f64 / n as f64;
            assert!((share - 0.1).abs() < 0.01, "decile share {share}");
        }
    }

    #[test]
    fn gaussian_has_unit_variance() {
        let n = 50_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let g = gaussian(5, i, 1, 2);
            s += g;
            s2 += g * g;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(
            mean.abs() < 0.02 && (var - 1.0).abs() < 0.03,
            "{mean} {var}"
        );
    }

    #[test]
    fn noise_is_bounded_and_continuous() {
        for i in 0..2000 {
            let p = [i as f64 * 0.013, -(i as f64) * 0.029, 0.3];
            let v = fbm(3, p, 0.5, 4);
            assert!((-1.0..=1.0).contains(&v));
            let w = fbm(3, [p[0] + 1e-5, p[1], p[2]], 0.5, 4);
            assert!((v - w).abs() < 1e-3);
        }
    }
}
