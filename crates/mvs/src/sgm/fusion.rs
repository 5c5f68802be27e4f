//! Multi-baseline fusion: a reference matched against several sources
//! keeps, per pixel, the median of the largest group of pair depths that
//! agree with each other, when the group has `min_agreeing_pairs` members
//! (or all the pairs that gave a depth there, if fewer), as SURE fuses its
//! pairs. Agreement is a relative depth difference or a disparity
//! difference in pixels ([`PairAgreement`]).

use rayon::prelude::*;

use super::{PairAgreement, SgmParams};

/// One pair's depths on the reference's grid (0: none) and its rectified
/// focal length times baseline (pixels x metres; `None` when the pair gave
/// no depth at all): a depth `z` is a disparity of about that over `z`.
pub(crate) struct PairDepth {
    pub depth: Vec<f32>,
    pub focal_baseline: Option<f64>,
}

/// The fused depth map (`width` x `height`) of a reference's `pairs`.
pub(crate) fn fuse(
    pairs: &[PairDepth],
    (width, height): (usize, usize),
    params: &SgmParams,
) -> Vec<f32> {
    let min_agree = params.min_agreeing_pairs as usize;
    // The narrowest pair sets the pixel scale: its disparities are the
    // coarsest measurement of depth among the pairs.
    let narrowest = pairs
        .iter()
        .filter_map(|p| p.focal_baseline)
        .fold(f64::INFINITY, f64::min);
    let (rel, px) = (params.pair_depth_tolerance, params.pair_tolerance_px);
    let fb = narrowest as f32;
    let agree = |e: f32, d: f32| match params.pair_agreement {
        PairAgreement::Relative => (e - d).abs() <= rel * d,
        PairAgreement::Pixels => (fb / e - fb / d).abs() <= px,
    };
    let mut depth = vec![0.0f32; width * height];
    depth
        .par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            let mut at = Vec::with_capacity(pairs.len());
            for (x, o) in row.iter_mut().enumerate() {
                at.clear();
                at.extend(pairs.iter().map(|p| p.depth[y * width + x]));
                *o = fuse_pixel(&mut at, min_agree, agree).unwrap_or(0.0);
            }
        });
    depth
}

/// One pixel's fusion of its pair depths (zeros are "none"): the median of
/// the largest group of depths that `agree` with one depth of it, `None`
/// when the group is smaller than `min_agree` (capped at the number of
/// depths). `agree(e, d)` must widen monotonically away from `d`, so that
/// in sorted order each depth's group is a contiguous run around it.
fn fuse_pixel(
    depths: &mut Vec<f32>,
    min_agree: usize,
    agree: impl Fn(f32, f32) -> bool,
) -> Option<f32> {
    depths.retain(|&d| d > 0.0);
    if depths.is_empty() {
        return None;
    }
    depths.sort_by(f32::total_cmp);
    let mut best = (0, 0, 0);
    for (i, &d) in depths.iter().enumerate() {
        let first = depths.iter().position(|&e| agree(e, d)).unwrap_or(i);
        let last = depths.iter().rposition(|&e| agree(e, d)).unwrap_or(i);
        if last + 1 - first > best.2 {
            best = (first, last, last + 1 - first);
        }
    }
    let (first, last, n) = best;
    (n >= min_agree.min(depths.len())).then(|| depths[first + (last - first) / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn relative(e: f32, d: f32) -> bool {
        (e - d).abs() <= 0.01 * d
    }

    #[test]
    fn fuse_pixel_keeps_the_agreeing_median() {
        let mut d = vec![10.0, 10.05, 0.0, 14.0];
        assert_eq!(fuse_pixel(&mut d, 2, relative), Some(10.0));
        let mut d = vec![10.0, 14.0];
        assert_eq!(fuse_pixel(&mut d, 2, relative), None);
        let mut d = vec![0.0, 14.0];
        assert_eq!(fuse_pixel(&mut d, 2, relative), Some(14.0));
        let mut d = vec![0.0, 0.0];
        assert_eq!(fuse_pixel(&mut d, 2, relative), None);
    }

    /// Two pairs of a reference 14 m from the ground: a narrow one (172 px
    /// focal length, 0.3 m baseline: about 3.7 px of disparity) and a wide
    /// one (5 m: 61 px), whose depths differ by one given disparity error.
    fn two_pairs(narrow_err_px: f32, agreement: PairAgreement) -> f32 {
        let (f, z) = (172.0f64, 14.0f32);
        let (narrow, wide) = (f * 0.3, f * 5.0);
        // The narrow pair's depth off by `narrow_err_px` of its disparity.
        let d_narrow = (narrow as f32) / ((narrow as f32) / z + narrow_err_px);
        let pairs = [
            PairDepth {
                depth: vec![d_narrow],
                focal_baseline: Some(narrow),
            },
            PairDepth {
                depth: vec![z],
                focal_baseline: Some(wide),
            },
        ];
        let params = SgmParams {
            pair_agreement: agreement,
            ..SgmParams::default()
        };
        fuse(&pairs, (1, 1), &params)[0]
    }

    #[test]
    fn relative_agreement_rejects_a_tenth_of_a_pixel_at_a_narrow_baseline() {
        // 0.1 px in a 3.7 px disparity is a 2.6 % depth difference: the
        // relative rule (1 %) drops the pixel, the pixel rule (1 px) keeps it.
        // (A fused depth of 0 is "no depth".)
        let kept = |err: f32, agreement| two_pairs(err, agreement) > 0.0;
        assert!(!kept(0.1, PairAgreement::Relative));
        assert!(kept(0.1, PairAgreement::Pixels));
        // Two pixels off in the narrow pair is a disagreement for both.
        assert!(!kept(2.0, PairAgreement::Pixels));
        assert!(!kept(2.0, PairAgreement::Relative));
    }

    #[test]
    fn pixel_agreement_is_the_same_test_at_every_depth_scale() {
        // Scaling the scene (depths and baselines alike) leaves disparities
        // and so the pixel rule's verdicts unchanged.
        let verdict = |scale: f32, err: f32| {
            let z = 14.0 * scale;
            let fb = 172.0 * 0.3 * scale;
            let pairs = [
                PairDepth {
                    depth: vec![fb / (fb / z + err)],
                    focal_baseline: Some(f64::from(fb)),
                },
                PairDepth {
                    depth: vec![z],
                    focal_baseline: Some(f64::from(fb) * 10.0),
                },
            ];
            let params = SgmParams {
                pair_agreement: PairAgreement::Pixels,
                ..SgmParams::default()
            };
            fuse(&pairs, (1, 1), &params)[0] > 0.0
        };
        for scale in [0.5, 1.0, 4.0] {
            assert!(verdict(scale, 0.9), "scale {scale}");
            assert!(!verdict(scale, 1.1), "scale {scale}");
        }
    }
}
