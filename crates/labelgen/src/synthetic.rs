//! COLMAP sparse models of procedural scenes: what SfM would give for known
//! cameras and a known surface. Used by tests and demos to feed
//! [`crate::triplets`] and the `labelgen` commands without real photos.

use nalgebra::Point3;
use vp_scene::colmap::Reconstruction;
use vp_scene::raycast::RayCaster;
use vp_scene::Camera;

/// A sparse model with one PINHOLE camera and one image per entry of
/// `cameras` (ids from 1 in order), and each of `points` that is visible
/// (in frame, unoccluded by the surface of `caster`) in at least two images
/// as a 3D point whose track lists those images. Projections are exact.
pub fn sparse_model(
    cameras: &[(String, Camera)],
    caster: &RayCaster,
    points: &[Point3<f64>],
) -> Reconstruction {
    let mut rec = Reconstruction::default();
    let ids: Vec<u32> = cameras
        .iter()
        .map(|(name, cam)| rec.add_pinhole_image(name, cam))
        .collect();
    let visibility: Vec<Vec<bool>> = cameras
        .iter()
        .map(|(_, c)| caster.visible_points(c, points))
        .collect();
    for (j, p) in points.iter().enumerate() {
        let seen: Vec<usize> = (0..cameras.len()).filter(|&i| visibility[i][j]).collect();
        if seen.len() < 2 {
            continue;
        }
        let observations: Vec<_> = seen
            .iter()
            .filter_map(|&i| cameras[i].1.project(p).map(|xy| (ids[i], xy)))
            .collect();
        // Every id was added above: this cannot fail.
        let _ = rec.add_point(*p, &observations);
    }
    rec
}
