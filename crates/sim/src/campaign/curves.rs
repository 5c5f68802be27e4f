//! Learned confidence against the simulator's truth, per material and angle
//! bin (the paper's Fig. 4), and the Spearman rank correlation between them.

use serde::Serialize;
use vp_scene::raster::ConfidenceImage;
use vp_scene::{Camera, Material, Mesh};

use crate::mvs::MvsProfile;
use crate::render::Rendered;

/// Running sums of learned and true confidence per material and bin.
#[derive(Debug, Clone, Default)]
pub struct CurveAccumulator {
    /// Bin centres, degrees (set by the first image).
    centres: Vec<f64>,
    /// Per material, per bin: (learned sum, truth sum, count).
    sums: Vec<Vec<(f64, f64, u64)>>,
}

/// One material's curves.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfidenceCurve {
    /// Material name.
    pub material: String,
    /// Bin centres, degrees.
    pub angle_deg: Vec<f64>,
    /// Mean predicted confidence of the material's pixels per bin.
    pub learned: Vec<f64>,
    /// Mean true success probability (profile, at each pixel's resolution) per bin.
    pub truth: Vec<f64>,
    /// Grid nodes averaged.
    pub samples: u64,
    /// Spearman rank correlation of `learned` and `truth` over the bins.
    pub spearman: f64,
}

impl CurveAccumulator {
    /// Adds the grid nodes of one predicted image: the material and
    /// resolution under each node come from the render.
    pub fn add(
        &mut self,
        mesh: &Mesh,
        cam: &Camera,
        img: &Rendered,
        conf: &ConfidenceImage,
        profile: &MvsProfile,
    ) {
        let bins = conf.bins();
        if self.centres.is_empty() {
            self.centres = (0..bins.len()).map(|b| f64::from(bins.centre(b))).collect();
            self.sums = vec![vec![(0.0, 0.0, 0); bins.len()]; Material::ALL.len()];
        }
        if self.centres.len() != bins.len() {
            return;
        }
        let (gw, gh) = conf.grid_size();
        let w = img.depth.width as usize;
        for j in 0..gh {
            for i in 0..gw {
                let (x, y) = conf.node_pixel(i, j);
                let Some(m) = img.material(mesh, x, y) else {
                    continue;
                };
                let depth = f64::from(img.depth.data[y as usize * w + x as usize]);
                let gsd = depth / cam.intrinsics.focal();
                let node = conf.node(i, j);
                for (b, s) in self.sums[m as usize].iter_mut().enumerate() {
                    s.0 += f64::from(node[b]);
                    s.1 += profile.success_probability(m, self.centres[b], Some(gsd));
                    s.2 += 1;
                }
            }
        }
    }

    /// The curves of every material with samples.
    pub fn curves(&self) -> Vec<ConfidenceCurve> {
        Material::ALL
            .iter()
            .zip(&self.sums)
            .filter(|(_, s)| s.first().is_some_and(|b| b.2 > 0))
            .map(|(m, s)| {
                let n = s[0].2 as f64;
                let learned: Vec<f64> = s.iter().map(|b| b.0 / n).collect();
                let truth: Vec<f64> = s.iter().map(|b| b.1 / n).collect();
                ConfidenceCurve {
                    material: m.name().to_string(),
                    angle_deg: self.centres.clone(),
                    spearman: spearman(&learned, &truth),
                    learned,
                    truth,
                    samples: s[0].2,
                }
            })
            .collect()
    }
}

/// Per angle bin, the Spearman rank correlation between the learned and the
/// true confidence across materials: whether the forest ranks materials
/// (rock above grass, ...) as the simulator's truth does. (angle, rho) pairs.
pub fn material_ranking(curves: &[ConfidenceCurve]) -> Vec<(f64, f64)> {
    let Some(first) = curves.first() else {
        return Vec::new();
    };
    (0..first.angle_deg.len())
        .map(|b| {
            let l: Vec<f64> = curves.iter().map(|c| c.learned[b]).collect();
            let t: Vec<f64> = curves.iter().map(|c| c.truth[b]).collect();
            (first.angle_deg[b], spearman(&l, &t))
        })
        .collect()
}

/// Ranks with ties averaged (1-based).
fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && v[idx[j + 1]].total_cmp(&v[idx[i]]).is_eq() {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = avg;
        }
        i = j + 1;
    }
    r
}

/// Spearman rank correlation (Pearson of the ranks); 0 when either side is constant.
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let (ra, rb) = (ranks(a), ranks(b));
    let n = ra.len() as f64;
    if n < 2.0 {
        return 0.0;
    }
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa == 0.0 || sbb == 0.0 {
        return 0.0;
    }
    sab / (saa * sbb).sqrt()
}

#[cfg(test)]
mod tests {
    use super::spearman;

    #[test]
    fn spearman_is_one_for_monotone_pairs_and_minus_one_reversed() {
        let a = [0.9, 0.8, 0.5, 0.1];
        assert!((spearman(&a, &[10.0, 7.0, 3.0, 1.0]) - 1.0).abs() < 1e-12);
        assert!((spearman(&a, &[1.0, 3.0, 7.0, 10.0]) + 1.0).abs() < 1e-12);
        assert!(spearman(&a, &[1.0; 4]).abs() < 1e-12);
        // Ties take the mean rank.
        let s = spearman(&[1.0, 2.0, 2.0, 3.0], &[1.0, 2.0, 3.0, 4.0]);
        assert!(s > 0.9 && s < 1.0, "{s}");
    }
}
