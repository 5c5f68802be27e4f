//! COLMAP models written by COLMAP 3.8 itself (see tests/data/colmap/README.md):
//! our reader must agree with COLMAP's writer, and COLMAP's reader with ours.

mod colmap_common;

use std::path::Path;

use colmap_common::{assert_same_model, data_dir, hand_model};
use nalgebra::Point3;
use vp_scene::colmap::{
    read_depth_map, read_model, read_model_as, write_binary, write_text, CameraModel, ModelFormat,
    Reconstruction,
};

/// Writes the hand model with our text writer into the test data. Run once
/// by hand (`cargo test -p vp-scene --test colmap_real -- --ignored`), then
/// convert with COLMAP as the README says.
#[test]
#[ignore = "regenerates committed test data"]
fn regenerate_hand_model_text() {
    write_text(&data_dir().join("hand/vpctl_txt"), &hand_model()).unwrap();
}

fn files_equal(a: &Path, b: &Path) {
    for f in ["cameras.txt", "images.txt", "points3D.txt"] {
        let x = std::fs::read_to_string(a.join(f)).unwrap();
        let y = std::fs::read_to_string(b.join(f)).unwrap();
        assert_eq!(x, y, "{f} differs");
    }
}

#[test]
fn text_writer_output_is_stable() {
    // Regression guard: the committed files COLMAP converted are exactly
    // what the writer produces today.
    let tmp = tempfile::tempdir().unwrap();
    write_text(tmp.path(), &hand_model()).unwrap();
    files_equal(tmp.path(), &data_dir().join("hand/vpctl_txt"));
}

#[test]
fn colmap_reads_our_text_and_writes_what_we_wrote() {
    let ours = hand_model();
    // COLMAP read our text, wrote binary; then read its binary, wrote text.
    let bin = read_model_as(&data_dir().join("hand/colmap_bin"), ModelFormat::Binary).unwrap();
    let txt = read_model_as(&data_dir().join("hand/colmap_txt"), ModelFormat::Text).unwrap();
    assert_same_model(&bin, &ours, 1e-15);
    assert_same_model(&txt, &ours, 1e-15);
    assert_eq!(bin, txt, "COLMAP's text and binary forms read identically");
    // Every COLMAP 3.8 model id went through COLMAP with its parameter count.
    let models: Vec<CameraModel> = bin.cameras.values().map(|c| c.model).collect();
    assert_eq!(models, CameraModel::ALL[..11].to_vec());
}

fn sfm_bin() -> Reconstruction {
    read_model(&data_dir().join("sfm/bin")).unwrap()
}

#[test]
fn sfm_text_and_binary_read_identically() {
    let bin = sfm_bin();
    let txt = read_model(&data_dir().join("sfm/txt")).unwrap();
    assert_eq!(bin, txt);
    assert_eq!((bin.cameras.len(), bin.images.len()), (1, 4));
    assert!(bin.points.len() > 100, "{} points", bin.points.len());
    // The header COLMAP wrote into points3D.txt states the mean track length.
    let header = std::fs::read_to_string(data_dir().join("sfm/txt/points3D.txt")).unwrap();
    let stated: f64 = header
        .lines()
        .find_map(|l| l.split("mean track length: ").nth(1))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!((bin.mean_track_length() - stated).abs() < 1e-12);
}

#[test]
fn sfm_round_trips_are_exact() {
    let rec = sfm_bin();
    let tmp = tempfile::tempdir().unwrap();
    let (t1, b1, t2) = (
        tmp.path().join("t1"),
        tmp.path().join("b1"),
        tmp.path().join("t2"),
    );
    write_text(&t1, &rec).unwrap();
    assert_eq!(read_model(&t1).unwrap(), rec, "bin -> text");
    write_binary(&b1, &rec).unwrap();
    assert_eq!(read_model(&b1).unwrap(), rec, "bin -> bin");
    // Same layout as COLMAP's: cameras.bin byte for byte; COLMAP 3.8 writes
    // images and points in hash-map order (we sort by id), so for those the
    // sizes must agree.
    let size = |dir: &Path, f: &str| std::fs::read(dir.join(f)).unwrap();
    let colmap_dir = data_dir().join("sfm/bin");
    assert!(size(&b1, "cameras.bin") == size(&colmap_dir, "cameras.bin"));
    for f in ["images.bin", "points3D.bin"] {
        assert_eq!(size(&b1, f).len(), size(&colmap_dir, f).len(), "{f}");
    }
    let txt = read_model(&data_dir().join("sfm/txt")).unwrap();
    write_binary(&b1, &txt).unwrap();
    write_text(&t2, &read_model(&b1).unwrap()).unwrap();
    files_equal(&t1, &t2);
    assert_eq!(read_model(&t2).unwrap(), txt, "text -> bin -> text");
}

#[test]
fn sfm_points_project_onto_their_observations() {
    let rec = sfm_bin();
    assert_eq!(rec.cameras[&1].model, CameraModel::SimplePinhole);
    for point in rec.points.values() {
        let mut sum = 0.0;
        for &(image_id, idx) in &point.track {
            let cam = rec.camera_of(image_id).unwrap();
            let seen = rec.images[&image_id].points2d[idx as usize].xy;
            let px = cam.project(&point.xyz).expect("point in front of camera");
            sum += (px - seen).norm();
        }
        let mean = sum / point.track.len() as f64;
        // COLMAP's ERROR is this same mean reprojection error over the track
        // (no distortion: the model is SIMPLE_PINHOLE), so pose, intrinsics
        // and pixel convention must reproduce it to rounding.
        assert!(
            (mean - point.error).abs() < 1e-9,
            "point {}: reprojection {mean} px, COLMAP says {}",
            point.id,
            point.error
        );
    }
}

#[test]
fn sfm_camera_centres_match_the_rendered_rig_up_to_scale() {
    // The views were rendered from centres on a circle (render_views.py);
    // SfM recovers them up to a similarity, so distance ratios must agree.
    let truth: Vec<Point3<f64>> = [-24.0f64, -8.0, 8.0, 24.0]
        .iter()
        .map(|a| {
            let a = a.to_radians();
            Point3::new(8.0 * a.cos() - 2.0, 8.0 * a.sin(), 5.0)
        })
        .collect();
    let rec = sfm_bin();
    let mut by_name: Vec<_> = rec.images.values().collect();
    by_name.sort_by(|a, b| a.name.cmp(&b.name));
    let est: Vec<Point3<f64>> = by_name.iter().map(|im| im.center()).collect();
    let scale = (est[0] - est[3]).norm() / (truth[0] - truth[3]).norm();
    for i in 0..4 {
        for j in i + 1..4 {
            let r = (est[i] - est[j]).norm() / (truth[i] - truth[j]).norm() / scale;
            assert!((r - 1.0).abs() < 0.03, "views {i},{j}: ratio {r}");
        }
    }
    // Focal length: rendered with 300 px.
    let f = rec.cameras[&1].pinhole().unwrap().fx;
    assert!((f - 300.0).abs() < 10.0, "f = {f}");
}

#[test]
fn depth_map_in_colmap_layout_reads_row_major() {
    // Written by numpy following COLMAP's read_write_dense.py layout
    // (see README): depth(x, y) = 1 + x + 10 y, with holes where x == y.
    let d = read_depth_map(&data_dir().join("depth/ramp_5x3.geometric.bin")).unwrap();
    assert_eq!((d.width, d.height), (5, 3));
    for y in 0..3 {
        for x in 0..5 {
            let want = if x == y {
                0.0
            } else {
                1.0 + x as f32 + 10.0 * y as f32
            };
            assert_eq!(d.get(x, y), Some(want), "({x}, {y})");
        }
    }
    let s = d.stats();
    assert_eq!((s.valid, s.total), (12, 15));
    assert_eq!((s.min, s.max), (Some(2.0), Some(25.0)));
}
