//! Shared fixtures of the COLMAP integration tests.
// Each test binary includes this module and uses only part of it.
#![allow(dead_code)]

use std::path::PathBuf;

use nalgebra::{Isometry3, Point2, Point3, Translation3, UnitQuaternion, Vector3};
use vp_scene::colmap::{CameraModel, ColmapCamera, ColmapImage, Point2D, Point3D, Reconstruction};

/// `crates/scene/tests/data/colmap`.
pub fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/colmap")
}

/// A small hand-made model: one camera of each model COLMAP 3.8 knows
/// (ids 0-10, distinct parameters), four images (one without features),
/// five 3D points. Its text form, written by vp-scene, is committed in
/// `data/colmap/hand/vpctl_txt` and was converted by COLMAP itself.
pub fn hand_model() -> Reconstruction {
    let mut rec = Reconstruction::default();
    add_hand_cameras(&mut rec);
    add_hand_images(&mut rec);
    add_hand_points(&mut rec);
    rec.validate().unwrap();
    rec
}

fn add_hand_cameras(rec: &mut Reconstruction) {
    for id in 0..=10 {
        let model = CameraModel::from_id(id).unwrap();
        // Focal length(s), principal point, then small distortion terms.
        let nf = if matches!(id, 0 | 2 | 3 | 8 | 9) {
            1
        } else {
            2
        };
        let params = (0..model.num_params())
            .map(|k| {
                let id = f64::from(id);
                if k < nf {
                    500.0 + id + 5.0 * k as f64
                } else if k == nf {
                    320.0 + id
                } else if k == nf + 1 {
                    240.0 - id
                } else {
                    0.01 * (k - nf - 1) as f64 - 0.003 * id
                }
            })
            .collect();
        let cam = ColmapCamera {
            id: 1 + id as u32,
            model,
            width: 640 + 2 * id as u64,
            height: 480,
            params,
        };
        rec.cameras.insert(cam.id, cam);
    }
}

fn add_hand_images(rec: &mut Reconstruction) {
    let pose = |axis: Vector3<f64>, angle: f64, t: [f64; 3]| {
        Isometry3::from_parts(
            Translation3::new(t[0], t[1], t[2]),
            UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle),
        )
    };
    let images = [
        (1, 1, "a.jpg", pose(Vector3::x(), 0.3, [0.1, -0.2, 4.0])),
        (
            2,
            2,
            "b.jpg",
            pose(Vector3::new(1.0, 2.0, 0.5), -0.7, [1.0, 0.5, 3.0]),
        ),
        (
            5,
            5,
            "sub/c.png",
            pose(Vector3::z(), 1.2, [-2.0, 0.25, 6.5]),
        ),
        (7, 11, "d.jpg", pose(Vector3::y(), 0.05, [0.0, 0.0, 1.0])),
    ];
    for (id, camera_id, name, cam_from_world) in images {
        rec.images.insert(
            id,
            ColmapImage {
                id,
                camera_id,
                name: name.to_string(),
                cam_from_world,
                points2d: Vec::new(),
            },
        );
    }
    let n2d = [(1u32, 6usize), (2, 4), (5, 5)];
    for (image_id, n) in n2d {
        let im = rec.images.get_mut(&image_id).unwrap();
        im.points2d = (0..n)
            .map(|k| Point2D {
                xy: Point2::new(10.5 + 37.25 * k as f64, 400.0 - 11.125 * k as f64),
                point3d_id: None,
            })
            .collect();
    }
}

/// Point id, xyz, rgb, error, track.
type HandPoint = (u64, [f64; 3], [u8; 3], f64, &'static [(u32, u32)]);

fn add_hand_points(rec: &mut Reconstruction) {
    let points: [HandPoint; 5] = [
        (1, [0.5, 0.25, 1.0], [255, 0, 10], 0.5, &[(1, 0), (2, 1)]),
        (
            2,
            [-1.0, 2.0, 0.125],
            [1, 2, 3],
            0.25,
            &[(1, 2), (2, 0), (5, 0)],
        ),
        (3, [1e-3, -7.5, 3.0], [0, 0, 0], 1.5, &[(5, 2), (1, 3)]),
        (10, [4.0, 4.0, -1.0], [9, 99, 199], 0.75, &[(2, 2), (5, 1)]),
        (
            11,
            [0.0, 0.0, 0.0],
            [128, 128, 128],
            2.0,
            &[(1, 4), (2, 3), (5, 3)],
        ),
    ];
    for (id, xyz, rgb, error, track) in points {
        for &(im, idx) in track {
            rec.images.get_mut(&im).unwrap().points2d[idx as usize].point3d_id = Some(id);
        }
        rec.points.insert(
            id,
            Point3D {
                id,
                xyz: Point3::new(xyz[0], xyz[1], xyz[2]),
                rgb,
                error,
                track: track.to_vec(),
            },
        );
    }
}

/// Whether two models are equal, poses up to `tol` (COLMAP renormalises
/// quaternions when it reads them, which may change the last bits).
pub fn assert_same_model(a: &Reconstruction, b: &Reconstruction, tol: f64) {
    assert_eq!(a.cameras, b.cameras);
    assert_eq!(a.points, b.points);
    assert_eq!(a.images.len(), b.images.len());
    for (ia, ib) in a.images.values().zip(b.images.values()) {
        assert_eq!(
            (ia.id, ia.camera_id, &ia.name, &ia.points2d),
            (ib.id, ib.camera_id, &ib.name, &ib.points2d)
        );
        let d = ia.cam_from_world.inverse() * ib.cam_from_world;
        assert!(
            d.rotation.angle() <= tol && d.translation.vector.norm() <= tol,
            "image {}: poses differ by {} rad, {}",
            ia.id,
            d.rotation.angle(),
            d.translation.vector.norm()
        );
    }
}
