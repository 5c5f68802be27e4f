//! Which images each image is matched against when no sparse points say
//! which see the same surface: the cameras whose frusta overlap most.

use vp_scene::triangulation::triangulation_angle_deg;
use vp_scene::Camera;

use crate::params::MvsParams;

/// Source images of each of `cameras` when no sparse points tell which
/// images see the same surface (an in-memory image set, a workspace without
/// points): the cameras whose frustum covers most of the reference's,
/// sampled at three depths of its range `ranges[r]`, with at least the
/// minimum triangulation angle at mid range; at most `max_sources`, best first.
pub fn frustum_sources(
    cameras: &[Camera],
    ranges: &[(f64, f64)],
    params: &MvsParams,
) -> Vec<Vec<usize>> {
    (0..cameras.len())
        .map(|r| {
            let scored = (0..cameras.len()).filter(|&s| s != r).map(|s| {
                let score = frustum_overlap(
                    &cameras[r],
                    &cameras[s],
                    ranges[r],
                    params.min_triangulation_angle_deg,
                );
                (score, s)
            });
            best_sources(scored, params.max_sources)
        })
        .collect()
}

/// The `max` best-scored sources (score > 0), best first, ties by index.
pub(crate) fn best_sources(scored: impl Iterator<Item = (f64, usize)>, max: usize) -> Vec<usize> {
    let mut scored: Vec<(f64, usize)> = scored.filter(|&(score, _)| score > 0.0).collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    scored.into_iter().take(max).map(|(_, s)| s).collect()
}

/// Share of a grid of the reference's pixels, at three depths of its range,
/// that the source sees; 0 when the angle at mid range is below `min_angle_deg`.
fn frustum_overlap(
    reference: &Camera,
    source: &Camera,
    range: (f64, f64),
    min_angle_deg: f64,
) -> f64 {
    let k = reference.intrinsics;
    let mid = 0.5 * (range.0 + range.1);
    let centre = reference.unproject(&nalgebra::Point2::new(k.cx, k.cy), mid);
    if triangulation_angle_deg(&centre, &[reference.center(), source.center()]) < min_angle_deg {
        return 0.0;
    }
    let (mut hit, mut total) = (0usize, 0usize);
    for d in [range.0, mid, range.1] {
        for j in 0..8 {
            for i in 0..8 {
                let px = nalgebra::Point2::new(
                    (f64::from(i) + 0.5) / 8.0 * f64::from(k.width),
                    (f64::from(j) + 0.5) / 8.0 * f64::from(k.height),
                );
                total += 1;
                if source.in_frustum(&reference.unproject(&px, d)) {
                    hit += 1;
                }
            }
        }
    }
    hit as f64 / total as f64
}
