//! The virtual MVS's triplet gate (`mvs = "virtual"` only): what it saw of
//! a triplet and whether the triplet produces output.

use serde::Serialize;
use vp_scene::Material;

use crate::config::MatchingGate;
use crate::virtual_mvs::{PixelStatus, PixelTruth};

/// What the gate saw of one triplet (virtual MVS only).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct GateStats {
    /// Pixels (over the three images) whose surface point all three see.
    pub overlap_pixels: usize,
    /// Share of them with success probability >= the gate's threshold.
    pub matchable_share: f64,
    /// Share of them on non-flat materials (grass, trees).
    pub nonflat_share: f64,
    /// Median triangulation angle of the non-flat ones, degrees (0 if none).
    pub nonflat_median_angle_deg: f64,
}

impl MatchingGate {
    /// Whether a triplet with these statistics produces any output.
    pub fn passes(&self, s: &GateStats) -> bool {
        if s.overlap_pixels == 0 {
            return false;
        }
        if !self.enabled {
            return true;
        }
        if s.matchable_share < self.min_matchable_share {
            return false;
        }
        !(s.nonflat_share >= self.nonflat_min_share
            && s.nonflat_median_angle_deg > self.max_nonflat_median_angle_deg)
    }
}

/// The gate's statistics of a virtual triplet.
pub(super) fn gate_stats(truth: &[&[PixelTruth]; 3], gate: &MatchingGate) -> GateStats {
    let (mut overlap, mut matchable) = (0usize, 0usize);
    let mut nonflat: Vec<f32> = Vec::new();
    for t in truth.iter().flat_map(|v| v.iter()) {
        if !matches!(
            t.status,
            PixelStatus::Failed | PixelStatus::Reconstructed | PixelStatus::Outlier
        ) {
            continue;
        }
        overlap += 1;
        if f64::from(t.probability) >= gate.matchable_probability {
            matchable += 1;
        }
        if matches!(t.material, Some(Material::Grass | Material::Tree)) {
            nonflat.push(t.angle_deg);
        }
    }
    nonflat.sort_by(f32::total_cmp);
    GateStats {
        overlap_pixels: overlap,
        matchable_share: matchable as f64 / overlap.max(1) as f64,
        nonflat_share: nonflat.len() as f64 / overlap.max(1) as f64,
        nonflat_median_angle_deg: nonflat
            .get(nonflat.len() / 2)
            .map_or(0.0, |&a| f64::from(a)),
    }
}
