//! Coarse-to-fine PatchMatch: images halved by 2x2 averaging, and the
//! coarse winning planes carried up as the next level's starting
//! hypotheses.
//!
//! Why: at half resolution a PatchMatch iteration costs a quarter, and
//! planes spread four times as far per propagation step, so most of the
//! search (random start to converged surfaces) is done cheaply; the full
//! resolution then only refines, in fewer iterations.

use rayon::prelude::*;

use crate::patchmatch::{Hyp, RawState};
use crate::view::{pixel_ray, GreyImage};

/// The image at half resolution: pixel (x, y) is the mean of the 2x2 block
/// at (2x, 2y), so continuous coordinates halve exactly (a pixel centre
/// (x + 0.5) maps to 2x + 1, the block's centre). An odd last row or
/// column is dropped.
pub(crate) fn half(image: &GreyImage) -> GreyImage {
    let (w, h) = (image.width as usize, image.height as usize);
    let (hw, hh) = (w / 2, h / 2);
    let mut data = vec![0.0; hw * hh];
    // (`max(1)`: an empty image has no rows, and no chunks of one.)
    data.par_chunks_mut(hw.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            let top = &image.data[2 * y * w..][..2 * hw];
            let bottom = &image.data[(2 * y + 1) * w..][..2 * hw];
            for (x, out) in row.iter_mut().enumerate() {
                let s = top[2 * x] + top[2 * x + 1] + bottom[2 * x] + bottom[2 * x + 1];
                *out = 0.25 * s;
            }
        });
    GreyImage {
        width: hw as u32,
        height: hh as u32,
        data,
    }
}

/// Intrinsics `[fx, fy, cx, cy]` of the halved image.
pub(crate) fn half_k(k: &[f32; 4]) -> [f32; 4] {
    k.map(|v| 0.5 * v)
}

/// Starting hypotheses at the finer level (`width` x `height`, intrinsics
/// `k`) from the coarse winners: each pixel takes its parent's plane, the
/// depth being where that plane meets this pixel's own ray (a plane, not a
/// depth, is what carries over between resolutions). Costs are left at the
/// worst; the finer level scores them.
pub(crate) fn upsample(
    coarse: &RawState,
    coarse_k: &[f32; 4],
    width: usize,
    height: usize,
    k: &[f32; 4],
    worst: f32,
) -> RawState {
    let parent_at = |x: usize, y: usize| {
        let (cx, cy) = (
            (x / 2).min(coarse.width - 1),
            (y / 2).min(coarse.height - 1),
        );
        (cx, cy, cy * coarse.width + cx)
    };
    // In parallel: a serial pass would sit between two parallel ones.
    let hyps = (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let (cx, cy, at) = parent_at(x, y);
            let parent = coarse.hyps[at];
            let n = parent.n;
            let rc = pixel_ray(coarse_k, cx, cy);
            let rf = pixel_ray(k, x, y);
            let den = n[0] * rf[0] + n[1] * rf[1] + n[2] * rf[2];
            let num = parent.d * (n[0] * rc[0] + n[1] * rc[1] + n[2] * rc[2]);
            let d = num / den;
            Hyp {
                d: if d.is_finite() && d > 0.0 {
                    d
                } else {
                    parent.d
                },
                n,
                cost: worst,
                photo: worst,
            }
        })
        .collect();
    // Each pixel keeps its parent's choice of sources, too.
    let sources = coarse.sources.as_ref().map(|masks| {
        (0..width * height)
            .into_par_iter()
            .map(|i| masks[parent_at(i % width, i / width).2])
            .collect()
    });
    RawState {
        width,
        height,
        hyps,
        sources,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_averages_blocks_and_drops_odd_edges() {
        let img = GreyImage {
            width: 5,
            height: 3,
            data: (0..15).map(|v| v as f32).collect(),
        };
        let h = half(&img);
        assert_eq!((h.width, h.height), (2, 1));
        assert_eq!(h.data, vec![3.0, 5.0]);
    }

    #[test]
    fn upsampled_planes_keep_the_coarse_plane() {
        // A tilted plane: every fine pixel's depth must lie on it.
        let k = [100.0f32, 100.0, 32.0, 32.0];
        let ck = half_k(&k);
        let n = {
            let v = [0.3f32, -0.2, -1.0];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / l)
        };
        // Plane n . X = -10 (distance 10 in front of the camera).
        let depth_on_plane =
            |ray: [f32; 3]| -10.0 / (n[0] * ray[0] + n[1] * ray[1] + n[2] * ray[2]);
        let (cw, ch) = (32usize, 32usize);
        let hyps: Vec<Hyp> = (0..cw * ch)
            .map(|i| Hyp {
                d: depth_on_plane(pixel_ray(&ck, i % cw, i / cw)),
                n,
                cost: 0.0,
                photo: 0.0,
            })
            .collect();
        let coarse = RawState {
            width: cw,
            height: ch,
            hyps,
            sources: None,
        };
        let fine = upsample(&coarse, &ck, 64, 64, &k, 2.0);
        for (i, hyp) in fine.hyps.iter().enumerate() {
            let want = depth_on_plane(pixel_ray(&k, i % 64, i / 64));
            assert!(
                (hyp.d - want).abs() < 1e-4 * want,
                "{i}: {} vs {want}",
                hyp.d
            );
            assert!(hyp.cost >= 2.0);
        }
    }
}
