//! Depth maps of the matcher: empty ones, vp-mvs's, and an SfM camera's
//! depths expressed in the true camera (what the truth is compared with).

use nalgebra::Point2;
use vp_scene::colmap::DepthMap;
use vp_scene::Camera;

/// An empty depth map of `cam`'s size.
pub(super) fn zero_depth(cam: &Camera) -> DepthMap {
    let k = cam.intrinsics;
    DepthMap {
        width: k.width,
        height: k.height,
        data: vec![0.0; k.width as usize * k.height as usize],
    }
}

/// `depth` (of the SfM camera `sfm`) expressed in the true camera `truth`:
/// each pixel's point on the SfM ray, its depth along the true axis.
pub(super) fn depth_in_truth(depth: &DepthMap, sfm: &Camera, truth: &Camera) -> DepthMap {
    let w = depth.width as usize;
    let truth_from_world = truth.cam_from_world();
    let data = depth
        .data
        .iter()
        .enumerate()
        .map(|(i, &z)| {
            if z <= 0.0 {
                return 0.0;
            }
            let px = Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let x = sfm.unproject(&px, f64::from(z));
            ((truth_from_world * x).z as f32).max(0.0)
        })
        .collect();
    DepthMap {
        width: depth.width,
        height: depth.height,
        data,
    }
}

/// The depth of a vp-mvs result, or zeros of `cam`'s size without one.
pub(super) fn depth_of(map: Option<&vp_mvs::DepthNormalMap>, cam: &Camera) -> DepthMap {
    map.map_or_else(
        || zero_depth(cam),
        |m| DepthMap {
            width: m.width,
            height: m.height,
            data: m.depth.clone(),
        },
    )
}
