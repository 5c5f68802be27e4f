//! COLMAP sparse models of procedural scenes: what SfM would give for known
//! cameras and a known surface. Used by tests and demos to feed
//! [`crate::triplets`] and the `labelgen` commands without real photos.

use nalgebra::Point3;
use vp_scene::colmap::{CameraModel, ColmapCamera, ColmapImage, Point2D, Point3D, Reconstruction};
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
    for (i, (name, cam)) in cameras.iter().enumerate() {
        let id = i as u32 + 1;
        let k = cam.intrinsics;
        rec.cameras.insert(
            id,
            ColmapCamera {
                id,
                model: CameraModel::Pinhole,
                width: u64::from(k.width),
                height: u64::from(k.height),
                params: vec![k.fx, k.fy, k.cx, k.cy],
            },
        );
        rec.images.insert(
            id,
            ColmapImage {
                id,
                camera_id: id,
                name: name.clone(),
                cam_from_world: cam.cam_from_world(),
                points2d: Vec::new(),
            },
        );
    }
    let visibility: Vec<Vec<bool>> = cameras
        .iter()
        .map(|(_, c)| caster.visible_points(c, points))
        .collect();
    let mut next_id = 1u64;
    for (j, p) in points.iter().enumerate() {
        let seen: Vec<usize> = (0..cameras.len()).filter(|&i| visibility[i][j]).collect();
        if seen.len() < 2 {
            continue;
        }
        let mut track = Vec::with_capacity(seen.len());
        for &i in &seen {
            let Some(xy) = cameras[i].1.project(p) else {
                continue;
            };
            let img = rec
                .images
                .get_mut(&(i as u32 + 1))
                .expect("image inserted above");
            track.push((img.id, img.points2d.len() as u32));
            img.points2d.push(Point2D {
                xy,
                point3d_id: Some(next_id),
            });
        }
        rec.points.insert(
            next_id,
            Point3D {
                id: next_id,
                xyz: *p,
                rgb: [128, 128, 128],
                error: 0.0,
                track,
            },
        );
        next_id += 1;
    }
    rec
}
