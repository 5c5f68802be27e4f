//! Grass tufts: clusters of thin blade triangles, denser in patches.
//!
//! Tufts are planned in the plane first (positions and blade shapes, so the
//! face count is known before the terrain resolution is chosen), then set
//! on the meshed terrain.

use nalgebra::Point3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::noise::Fbm;
use super::terrain::TerrainGrid;
use super::Builder;
use crate::error::{Result, SceneError};
use crate::mesh::Material;

/// Mean blades per tuft (5..=9), used to size tuft counts from a face budget.
pub(crate) const MEAN_BLADES: usize = 7;
/// Blade bases sit this far below the ground so blades join the terrain.
const ROOT_DEPTH: f64 = 0.02;

/// One blade: a thin triangle from two ground points to a tip.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Blade {
    base: [[f64; 2]; 2],
    tip: [f64; 2],
    /// Tip height above the ground at the blade's root centre.
    tip_height: f64,
}

/// Plans `n_tufts` tufts over the square |x|, |y| <= `half`, away from the
/// places `excluded` names. Acceptance follows a low-frequency density
/// field: dense meadow patches, sparse elsewhere.
pub(crate) fn plan(
    rng: &mut ChaCha8Rng,
    density: &Fbm,
    n_tufts: usize,
    half: f64,
    excluded: impl Fn(f64, f64) -> bool,
) -> Result<Vec<Blade>> {
    let mut blades = Vec::with_capacity(n_tufts * MEAN_BLADES);
    let max_attempts = 100 * n_tufts + 10_000;
    let (mut placed, mut attempts) = (0, 0);
    let edge = half - 0.5;
    while placed < n_tufts {
        attempts += 1;
        if attempts > max_attempts {
            return Err(SceneError::InvalidArgument(format!(
                "could place only {placed} of {n_tufts} grass tufts on the free ground"
            )));
        }
        let x = rng.random_range(-edge..edge);
        let y = rng.random_range(-edge..edge);
        let d = density.get(x, y) / density.bound().max(1e-9); // in [-1, 1]
        let accept = 0.08 + 0.92 * smoothstep((d + 0.1) / 0.4);
        if rng.random::<f64>() >= accept || excluded(x, y) {
            continue;
        }
        tuft(rng, x, y, &mut blades);
        placed += 1;
    }
    Ok(blades)
}

fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// 5 to 9 blades leaning outward from (x, y).
fn tuft(rng: &mut ChaCha8Rng, x: f64, y: f64, blades: &mut Vec<Blade>) {
    let n = rng.random_range(5..=9);
    let radius = rng.random_range(0.04..0.12);
    for _ in 0..n {
        let a = rng.random_range(0.0..std::f64::consts::TAU);
        let r = radius * rng.random::<f64>().sqrt();
        let (bx, by) = (x + r * a.cos(), y + r * a.sin());
        // Lean roughly away from the tuft centre.
        let lean_dir = a + rng.random_range(-0.6..0.6);
        let lean: f64 = rng.random_range(0.15..0.8); // radians from vertical
        let len = rng.random_range(0.15..0.45);
        let width = rng.random_range(0.008..0.02);
        blades.push(Blade::leaning([bx, by], lean_dir, lean, len, width));
    }
}

impl Blade {
    /// A blade rooted at `root`, `width` wide at its base, `len` long,
    /// leaning `lean` radians from vertical towards heading `lean_dir`
    /// (radians from +x).
    pub(crate) fn leaning(root: [f64; 2], lean_dir: f64, lean: f64, len: f64, width: f64) -> Self {
        let [bx, by] = root;
        let (dx, dy) = (lean_dir.cos(), lean_dir.sin());
        let (px, py) = (-dy * 0.5 * width, dx * 0.5 * width);
        Blade {
            // Base order (b1, b0) makes the blade face up and inward (n.z > 0).
            base: [[bx + px, by + py], [bx - px, by - py]],
            tip: [bx + dx * len * lean.sin(), by + dy * len * lean.sin()],
            tip_height: len * lean.cos(),
        }
    }

    /// The middle of the blade's base.
    pub(crate) fn root(&self) -> [f64; 2] {
        let [[x0, y0], [x1, y1]] = self.base;
        [0.5 * (x0 + x1), 0.5 * (y0 + y1)]
    }
}

/// Blades set on the meshed terrain, one face each.
pub(crate) fn mesh(blades: &[Blade], ground: &TerrainGrid) -> Builder {
    let mut out = Builder::default();
    for b in blades {
        let [[x0, y0], [x1, y1]] = b.base;
        let [cx, cy] = b.root();
        out.triangle(
            [
                Point3::new(x0, y0, ground.height(x0, y0) - ROOT_DEPTH),
                Point3::new(x1, y1, ground.height(x1, y1) - ROOT_DEPTH),
                Point3::new(b.tip[0], b.tip[1], ground.height(cx, cy) + b.tip_height),
            ],
            Material::Grass,
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::terrain::Terrain;
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn blades_face_up_and_are_denser_in_patches() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let density = Fbm::new(6, 14.0, 1.0, 3);
        let blades = plan(&mut rng, &density, 2000, 30.0, |x, _| x > 25.0).unwrap();
        assert!(blades.len() >= 2000 * 5 && blades.len() <= 2000 * 9);
        assert!(blades.iter().all(|b| b.base[0][0] <= 25.2));
        let g = TerrainGrid::new(&Terrain::new(1), 30.0, 30, 30);
        let m = mesh(&blades, &g).finish();
        m.validate().unwrap();
        assert!(m.face_normals().iter().all(|n| n.z > 0.0));
        // Patchiness: tuft counts per 6 m cell vary a lot.
        let mut cells = [0usize; 100];
        for b in &blades {
            let i = ((b.base[0][0] + 30.0) / 6.0).clamp(0.0, 9.0) as usize;
            let j = ((b.base[0][1] + 30.0) / 6.0).clamp(0.0, 9.0) as usize;
            cells[j * 10 + i] += 1;
        }
        let max = *cells[..].iter().max().unwrap();
        let mut sorted = cells;
        sorted.sort_unstable();
        assert!(max > 4 * sorted[20].max(1), "grass not patchy: {sorted:?}");
    }
}
