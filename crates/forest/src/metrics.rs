//! Evaluation: label accuracy and sparsification (AUSC), as in the paper's
//! KITTI experiment (after Mostegel et al. 2016).
//!
//! Sparsification: rank the labelled pixels by predicted confidence and
//! remove the least confident first. After removing k of n pixels, the error
//! rate is the share of negatives among the n - k left. The curve runs over
//! k = 0..n-1; AUSC is its mean (the area with the removed fraction on the
//! x axis). The optimal ranking removes all negatives first; a random ranking
//! keeps the error rate e = negatives / n at every k in expectation, so its
//! AUSC is e. Relative AUSC = AUSC / optimal AUSC (paper, KITTI: 3.15,
//! random 5.15). Pixels with equal confidence count in their expected order:
//! removing part of a tie removes its negatives in proportion.

use serde::{Deserialize, Serialize};
use vp_scene::raster::{Label, LabelImage, RgbImage};

use crate::error::{ForestError, Result};
use crate::lab::LabPlanes;
use crate::Forest;

/// A labelled pixel with the confidence predicted for it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scored {
    /// Predicted confidence at the pixel's own triangulation angle.
    pub confidence: f32,
    /// Whether the label is positive.
    pub positive: bool,
}

/// Share of samples whose prediction (confidence >= `threshold`) matches the label.
pub fn accuracy(samples: &[Scored], threshold: f32) -> Result<f64> {
    check(samples)?;
    let right = samples
        .iter()
        .filter(|s| (s.confidence >= threshold) == s.positive)
        .count();
    Ok(right as f64 / samples.len() as f64)
}

fn check(samples: &[Scored]) -> Result<()> {
    if samples.is_empty() {
        return Err(ForestError::InvalidInput(
            "no labelled samples to evaluate".into(),
        ));
    }
    if let Some(i) = samples.iter().position(|s| !s.confidence.is_finite()) {
        return Err(ForestError::InvalidInput(format!(
            "sample {i} has confidence {}",
            samples[i].confidence
        )));
    }
    Ok(())
}

/// Sparsification of a ranking; see the module docs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sparsification {
    /// Share of negatives among all samples, e.
    pub error_rate: f64,
    /// (fraction removed, error rate of the rest) at evenly spaced fractions.
    pub curve: Vec<(f64, f64)>,
    /// The same for the optimal ranking.
    pub optimal_curve: Vec<(f64, f64)>,
    /// Area under the curve.
    pub ausc: f64,
    /// Area under the optimal curve.
    pub optimal_ausc: f64,
    /// ausc / optimal_ausc (1 is perfect; 1 also when there is no error at all).
    pub relative_ausc: f64,
    /// Expected area of a random ranking: e.
    pub random_ausc: f64,
    /// random_ausc / optimal_ausc: the figure a useful predictor must beat.
    pub random_relative_ausc: f64,
}

/// Error rate after removing k samples, for every k in 0..n, given the
/// (expected) number of negatives removed after k removals.
fn error_rates(n: usize, negatives: f64, removed_neg: impl Fn(usize) -> f64) -> Vec<f64> {
    (0..n)
        .map(|k| ((negatives - removed_neg(k)) / (n - k) as f64).max(0.0))
        .collect()
}

fn sample_curve(err: &[f64], points: usize) -> Vec<(f64, f64)> {
    let n = err.len();
    (0..points)
        .map(|j| {
            let x = j as f64 / points as f64;
            (x, err[((x * n as f64) as usize).min(n - 1)])
        })
        .collect()
}

fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 {
        a / b
    } else {
        1.0
    }
}

/// Sparsification of `samples` ranked by confidence, with curves sampled
/// at `curve_points` fractions (0, 1/P, ..).
pub fn sparsification(samples: &[Scored], curve_points: usize) -> Result<Sparsification> {
    check(samples)?;
    let n = samples.len();
    let negatives = samples.iter().filter(|s| !s.positive).count() as f64;
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| samples[a].confidence.total_cmp(&samples[b].confidence));
    // Expected negatives removed after k removals, ties spread evenly.
    let mut removed = vec![0.0f64; n + 1];
    let mut start = 0;
    while start < n {
        let c = samples[order[start]].confidence;
        let end = start
            + order[start..]
                .iter()
                .take_while(|&&i| samples[i].confidence.total_cmp(&c).is_eq())
                .count();
        let g = (end - start) as f64;
        let q = order[start..end]
            .iter()
            .filter(|&&i| !samples[i].positive)
            .count() as f64;
        for j in 1..=end - start {
            removed[start + j] = removed[start] + q * j as f64 / g;
        }
        start = end;
    }
    let err = error_rates(n, negatives, |k| removed[k]);
    let optimal = error_rates(n, negatives, |k| (k as f64).min(negatives));
    let ausc = err.iter().sum::<f64>() / n as f64;
    let optimal_ausc = optimal.iter().sum::<f64>() / n as f64;
    let error_rate = negatives / n as f64;
    Ok(Sparsification {
        error_rate,
        curve: sample_curve(&err, curve_points.max(1)),
        optimal_curve: sample_curve(&optimal, curve_points.max(1)),
        ausc,
        optimal_ausc,
        relative_ausc: ratio(ausc, optimal_ausc),
        random_ausc: error_rate,
        random_relative_ausc: ratio(error_rate, optimal_ausc),
    })
}

impl Forest {
    /// Scores every labelled pixel of `labels` on `image`: the forest's
    /// confidence at the pixel, interpolated at the pixel's own angle as the
    /// planner reads confidence images (linear between bin centres, the last
    /// bin at or above gamma_max).
    pub fn score_labels(&self, image: &RgbImage, labels: &LabelImage) -> Result<Vec<Scored>> {
        if (labels.width(), labels.height()) != image.dimensions() {
            return Err(ForestError::InvalidInput(format!(
                "label image {}x{} does not match the image {}x{}",
                labels.width(),
                labels.height(),
                image.width(),
                image.height()
            )));
        }
        let planes = LabPlanes::from_rgb_with_complement(image);
        let labelled: Vec<_> = labels.labelled().collect();
        let pixels: Vec<(u32, u32)> = labelled.iter().map(|&(x, y, _, _)| (x, y)).collect();
        let values = self.predict_pixels(&planes, &pixels)?;
        let b = self.bins().len();
        Ok(labelled
            .iter()
            .zip(values.chunks_exact(b))
            .map(|(&(_, _, label, angle), v)| Scored {
                confidence: self.bins().interpolate(v, f64::from(angle)),
                positive: label == Label::Positive,
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_set(n: usize, e: f64, seed: u64) -> Vec<Scored> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| Scored {
                confidence: rng.random(),
                positive: rng.random::<f64>() >= e,
            })
            .collect()
    }

    #[test]
    fn perfect_ranking_reaches_the_optimum() {
        let mut s = random_set(5000, 0.3, 1);
        for x in &mut s {
            x.confidence = if x.positive {
                0.5 + x.confidence / 2.0
            } else {
                x.confidence / 2.0
            };
        }
        let sp = sparsification(&s, 20).unwrap();
        assert!((sp.ausc - sp.optimal_ausc).abs() < 1e-12);
        assert!((sp.relative_ausc - 1.0).abs() < 1e-9);
        assert!((accuracy(&s, 0.5).unwrap() - 1.0).abs() < 1e-12);
        // Closed form of the continuous optimum: e + (1 - e) ln(1 - e).
        let e = sp.error_rate;
        assert!((sp.optimal_ausc - (e + (1.0 - e) * (1.0 - e).ln())).abs() < 1e-3);
        assert_eq!(sp.curve.len(), 20);
        assert!((sp.curve[0].1 - e).abs() < 1e-12);
    }

    #[test]
    fn random_ranking_matches_the_random_figure() {
        let s = random_set(200_000, 0.35, 2);
        let sp = sparsification(&s, 10).unwrap();
        assert!(
            (sp.ausc - sp.random_ausc).abs() < 0.01,
            "{} vs {}",
            sp.ausc,
            sp.random_ausc
        );
        assert!((sp.relative_ausc / sp.random_relative_ausc - 1.0).abs() < 0.03);
        // With e = 0.35 the random figure is near the paper's KITTI 5.15.
        assert!(
            (sp.random_relative_ausc - 5.0).abs() < 0.3,
            "{}",
            sp.random_relative_ausc
        );
        assert!((accuracy(&s, 0.5).unwrap() - 0.5).abs() < 0.01);
    }

    #[test]
    fn all_equal_confidences_count_as_random() {
        let mut s = random_set(1000, 0.2, 3);
        for x in &mut s {
            x.confidence = 0.7;
        }
        let sp = sparsification(&s, 4).unwrap();
        assert!((sp.ausc - sp.error_rate).abs() < 1e-12);
    }

    #[test]
    fn inverted_ranking_is_worse_than_random_and_bad_input_errors() {
        let mut s = random_set(2000, 0.3, 4);
        for x in &mut s {
            x.confidence = if x.positive { 0.0 } else { 1.0 };
        }
        let sp = sparsification(&s, 4).unwrap();
        assert!(sp.relative_ausc > sp.random_relative_ausc);
        assert!(sparsification(&[], 4).is_err());
        assert!(accuracy(
            &[Scored {
                confidence: f32::NAN,
                positive: true
            }],
            0.5
        )
        .is_err());
        let none_wrong = vec![
            Scored {
                confidence: 0.2,
                positive: true
            };
            10
        ];
        assert!((sparsification(&none_wrong, 4).unwrap().relative_ausc - 1.0).abs() < 1e-12);
    }
}
