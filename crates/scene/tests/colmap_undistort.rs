//! `undistort_workspace` against COLMAP 3.8's own `image_undistorter` on the
//! same model and images (`data/colmap/undistort`, see its README): one
//! camera of each of COLMAP 3.8's eleven models, a real photo.

use std::path::{Path, PathBuf};

use vp_scene::colmap::{read_model, undistort_workspace, CameraModel, UndistortOptions};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/colmap/undistort")
}

fn mean_abs_diff(a: &Path, b: &Path) -> (f64, u8) {
    let a = image::open(a).unwrap().to_rgb8();
    let b = image::open(b).unwrap().to_rgb8();
    assert_eq!(a.dimensions(), b.dimensions(), "{}", a.width());
    let mut sum = 0u64;
    let mut max = 0u8;
    for (p, q) in a.as_raw().iter().zip(b.as_raw()) {
        let d = p.abs_diff(*q);
        sum += u64::from(d);
        max = max.max(d);
    }
    (sum as f64 / a.as_raw().len() as f64, max)
}

#[test]
fn undistorted_workspace_matches_colmap_image_undistorter() {
    let tmp = tempfile::tempdir().unwrap();
    let out = std::env::var_os("VP_KEEP_UNDISTORTED")
        .map_or_else(|| tmp.path().join("ws"), PathBuf::from);
    let report = undistort_workspace(
        &data().join("input/model"),
        &data().join("input/images"),
        &out,
        &UndistortOptions::default(),
        false,
    )
    .unwrap();
    assert_eq!(report.n_images, 11);
    let ours = read_model(&out.join("sparse")).unwrap();
    let theirs = read_model(&data().join("colmap/sparse")).unwrap();
    // Same output cameras: model, size, parameters.
    for (id, c) in &theirs.cameras {
        let o = &ours.cameras[id];
        assert_eq!(
            (o.model, o.width, o.height),
            (c.model, c.width, c.height),
            "camera {id}"
        );
        for (a, b) in o.params.iter().zip(&c.params) {
            assert!(
                (a - b).abs() < 1e-9,
                "camera {id}: {:?} vs COLMAP {:?}",
                o.params,
                c.params
            );
        }
    }
    // Same 2D features, same poses.
    for (id, im) in &theirs.images {
        let o = &ours.images[id];
        assert_eq!(o.name, im.name);
        assert_eq!(o.cam_from_world, im.cam_from_world);
        for (p, q) in o.points2d.iter().zip(&im.points2d) {
            assert!(
                (p.xy - q.xy).norm() < 1e-4,
                "{}: {} vs COLMAP {}",
                im.name,
                p.xy,
                q.xy
            );
        }
    }
    // Images within 1 grey level mean absolute difference.
    let mut worst = 0.0f64;
    for im in theirs.images.values() {
        let (mad, max) = mean_abs_diff(
            &out.join("images").join(&im.name),
            &data().join("colmap/images").join(&im.name),
        );
        let model = theirs.cameras[&im.camera_id].model;
        eprintln!(
            "{} ({model}): mean abs difference {mad:.4}, max {max}",
            im.name
        );
        assert!(mad <= 1.0, "{}: {mad}", im.name);
        worst = worst.max(mad);
    }
    eprintln!("worst mean abs difference: {worst:.4} grey levels");
    for cfg in ["patch-match.cfg", "fusion.cfg"] {
        assert_eq!(
            std::fs::read_to_string(out.join("stereo").join(cfg)).unwrap(),
            std::fs::read_to_string(data().join("colmap").join(cfg)).unwrap(),
            "{cfg}"
        );
    }
    assert!(out.join("stereo/depth_maps").is_dir());
    assert_eq!(ours.cameras[&1].model, CameraModel::SimplePinhole);
}

#[test]
fn undistort_refuses_existing_output_and_missing_images_without_writing() {
    let tmp = tempfile::tempdir().unwrap();
    let images = tmp.path().join("images");
    std::fs::create_dir(&images).unwrap();
    // Only one of the eleven images is there.
    let first = "m00_simple_pinhole.png";
    std::fs::copy(data().join("input/images").join(first), images.join(first)).unwrap();
    let out = tmp.path().join("ws");
    let e = undistort_workspace(
        &data().join("input/model"),
        &images,
        &out,
        &UndistortOptions::default(),
        false,
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("m01_pinhole.png") && msg.contains("missing"),
        "{msg}"
    );
    assert!(e.is_input_error());
    assert!(!out.exists(), "nothing written");
    assert_eq!(
        std::fs::read_dir(tmp.path()).unwrap().count(),
        1,
        "no temporary left"
    );

    // A folder of other files is refused, even with force.
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let e = undistort_workspace(
        &data().join("input/model"),
        &data().join("input/images"),
        &out,
        &UndistortOptions::default(),
        true,
    )
    .unwrap_err();
    assert!(e.to_string().contains("is not a vpctl output"), "{e}");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1);
}

#[test]
fn undistort_refuses_an_image_of_the_wrong_size_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    // An aligned model keeps its frame in the workspace.
    let model = tmp.path().join("model");
    std::fs::create_dir(&model).unwrap();
    for e in std::fs::read_dir(data().join("input/model")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), model.join(e.file_name())).unwrap();
    }
    std::fs::write(model.join("frame.json"), "{}").unwrap();
    let ws = tmp.path().join("ws-frame");
    undistort_workspace(
        &model,
        &data().join("input/images"),
        &ws,
        &UndistortOptions::default(),
        false,
    )
    .unwrap();
    assert_eq!(
        std::fs::read_to_string(ws.join("sparse/frame.json")).unwrap(),
        "{}"
    );
    let images = tmp.path().join("images");
    std::fs::create_dir(&images).unwrap();
    for e in std::fs::read_dir(data().join("input/images")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), images.join(e.file_name())).unwrap();
    }
    image::RgbImage::new(80, 60)
        .save(images.join("m03_radial.png"))
        .unwrap();
    let out = tmp.path().join("ws");
    let e = undistort_workspace(
        &data().join("input/model"),
        &images,
        &out,
        &UndistortOptions::default(),
        false,
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("m03_radial.png") && msg.contains("80x60"),
        "{msg}"
    );
    assert!(!out.exists());
}
