//! Learned confidence against what the MVS measurably did, per material and
//! angle bin (the paper's Fig. 4), and the Spearman rank correlation between
//! them.
//!
//! Measured: over a set of triplets, the pixels all three cameras see,
//! binned by their triangulation angle; the share whose depth is within the
//! uncertainty bound of the true depth (`k_sigma` sigma, as a positive label
//! claims). Two sets, reported side by side (issue 34, item 7): the flown
//! triplets (the planners chose them, so they lean toward the angles each
//! planner favoured), and a fixed random set on each held-out site that no
//! planner chose, the same for every strategy (out of sample: neither
//! trained on nor planned; see [`super::training::measure_out_of_sample`]).
//! Learned: the forest's mean predicted confidence per bin over the
//! held-out images' pixels of the material.

use serde::Serialize;
use vp_scene::raster::{AngleBins, ConfidenceImage};
use vp_scene::Material;

use crate::render::Rendered;

/// Running sums of learned and measured confidence per material and bin.
#[derive(Debug, Clone)]
pub struct CurveAccumulator {
    bins: AngleBins,
    /// Per material, per bin: (learned sum, learned count).
    learned: Vec<Vec<(f64, u64)>>,
    /// Per material, per bin: (reconstructed within the bound, visible).
    measured: Vec<Vec<(u64, u64)>>,
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
    /// Measured share of reconstructed pixels per bin (NaN for a bin
    /// without measured pixels).
    pub measured: Vec<f64>,
    /// Measured pixels per bin.
    pub measured_pixels: Vec<u64>,
    /// The same measured on the fixed random triplets no planner chose
    /// (NaN for a bin without pixels; all NaN when no random set was flown).
    pub measured_random: Vec<f64>,
    /// Their pixels per bin.
    pub measured_random_pixels: Vec<u64>,
    /// Grid nodes averaged for `learned`.
    pub samples: u64,
    /// Spearman rank correlation of `learned` and `measured` over the bins
    /// with measured pixels.
    pub spearman: f64,
    /// The same against `measured_random`.
    pub spearman_random: f64,
}

impl CurveAccumulator {
    /// Nothing accumulated, over `bins` (the forest's angle bins).
    pub fn new(bins: AngleBins) -> Self {
        let n = bins.len();
        CurveAccumulator {
            bins,
            learned: vec![vec![(0.0, 0); n]; Material::ALL.len()],
            measured: vec![vec![(0, 0); n]; Material::ALL.len()],
        }
    }

    /// Adds the grid nodes of one predicted image: the material under each
    /// node comes from the render. A confidence image with other bins is
    /// refused (it would mix curves).
    pub fn add_learned(&mut self, img: &Rendered, mesh: &vp_scene::Mesh, conf: &ConfidenceImage) {
        if conf.bins() != &self.bins {
            return;
        }
        let (gw, gh) = conf.grid_size();
        for j in 0..gh {
            for i in 0..gw {
                let (x, y) = conf.node_pixel(i, j);
                let Some(m) = img.material(mesh, x, y) else {
                    continue;
                };
                let node = conf.node(i, j);
                for (b, s) in self.learned[m as usize].iter_mut().enumerate() {
                    s.0 += f64::from(node[b]);
                    s.1 += 1;
                }
            }
        }
    }

    /// Adds one pixel of a triplet that all three cameras see.
    pub fn add_measured(&mut self, material: Material, angle_deg: f32, reconstructed: bool) {
        if let Some(b) = self.bins.bin_of(angle_deg) {
            let s = &mut self.measured[material as usize][b];
            s.0 += u64::from(reconstructed);
            s.1 += 1;
        }
    }

    /// What was measured, one row per material and bin with pixels, tagged
    /// with `site` (an accumulator per site gives the per-site rows).
    pub fn measured_rows(&self, site: u64) -> Vec<super::angle_fall::SiteSuccess> {
        Material::ALL
            .iter()
            .zip(&self.measured)
            .flat_map(|(&material, per_bin)| {
                per_bin
                    .iter()
                    .enumerate()
                    .filter(|(_, b)| b.1 > 0)
                    .map(move |(bin, b)| super::angle_fall::SiteSuccess {
                        site,
                        material,
                        bin,
                        visible: b.1,
                        reconstructed: b.0,
                    })
            })
            .collect()
    }

    /// The curves of every material with learned samples, without a
    /// random set.
    pub fn curves(&self) -> Vec<ConfidenceCurve> {
        self.curves_with(None)
    }

    /// The curves of every material with learned samples; `random`: the
    /// measurements of the random triplets no planner chose.
    pub fn curves_with(&self, random: Option<&CurveAccumulator>) -> Vec<ConfidenceCurve> {
        let share = |b: &(u64, u64)| {
            if b.1 > 0 {
                b.0 as f64 / b.1 as f64
            } else {
                f64::NAN
            }
        };
        let centres: Vec<f64> = (0..self.bins.len())
            .map(|b| f64::from(self.bins.centre(b)))
            .collect();
        Material::ALL
            .iter()
            .zip(self.learned.iter().zip(&self.measured))
            .filter(|(_, (l, _))| l.first().is_some_and(|b| b.1 > 0))
            .map(|(m, (l, meas))| {
                let learned: Vec<f64> = l.iter().map(|b| b.0 / b.1 as f64).collect();
                let measured: Vec<f64> = meas.iter().map(share).collect();
                let empty = vec![(0, 0); meas.len()];
                let rand = random.map_or(&empty, |r| &r.measured[*m as usize]);
                let measured_random: Vec<f64> = rand.iter().map(share).collect();
                ConfidenceCurve {
                    material: m.name().to_string(),
                    angle_deg: centres.clone(),
                    spearman: spearman_finite(&learned, &measured),
                    spearman_random: spearman_finite(&learned, &measured_random),
                    learned,
                    measured,
                    measured_pixels: meas.iter().map(|b| b.1).collect(),
                    measured_random,
                    measured_random_pixels: rand.iter().map(|b| b.1).collect(),
                    samples: l[0].1,
                }
            })
            .collect()
    }
}

/// Spearman rank correlation of `learned` and `measured` over the bins
/// where `measured` has pixels (is finite).
fn spearman_finite(learned: &[f64], measured: &[f64]) -> f64 {
    let (a, b): (Vec<f64>, Vec<f64>) = learned
        .iter()
        .zip(measured)
        .filter(|(_, m)| m.is_finite())
        .map(|(l, m)| (*l, *m))
        .unzip();
    spearman(&a, &b)
}

/// Per angle bin, the Spearman rank correlation between the learned and the
/// measured confidence across materials: whether the forest ranks materials
/// (rock above grass, ...) as the MVS's measured behaviour does. (angle,
/// rho) pairs; materials without measured pixels in a bin are left out.
/// Measured on the flown triplets; [`material_ranking_random`] on the
/// random set.
pub fn material_ranking(curves: &[ConfidenceCurve]) -> Vec<(f64, f64)> {
    ranking_by(curves, |c| &c.measured)
}

/// [`material_ranking`] against the random triplets no planner chose.
pub fn material_ranking_random(curves: &[ConfidenceCurve]) -> Vec<(f64, f64)> {
    ranking_by(curves, |c| &c.measured_random)
}

fn ranking_by(
    curves: &[ConfidenceCurve],
    measured: fn(&ConfidenceCurve) -> &Vec<f64>,
) -> Vec<(f64, f64)> {
    let Some(first) = curves.first() else {
        return Vec::new();
    };
    (0..first.angle_deg.len())
        .map(|b| {
            let (l, t): (Vec<f64>, Vec<f64>) = curves
                .iter()
                .filter(|c| measured(c)[b].is_finite())
                .map(|c| (c.learned[b], measured(c)[b]))
                .unzip();
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
