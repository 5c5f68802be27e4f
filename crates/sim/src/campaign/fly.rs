//! Flying a triplet: the virtual MVS on the true mesh, with the
//! triplet-level matching gate of [`MatchingGate`].

use serde::Serialize;
use vp_scene::colmap::DepthMap;
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Material, Mesh};

use super::config::MatchingGate;
use crate::error::Result;
use crate::mvs::{PixelStatus, VirtualMvs};

/// What the gate saw of one triplet.
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

/// One reconstructed triplet.
#[derive(Debug, Clone)]
pub struct Flown {
    /// Identities of the three images (distinct images have distinct ids).
    pub ids: [u64; 3],
    /// The true cameras.
    pub cams: [Camera; 3],
    /// Depth maps (full resolution); `None` when the triplet produced nothing.
    pub depth: Option<[DepthMap; 3]>,
    /// Gate statistics.
    pub stats: GateStats,
}

impl Flown {
    /// Whether the virtual MVS produced any 3D output.
    pub fn success(&self) -> bool {
        self.depth
            .as_ref()
            .is_some_and(|d| d.iter().any(|m| m.data.iter().any(|&z| z > 0.0)))
    }
}

/// Runs the virtual MVS on `cams` at `level` and applies the gate: the
/// depth maps, or `None` when the triplet fails as a whole.
pub fn reconstruct_gated(
    mvs: &VirtualMvs,
    gate: &MatchingGate,
    mesh: &Mesh,
    caster: &RayCaster,
    cams: [&Camera; 3],
    level: u8,
    seed: u64,
) -> Result<(Option<[DepthMap; 3]>, GateStats)> {
    let views = mvs.reconstruct_with_truth(mesh, caster, cams, level, seed)?;
    let (mut overlap, mut matchable) = (0usize, 0usize);
    let mut nonflat: Vec<f32> = Vec::new();
    for v in &views {
        for t in &v.truth {
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
    }
    nonflat.sort_by(f32::total_cmp);
    let stats = GateStats {
        overlap_pixels: overlap,
        matchable_share: matchable as f64 / overlap.max(1) as f64,
        nonflat_share: nonflat.len() as f64 / overlap.max(1) as f64,
        nonflat_median_angle_deg: nonflat
            .get(nonflat.len() / 2)
            .map_or(0.0, |&a| f64::from(a)),
    };
    if !gate.passes(&stats) {
        return Ok((None, stats));
    }
    let [a, b, c] = views;
    Ok((Some([a.depth, b.depth, c.depth]), stats))
}

/// Flies one triplet at full resolution.
#[allow(clippy::too_many_arguments)]
pub fn fly_triplet(
    mvs: &VirtualMvs,
    gate: &MatchingGate,
    mesh: &Mesh,
    caster: &RayCaster,
    cams: [Camera; 3],
    ids: [u64; 3],
    seed: u64,
) -> Result<Flown> {
    let (depth, stats) = reconstruct_gated(
        mvs,
        gate,
        mesh,
        caster,
        [&cams[0], &cams[1], &cams[2]],
        1,
        seed,
    )?;
    Ok(Flown {
        ids,
        cams,
        depth,
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(matchable: f64, nonflat: f64, angle: f64) -> GateStats {
        GateStats {
            overlap_pixels: 1000,
            matchable_share: matchable,
            nonflat_share: nonflat,
            nonflat_median_angle_deg: angle,
        }
    }

    #[test]
    fn gate_fails_wide_vegetation_triplets_and_keeps_flat_ones() {
        let g = MatchingGate::default();
        // Rock at a wide angle: mostly matchable, little vegetation.
        assert!(g.passes(&stats(0.9, 0.1, 40.0)));
        // Grass seen at 35 deg: median angle over the limit.
        assert!(!g.passes(&stats(0.6, 0.5, 35.0)));
        // The same grass at 10 deg passes.
        assert!(g.passes(&stats(0.6, 0.5, 10.0)));
        // Too little matchable overlap.
        assert!(!g.passes(&stats(0.3, 0.0, 0.0)));
        // No overlap: no output, gate or not.
        let off = MatchingGate {
            enabled: false,
            ..MatchingGate::default()
        };
        assert!(off.passes(&stats(0.0, 1.0, 80.0)));
        assert!(!off.passes(&GateStats::default()));
    }
}
