//! M3's potential gains: the best fulfillment of a hypothetical
//! equilateral triplet at a surrogate facing a linked triangle (M2 evaluates
//! it once per link), and g_pot = max(0, that - f(t)) per surrogate.

use nalgebra::Point3;
use rayon::prelude::*;
use vp_scene::Camera;

use super::{frame, half_cone, Search, AZIMUTHS_DEG};
use crate::fulfillment::Fulfillment;
use crate::quality::ConfCurve;

/// Geometry of the hypothetical equilateral triplet of one bin.
struct BinGeometry {
    /// Bin index and centre angle, degrees.
    bin: usize,
    sin_b: f64,
    cos_b: f64,
    /// `cos_b^2`: camera distance d / cos_b squared is `d^2 / cos2_b`.
    cos2_b: f64,
    /// `sqrt(f^2 cos2_b min(3 s2, 3 - 1.5 s2)) / sigma`: sqrt of the smallest
    /// information eigenvalue times the focus distance d.
    sqrt_info_d: f64,
}

/// The best fulfillment over the bins of the hypothetical equilateral triplet
/// centred at a surrogate, facing a triangle, with the bin-centre angle at
/// it (M3 g_pot without the `- f(t)`, which is the same for every bin). It
/// depends on the acquired cameras only, so M2 evaluates it once per link.
///
/// The cameras look straight at t, where the information of each is
/// `(f/D)^2 (I - u u^T) / sigma^2`; for the symmetric triplet the smallest
/// eigenvalue of the sum is `min(3 k sin^2 b, k (3 - 1.5 sin^2 b))`,
/// `k = f^2 / (sigma D)^2`, b the half-cone angle. Confidence comes from
/// the acquired image closest to the surrogate among those observing t.
pub struct Potential<'a> {
    ful: &'a Fulfillment,
    focal: f64,
    bins: Vec<BinGeometry>,
    azimuths: [(f64, f64); 3],
    one: ConfCurve,
    /// Centres of the acquired cameras (the closest-image rule reads them per link).
    centres: Vec<Point3<f64>>,
    /// Per sampled triangle: true when all its acquired curves are equal
    /// (always without prediction), so the closest image need not be found.
    uniform: Vec<bool>,
}

impl<'a> Potential<'a> {
    /// Precomputes the per-bin geometry for cameras of focal length `focal` px.
    pub fn new(ful: &'a Fulfillment, focal: f64) -> Self {
        let req = &ful.req;
        let bins = (0..req.bins.len())
            .map(|bin| {
                let gamma = f64::from(req.bins.centre(bin)).to_radians();
                let (sin_b, cos_b) = half_cone(gamma).sin_cos();
                let s2 = sin_b * sin_b;
                let cos2_b = cos_b * cos_b;
                let info = focal * focal * cos2_b * (3.0 * s2).min(3.0 - 1.5 * s2);
                BinGeometry {
                    bin,
                    sin_b,
                    cos_b,
                    cos2_b,
                    sqrt_info_d: info.sqrt() / ful.sigma_px,
                }
            })
            .collect();
        Potential {
            ful,
            focal,
            bins,
            azimuths: AZIMUTHS_DEG.map(|a| a.to_radians().sin_cos()),
            one: ConfCurve::one(&req.bins),
            centres: ful.cameras.iter().map(Camera::center).collect(),
            uniform: ful
                .acquired_curves
                .iter()
                .map(|c| c.windows(2).all(|w| w[0].1 == w[1].1))
                .collect(),
        }
    }

    /// The value for surrogate position `s` and sampled triangle `t`.
    pub fn value(&self, s: &Point3<f64>, t: usize) -> f64 {
        let (ful, req) = (self.ful, &self.ful.req);
        let tri = &ful.tris[t];
        let to = s - tri.centroid;
        let d = to.norm();
        if !(d > 0.0) {
            return 0.0;
        }
        let w = to / d;
        let (e1, e2) = frame(&-w);
        let curves = &ful.acquired_curves[t];
        let curve = if self.uniform[t] {
            curves.first().map_or(&self.one, |x| &x.1)
        } else {
            curves
                .iter()
                .map(|x| ((self.centres[x.0 as usize] - s).norm_squared(), x.0, &x.1))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
                .map_or(&self.one, |x| x.2)
        };
        // n . u for u = w cos b + (e1 cos a + e2 sin a) sin b.
        let (nw, n1, n2) = (tri.normal.dot(&w), tri.normal.dot(&e1), tri.normal.dot(&e2));
        let ring_min = self
            .azimuths
            .iter()
            .map(|(sa, ca)| n1 * ca + n2 * sa)
            .fold(f64::INFINITY, f64::min);
        let (f2, d_sq) = (self.focal * self.focal, d * d);
        let mut best = 0.0f64;
        for g in &self.bins {
            let cos_min = nw * g.cos_b + ring_min * g.sin_b;
            let r_min = (f2 * cos_min * g.cos2_b / d_sq).max(0.0);
            let f_unc = (req.accuracy * g.sqrt_info_d / d).min(1.0);
            let q = req.alpha * req.f_res(r_min) + (1.0 - req.alpha) * f_unc;
            // At a bin centre the interpolated curve is the bin's own value.
            best = best.max(q * f64::from(curve.0[g.bin]));
        }
        best
    }
}

impl Search<'_> {
    /// g_pot(t) for surrogate `s` (index) and selected triangle `ti` (index
    /// into `selected`): `max(0, best - f(t))` with the precomputed best
    /// hypothetical fulfillment (see [`Potential::value`]).
    pub(super) fn potential_gain(&self, best: f64, t: usize) -> f64 {
        if self.ful.observers[t].len() + 3 < self.ful.min_cameras {
            return 0.0;
        }
        (best - self.ful.f(t)).max(0.0)
    }

    /// Potential gains per surrogate (aligned with `links`), from the best
    /// hypothetical fulfillment of each link ([`Search::run`]'s arguments).
    pub(super) fn potential_gains(
        &self,
        links: &[Vec<u32>],
        potential: &[Vec<f64>],
    ) -> Vec<Vec<f64>> {
        potential
            .par_iter()
            .zip(links)
            .map(|(best, links)| {
                links
                    .iter()
                    .zip(best)
                    .map(|(&ti, &b)| self.potential_gain(b, self.selected[ti as usize]))
                    .collect()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::super::{frame, half_cone, AZIMUTHS_DEG};

    #[test]
    fn half_cone_gives_the_bin_angle() {
        for gamma in [2.5f64, 22.5, 42.5] {
            let beta = half_cone(gamma.to_radians());
            let w = Vector3::z();
            let (e1, e2) = frame(&-w);
            let u: Vec<Vector3<f64>> = AZIMUTHS_DEG
                .iter()
                .map(|a| {
                    let (sa, ca) = a.to_radians().sin_cos();
                    w * beta.cos() + (e1 * ca + e2 * sa) * beta.sin()
                })
                .collect();
            let got = vp_scene::triangulation::largest_pairwise_angle_deg(&u);
            assert!((got - gamma).abs() < 1e-9, "{got} vs {gamma}");
        }
    }
}
