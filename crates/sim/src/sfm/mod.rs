//! The one SfM simulator: what a user's SfM (COLMAP, OpenSfM) would give of
//! a set of rendered images, used by every part of the simulator (the
//! campaign's flights, each reconstruction's depth range, the training
//! sites' stage-3 mesh, `vpctl sim fly`'s model).
//!
//! - [`sfm_camera`]: the pose SfM estimates for a true camera (one
//!   georeferencing error per model, exact relative poses);
//! - [`SparseCandidates`]: the surface points SfM may triangulate, which
//!   of them a set of images observes ([`features`]: where FAST fires on
//!   the renders) and their noisy positions ([`point_noise`]);
//! - [`sparse_depth_ranges`]: each view's depth range from its sparse
//!   points, by COLMAP's rule.

pub mod candidates;
pub mod features;

pub use candidates::{sparse_depth_ranges, track_samples, SparseCandidates};
pub use features::FeatureMask;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use vp_scene::hash::mix64;
use vp_scene::Camera;

use crate::config::CampaignConfig;
use crate::noise::gaussian;

/// Seeded Gaussian noise of a 3D position, a pure function of the position
/// (standard deviation `sigma` per axis).
pub fn point_noise(seed: u64, p: &Point3<f64>, sigma: f64) -> Vector3<f64> {
    let q = |v: f64| (v * 1e4).round() as i64;
    let (a, b, c) = (q(p.x), q(p.y), q(p.z));
    Vector3::new(
        gaussian(seed ^ 0x78, a, b, c),
        gaussian(seed ^ 0x79, a, b, c),
        gaussian(seed ^ 0x7a, a, b, c),
    ) * sigma
}

/// The camera as SfM estimates it: the true pose moved by the
/// georeferencing error of the SfM model of `seed`, one rigid transform
/// for every image of that model (rotation about the site's origin with
/// `sfm.rotation_noise_deg` per axis, shift with `sfm.position_noise_m`
/// per axis). The images' poses relative to each other are exact: bundle
/// adjustment leaves sub-pixel reprojection errors, so the error a matcher
/// sees is not epipolar; the planner and the evaluation see the shift.
/// (Independent centimetre noise per camera, as before issue 34, would be a
/// 1-2 % depth error at the campaign's short baselines: no SfM model has
/// relative poses that poor.)
pub fn sfm_camera(cam: &Camera, cfg: &CampaignConfig, seed: u64) -> Camera {
    let s = mix64(seed ^ 0x0073_666d);
    let g = |k: i64| gaussian(s, k, 0, 0);
    let dp = Vector3::new(g(0), g(1), g(2)) * cfg.sfm.position_noise_m;
    let dr = Vector3::new(g(3), g(4), g(5)) * cfg.sfm.rotation_noise_deg.to_radians();
    let georef =
        Isometry3::from_parts(Translation3::from(dp), UnitQuaternion::from_scaled_axis(dr));
    Camera::new(cam.intrinsics, georef * cam.world_from_cam)
}

/// SfM's estimates of `cams`, all in the SfM model of `seed`
/// ([`sfm_camera`]): the one pose set a reconstruction, labelgen and the
/// planner share.
pub fn sfm_cameras(cams: &[Camera], cfg: &CampaignConfig, seed: u64) -> Vec<Camera> {
    cams.iter().map(|c| sfm_camera(c, cfg, seed)).collect()
}
