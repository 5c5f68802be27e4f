//! The depth and normal map of one view, and the photometric filter that
//! turns PatchMatch's unfiltered planes into the photometric map.

use crate::params::MvsParams;

/// A depth and normal map in the reference camera frame: PatchMatch's
/// photometric result, or that result after the geometric filter.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthNormalMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Depth along the optical axis; 0 where a filter (photometric:
    /// `min_ncc`; geometric: consistency) rejected the pixel.
    pub depth: Vec<f32>,
    /// Unit normal (camera frame); zero where depth is 0.
    pub normal: Vec<[f32; 3]>,
    /// Aggregated matching cost (1 - NCC, in [0, 2]) of the winning
    /// hypothesis, kept for every pixel.
    pub cost: Vec<f32>,
}

impl DepthNormalMap {
    /// An unfiltered map with the photometric filter applied in place: a
    /// pixel whose cost exceeds `1 - min_ncc` loses its depth and normal
    /// (its cost stays).
    pub(crate) fn photometric(mut self, params: &MvsParams) -> Self {
        let max_cost = 1.0 - params.min_ncc;
        for ((d, n), &c) in self.depth.iter_mut().zip(&mut self.normal).zip(&self.cost) {
            if !(c <= max_cost) {
                *d = 0.0;
                *n = [0.0; 3];
            }
        }
        self
    }

    /// The photometric map of this unfiltered map (see
    /// [`DepthNormalMap::photometric`]), leaving only its depths behind:
    /// what the other views' geometric passes still read of it.
    pub(crate) fn take_photometric(&mut self, params: &MvsParams) -> Self {
        DepthNormalMap {
            width: self.width,
            height: self.height,
            depth: self.depth.clone(),
            normal: std::mem::take(&mut self.normal),
            cost: std::mem::take(&mut self.cost),
        }
        .photometric(params)
    }
}
