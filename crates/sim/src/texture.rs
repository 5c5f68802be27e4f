//! Procedural solid textures per material.
//!
//! Albedo is a pure function of the material and the 3D world point, so every
//! view of a surface point sees the same texture: what the forest learns from
//! one image transfers to the next. The texture statistics follow what makes
//! dense matching easy or hard in the paper's domain: rock with the 1/f
//! spectrum of natural images at every scale, earthy ground at mid
//! frequencies, grass and leaves with high-frequency high-contrast texture
//! (whose look changes between views: the geometry is thin and occludes
//! itself), black and white checker markers.

use nalgebra::Point3;
use vp_scene::Material;

use crate::noise::{fbm, fbm_gain, hash3, unit};

/// Side of one checker cell of a marker plate, metres (4 x 4 cells on the
/// 0.5 m plates of vp-scene's sites).
pub const MARKER_CELL: f64 = 0.125;

/// Linear RGB albedo in [0, 1].
pub type Rgb = [f32; 3];

/// Per-material seed offsets so that materials do not share noise.
const SEED_ROCK: u64 = 0x726f_636b;
const SEED_GROUND: u64 = 0x6772_6f75;
const SEED_GRASS: u64 = 0x6772_6173;
const SEED_TREE: u64 = 0x7472_6565;

/// Albedo of `material` at world point `p`; `seed` varies the textures
/// between worlds.
pub fn albedo(material: Material, p: &Point3<f64>, seed: u64) -> Rgb {
    let q = [p.x, p.y, p.z];
    match material {
        Material::Rock => rock(q, seed ^ SEED_ROCK),
        Material::Ground => ground(q, seed ^ SEED_GROUND),
        Material::Grass => foliage(q, seed ^ SEED_GRASS, [0.22, 0.46, 0.12], 0.04),
        Material::Tree => foliage(q, seed ^ SEED_TREE, [0.18, 0.38, 0.11], 0.05),
        Material::Marker => marker(q),
    }
}

fn scale(c: [f32; 3], s: f64) -> Rgb {
    c.map(|v| (f64::from(v) * s).clamp(0.0, 1.0) as f32)
}

fn mix(a: [f32; 3], b: [f32; 3], t: f64) -> Rgb {
    let t = t.clamp(0.0, 1.0) as f32;
    [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t)
}

/// Grey-beige stone with the spectrum of a photo of rock: 1/f^alpha
/// amplitude (alpha about 1.2, gain 0.85 per octave) from 4 m patches down
/// to 1.6 cm grain (9 octaves), plus 1 cm speckle. An earlier rock had
/// energy only above 1 m and at 1 cm: flat at every ground sampling
/// distance a drone flies, which no real rock is.
fn rock(q: [f64; 3], seed: u64) -> Rgb {
    let low = fbm_gain(seed, q, 4.0, 9, 0.85);
    let tint = fbm(seed ^ 1, q, 4.0, 1);
    // Speckle on a 1 cm lattice: a little grain, far below the grass contrast.
    let cell = q.map(|v| (v * 100.0).floor() as i64);
    let speckle = unit(hash3(seed ^ 2, cell[0], cell[1], cell[2])) - 0.5;
    let base = mix([0.56, 0.53, 0.49], [0.50, 0.47, 0.44], 0.5 + 0.5 * tint);
    scale(base, 1.0 + 1.5 * low + 0.03 * speckle)
}

/// Brown earth with mid-frequency mottling, darker patches and soil grain.
fn ground(q: [f64; 3], seed: u64) -> Rgb {
    let mid = fbm(seed, q, 0.25, 3);
    let patches = fbm(seed ^ 1, q, 2.5, 1);
    let cell = q.map(|v| (v * 66.0).floor() as i64);
    let grain = unit(hash3(seed ^ 2, cell[0], cell[1], cell[2])) - 0.5;
    let base = mix([0.44, 0.34, 0.22], [0.30, 0.26, 0.18], 0.5 + 0.8 * patches);
    scale(base, 1.0 + 0.4 * mid + 0.16 * grain)
}

/// Leaves and blades: strong contrast at a few centimetres, hue drifting
/// between green and straw.
fn foliage(q: [f64; 3], seed: u64, green: [f32; 3], wavelength: f64) -> Rgb {
    let hi = fbm(seed, q, wavelength, 2);
    let hue = fbm(seed ^ 1, q, 1.5, 1);
    let base = mix(green, [0.52, 0.50, 0.20], 0.3 + 0.6 * hue);
    scale(base, 1.0 + 0.85 * hi)
}

/// Black and white checker in world x, y.
fn marker(q: [f64; 3]) -> Rgb {
    let parity = ((q[0] / MARKER_CELL).floor() as i64 + (q[1] / MARKER_CELL).floor() as i64) & 1;
    if parity == 0 {
        [0.9, 0.9, 0.9]
    } else {
        [0.04, 0.04, 0.04]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mean absolute difference of the green channel between points `step` apart.
    fn roughness(m: Material, step: f64) -> f64 {
        let n = 4000;
        (0..n)
            .map(|i| {
                let p = Point3::new(i as f64 * 0.37, (i % 50) as f64 * 0.53, 1.0);
                let q = Point3::new(p.x + step, p.y, p.z);
                f64::from((albedo(m, &p, 1)[1] - albedo(m, &q, 1)[1]).abs())
            })
            .sum::<f64>()
            / f64::from(n)
    }

    #[test]
    fn foliage_is_rougher_than_rock_at_pixel_scale() {
        let rock = roughness(Material::Rock, 0.03);
        let grass = roughness(Material::Grass, 0.03);
        let tree = roughness(Material::Tree, 0.03);
        assert!(
            grass > 2.0 * rock && tree > 2.0 * rock && rock > 0.01,
            "rock {rock} grass {grass} tree {tree}"
        );
    }

    #[test]
    fn albedo_is_a_function_of_the_point() {
        let p = Point3::new(1.234, -5.6, 0.7);
        for m in Material::ALL {
            assert_eq!(
                albedo(m, &p, 9).map(f32::to_bits),
                albedo(m, &p, 9).map(f32::to_bits)
            );
            assert!(albedo(m, &p, 9).iter().all(|v| (0.0..=1.0).contains(v)));
        }
    }
}
