//! Triangulation-angle bins: what ties label images (one angle per pixel)
//! to confidence images (one value per bin).

use serde::{Deserialize, Serialize};

use crate::error::{Result, SceneError};

/// Triangulation-angle bins in degrees: b bins given by b + 1 increasing edges.
/// The paper's default is 9 bins of 5 deg over [0, gamma_max = 45).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<f32>", into = "Vec<f32>")]
pub struct AngleBins {
    edges: Vec<f32>,
}

impl AngleBins {
    /// Bins from explicit edges: at least two, finite, non-negative, strictly increasing.
    pub fn new(edges: Vec<f32>) -> Result<Self> {
        let ok = edges.len() >= 2
            && edges.iter().all(|e| e.is_finite() && *e >= 0.0)
            && edges.windows(2).all(|w| w[0] < w[1]);
        if !ok {
            return Err(SceneError::InvalidArgument(format!(
                "angle bin edges must be at least two finite, non-negative, strictly increasing degrees, got {edges:?}"
            )));
        }
        Ok(AngleBins { edges })
    }

    /// `count` bins of equal width over [0, `gamma_max_deg`).
    pub fn uniform(count: usize, gamma_max_deg: f32) -> Result<Self> {
        if count == 0 {
            return Err(SceneError::InvalidArgument("zero angle bins".into()));
        }
        let edges = (0..=count)
            .map(|i| gamma_max_deg * i as f32 / count as f32)
            .collect();
        Self::new(edges)
    }

    /// The paper's bins: 9 bins of 5 deg over [0, 45).
    pub fn paper() -> Self {
        AngleBins {
            edges: (0..=9u8).map(|i| 5.0 * f32::from(i)).collect(),
        }
    }

    /// Number of bins b.
    pub fn len(&self) -> usize {
        self.edges.len() - 1
    }

    /// Always false: there is at least one bin.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The b + 1 edges in degrees.
    pub fn edges(&self) -> &[f32] {
        &self.edges
    }

    /// The last edge, gamma_max: angles at or above it fall in no bin.
    pub fn gamma_max(&self) -> f32 {
        self.edges[self.edges.len() - 1]
    }

    /// Centre of bin `i` in degrees.
    pub fn centre(&self, i: usize) -> f32 {
        0.5 * (self.edges[i] + self.edges[i + 1])
    }

    /// The bin holding `angle_deg`; `None` below the first edge, at or above
    /// gamma_max, or for NaN.
    pub fn bin_of(&self, angle_deg: f32) -> Option<usize> {
        if !(angle_deg >= self.edges[0] && angle_deg < self.gamma_max()) {
            return None;
        }
        // Bins are few (9 by default): a linear scan beats a binary search.
        self.edges[1..].iter().position(|&e| angle_deg < e)
    }

    /// Interpolation in angle as [`ConfidenceImage::sample`] uses it: the two
    /// bins to blend and the weight of the second. Linear between bin centres;
    /// below the first centre the first bin, from the last centre on (also at
    /// or above gamma_max) the last bin. `None` for a NaN angle.
    pub fn interpolation(&self, angle_deg: f64) -> Option<(usize, usize, f32)> {
        if angle_deg.is_nan() {
            return None;
        }
        let b = self.len();
        if angle_deg <= f64::from(self.centre(0)) {
            return Some((0, 0, 0.0));
        }
        for i in 0..b - 1 {
            let (c0, c1) = (f64::from(self.centre(i)), f64::from(self.centre(i + 1)));
            if angle_deg < c1 {
                return Some((i, i + 1, ((angle_deg - c0) / (c1 - c0)) as f32));
            }
        }
        Some((b - 1, b - 1, 0.0))
    }

    /// Interpolates per-bin values (one per bin) at `angle_deg`, as
    /// [`AngleBins::interpolation`] describes; NaN for a NaN angle.
    pub fn interpolate(&self, per_bin: &[f32], angle_deg: f64) -> f32 {
        match self.interpolation(angle_deg) {
            Some((i0, i1, t)) => per_bin[i0] + t * (per_bin[i1] - per_bin[i0]),
            None => f32::NAN,
        }
    }
}

impl Default for AngleBins {
    fn default() -> Self {
        Self::paper()
    }
}

impl TryFrom<Vec<f32>> for AngleBins {
    type Error = SceneError;
    fn try_from(edges: Vec<f32>) -> Result<Self> {
        Self::new(edges)
    }
}

impl From<AngleBins> for Vec<f32> {
    fn from(bins: AngleBins) -> Self {
        bins.edges
    }
}
