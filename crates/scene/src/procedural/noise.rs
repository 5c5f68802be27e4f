//! Seeded 2D gradient noise and fractal Brownian motion (fBm).
//!
//! Our own small implementation rather than the `noise` crate: the sites
//! must be bit-identical for a seed across versions and platforms, and the
//! whole thing is a few dozen lines. Evaluation is a pure function of the
//! table built from the seed, so it does not depend on the thread count.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Size of the permutation and gradient tables; the noise repeats with this
/// period (in lattice units), far beyond any site at the frequencies used.
const TABLE: usize = 256;

/// Perlin-style gradient noise on the plane with random unit gradients.
///
/// Values lie in [-1, 1]: the raw maximum of 2D gradient noise with unit
/// gradients is sqrt(1/2), and [`GradientNoise::get`] rescales by sqrt(2).
#[derive(Debug, Clone)]
pub struct GradientNoise {
    perm: [u8; TABLE],
    grads: [[f64; 2]; TABLE],
}

impl GradientNoise {
    /// Noise whose tables are drawn from `seed`.
    pub fn new(seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut perm = [0u8; TABLE];
        for (i, p) in perm.iter_mut().enumerate() {
            *p = i as u8;
        }
        // Fisher-Yates with our own loop: the order of draws is part of the
        // output and must not change with a library's shuffle algorithm.
        for i in (1..TABLE).rev() {
            let j = rng.random_range(0..=i);
            perm.swap(i, j);
        }
        let mut grads = [[0.0; 2]; TABLE];
        for g in &mut grads {
            let a = rng.random::<f64>() * std::f64::consts::TAU;
            *g = [a.cos(), a.sin()];
        }
        GradientNoise { perm, grads }
    }

    fn gradient(&self, ix: i64, iy: i64) -> [f64; 2] {
        let hx = self.perm[(ix & (TABLE as i64 - 1)) as usize] as usize;
        let h = self.perm[(hx + (iy & (TABLE as i64 - 1)) as usize) % TABLE] as usize;
        self.grads[h]
    }

    /// Noise value at (x, y) in lattice units, in [-1, 1]; zero on lattice points.
    pub fn get(&self, x: f64, y: f64) -> f64 {
        let (fx, fy) = (x.floor(), y.floor());
        let (ix, iy) = (fx as i64, fy as i64);
        let (tx, ty) = (x - fx, y - fy);
        let dot = |dx: i64, dy: i64| {
            let g = self.gradient(ix + dx, iy + dy);
            g[0] * (tx - dx as f64) + g[1] * (ty - dy as f64)
        };
        let (sx, sy) = (fade(tx), fade(ty));
        let a = lerp(dot(0, 0), dot(1, 0), sx);
        let b = lerp(dot(0, 1), dot(1, 1), sx);
        (lerp(a, b, sy) * std::f64::consts::SQRT_2).clamp(-1.0, 1.0)
    }
}

/// Quintic fade: C2-continuous interpolation weights (no visible lattice creases).
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Fractal Brownian motion: a sum of octaves of [`GradientNoise`], each at
/// `lacunarity` times the frequency and `gain` times the amplitude of the last.
#[derive(Debug, Clone)]
pub struct Fbm {
    noise: GradientNoise,
    /// Frequency of the first octave, cycles per metre (1 / wavelength).
    pub frequency: f64,
    /// Amplitude of the first octave, metres.
    pub amplitude: f64,
    /// Number of octaves.
    pub octaves: u32,
    /// Frequency factor between octaves.
    pub lacunarity: f64,
    /// Amplitude factor between octaves.
    pub gain: f64,
}

impl Fbm {
    /// fBm with the usual lacunarity 2 and gain 0.5.
    pub fn new(seed: u64, wavelength: f64, amplitude: f64, octaves: u32) -> Self {
        Fbm {
            noise: GradientNoise::new(seed),
            frequency: 1.0 / wavelength,
            amplitude,
            octaves,
            lacunarity: 2.0,
            gain: 0.5,
        }
    }

    /// Value at (x, y) in metres; |value| <= [`Fbm::bound`].
    pub fn get(&self, x: f64, y: f64) -> f64 {
        let (mut f, mut a, mut sum) = (self.frequency, self.amplitude, 0.0);
        for octave in 0..self.octaves {
            // Shift each octave so their lattice zeros do not line up at the origin.
            let shift = 17.31 * f64::from(octave);
            sum += a * self.noise.get(x * f + shift, y * f - shift);
            f *= self.lacunarity;
            a *= self.gain;
        }
        sum
    }

    /// Upper bound of |[`Fbm::get`]|: the sum of the octave amplitudes.
    pub fn bound(&self) -> f64 {
        (0..self.octaves)
            .map(|o| self.amplitude.abs() * self.gain.abs().powi(o as i32))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_bounded_seeded_and_varied() {
        let n = GradientNoise::new(7);
        let m = GradientNoise::new(7);
        let o = GradientNoise::new(8);
        let (mut lo, mut hi, mut diff) = (f64::MAX, f64::MIN, 0.0_f64);
        for i in 0..4000 {
            let (x, y) = (i as f64 * 0.137 - 200.0, i as f64 * 0.071 - 100.0);
            let v = n.get(x, y);
            assert_eq!(v.to_bits(), m.get(x, y).to_bits());
            lo = lo.min(v);
            hi = hi.max(v);
            diff = diff.max((v - o.get(x, y)).abs());
        }
        assert!((-1.0..=1.0).contains(&lo) && (-1.0..=1.0).contains(&hi));
        assert!(hi - lo > 0.8, "noise too flat: [{lo}, {hi}]");
        assert!(diff > 0.3, "another seed should give other noise");
    }

    #[test]
    fn noise_is_continuous() {
        let n = GradientNoise::new(3);
        for i in 0..1000 {
            let (x, y) = (i as f64 * 0.0173 - 5.0, i as f64 * 0.0291 - 9.0);
            // Gradient of unit-gradient noise is bounded (a few units per lattice cell).
            assert!((n.get(x, y) - n.get(x + 1e-4, y)).abs() < 1e-3);
        }
    }

    #[test]
    fn fbm_respects_its_bound() {
        let f = Fbm::new(11, 20.0, 1.5, 5);
        let b = f.bound();
        assert!((b - 1.5 * (1.0 + 0.5 + 0.25 + 0.125 + 0.0625)).abs() < 1e-12);
        for i in 0..2000 {
            let v = f.get(i as f64 * 0.31 - 300.0, i as f64 * 0.17);
            assert!(v.abs() <= b);
        }
    }
}
