//! Round trips of random models through both COLMAP forms are lossless.

mod colmap_common;

use nalgebra::{Isometry3, Point2, Point3, Quaternion, Translation3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_scene::colmap::{
    cameras_to_bytes, images_to_bytes, points3d_to_bytes, read_model, read_model_as, write_binary,
    write_text, CameraModel, ColmapCamera, ColmapImage, ModelFormat, Point2D, Point3D,
    Reconstruction,
};

/// A value from a wide range of magnitudes and signs, to exercise number
/// printing (exponents, negative zero, long mantissas).
fn wild(rng: &mut ChaCha8Rng) -> f64 {
    match rng.random_range(0..6) {
        0 => 0.0,
        1 => -0.0,
        2 => rng.random_range(-1e3..1e3),
        3 => rng.random::<f64>() * 10f64.powi(rng.random_range(-300..300)),
        4 => -rng.random::<f64>() * 1e-7,
        _ => f64::from(rng.random_range(-5i32..5)),
    }
}

/// A random consistent model: every camera model, tracks and 2D points
/// cross-referenced, names with spaces and sub-folders.
fn random_model(seed: u64) -> Reconstruction {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut rec = Reconstruction::default();
    for (k, model) in CameraModel::ALL.into_iter().enumerate() {
        let id = 3 * k as u32 + 1;
        let params = (0..model.num_params()).map(|_| wild(&mut rng)).collect();
        rec.cameras.insert(
            id,
            ColmapCamera {
                id,
                model,
                width: rng.random_range(1..10_000),
                height: rng.random_range(1..10_000),
                params,
            },
        );
    }
    let camera_ids: Vec<u32> = rec.cameras.keys().copied().collect();
    for k in 0..rng.random_range(1..8u32) {
        let id = 10 * k + rng.random_range(0..10);
        let q = Quaternion::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let pose = Isometry3::from_parts(
            Translation3::new(wild(&mut rng), wild(&mut rng), wild(&mut rng)),
            UnitQuaternion::from_quaternion(q),
        );
        let n2d = rng.random_range(0..30);
        rec.images.insert(
            id,
            ColmapImage {
                id,
                camera_id: camera_ids[rng.random_range(0..camera_ids.len())],
                name: format!("dir {k}/img_{id}.jpg"),
                cam_from_world: pose,
                points2d: (0..n2d)
                    .map(|_| Point2D {
                        xy: Point2::new(wild(&mut rng), wild(&mut rng)),
                        point3d_id: None,
                    })
                    .collect(),
            },
        );
    }
    // Points observe free 2D points of random images.
    let mut free: Vec<(u32, u32)> = rec
        .images
        .values()
        .flat_map(|im| (0..im.points2d.len() as u32).map(move |i| (im.id, i)))
        .collect();
    let mut next_id = 1u64 << 40;
    while free.len() >= 2 {
        let len = rng.random_range(2..=free.len().min(5));
        let track: Vec<(u32, u32)> = (0..len)
            .map(|_| free.swap_remove(rng.random_range(0..free.len())))
            .collect();
        next_id += rng.random_range(1..1000);
        for &(im, i) in &track {
            rec.images.get_mut(&im).unwrap().points2d[i as usize].point3d_id = Some(next_id);
        }
        rec.points.insert(
            next_id,
            Point3D {
                id: next_id,
                xyz: Point3::new(wild(&mut rng), wild(&mut rng), wild(&mut rng)),
                rgb: [rng.random(), rng.random(), rng.random()],
                error: if rng.random_bool(0.2) {
                    -1.0
                } else {
                    rng.random::<f64>()
                },
                track,
            },
        );
    }
    rec.validate().unwrap();
    rec
}

#[test]
fn random_models_round_trip_through_text_and_binary() {
    for seed in 0..24 {
        let rec = random_model(seed);
        let tmp = tempfile::tempdir().unwrap();
        let (t1, b1, t2) = (
            tmp.path().join("t1"),
            tmp.path().join("b1"),
            tmp.path().join("t2"),
        );
        write_text(&t1, &rec).unwrap();
        let from_text = read_model(&t1).unwrap();
        assert_eq!(from_text, rec, "seed {seed}: text -> text");
        write_binary(&b1, &rec).unwrap();
        let from_bin = read_model(&b1).unwrap();
        assert_eq!(from_bin, rec, "seed {seed}: bin -> bin");
        write_binary(&b1, &from_text).unwrap();
        write_text(&t2, &read_model_as(&b1, ModelFormat::Binary).unwrap()).unwrap();
        for f in ["cameras.txt", "images.txt", "points3D.txt"] {
            assert_eq!(
                std::fs::read(t1.join(f)).unwrap(),
                std::fs::read(t2.join(f)).unwrap(),
                "seed {seed}: text -> bin -> text changed {f}"
            );
        }
    }
}

#[test]
fn same_seed_same_bytes() {
    let (a, b) = (random_model(7), random_model(7));
    assert_eq!(cameras_to_bytes(&a), cameras_to_bytes(&b));
    assert_eq!(images_to_bytes(&a), images_to_bytes(&b));
    assert_eq!(points3d_to_bytes(&a), points3d_to_bytes(&b));
}

#[test]
fn writers_refuse_inconsistent_models() {
    let mut rec = random_model(3);
    let tmp = tempfile::tempdir().unwrap();
    let first = *rec.images.keys().next().unwrap();
    rec.images.get_mut(&first).unwrap().camera_id = 999;
    let e = write_text(tmp.path(), &rec).unwrap_err();
    assert!(
        e.to_string().contains("refers to unknown camera 999"),
        "{e}"
    );
    assert!(write_binary(tmp.path(), &rec).is_err());
    // Nothing was written.
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);

    let mut rec = random_model(3);
    rec.cameras.values_mut().next().unwrap().params.pop();
    let e = write_binary(tmp.path(), &rec).unwrap_err();
    assert!(
        e.to_string().contains("expects 3 parameters, found 2"),
        "{e}"
    );
}

#[test]
fn camera_of_is_the_inverse_pose_with_pinhole_intrinsics() {
    let rec = colmap_common::hand_model();
    let cam = rec.camera_of(2).unwrap();
    let im = &rec.images[&2];
    let k = rec.cameras[&2].pinhole().unwrap();
    assert_eq!(cam.intrinsics, k);
    assert!((cam.center() - im.center()).norm() < 1e-12);
    // A point on the optical axis in front of the camera lands on the principal point.
    let p = cam.world_from_cam * Point3::new(0.0, 0.0, 5.0);
    let px = cam.project(&p).unwrap();
    assert!((px.x - k.cx).abs() < 1e-9 && (px.y - k.cy).abs() < 1e-9);
    assert!(rec.camera_of(3).is_err(), "no image 3");
    assert!((rec.mean_track_length() - 2.4).abs() < 1e-12);
    assert!((rec.mean_observations_per_image() - 3.0).abs() < 1e-12);
}
