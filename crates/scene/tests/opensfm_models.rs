//! OpenSfM's other camera models (brown, fisheye, fisheye_opencv), its
//! geodetic reference files, the undistort step, and bad input: each
//! projection checked against OpenSfM's formulas written out here
//! (`camera_instances.h`: projection, distortion, affine to normalised
//! coordinates), each error against the file, the place and the next step.

use std::path::Path;

use serde_json::{json, Value};
use vp_scene::colmap::{CameraModel, ColmapCamera, UndistortOptions};
use vp_scene::opensfm::{read_opensfm, undistort_opensfm_workspace, ModelSource};

/// A nadir flight of four shots 40 m above a grid of points at z = 0, in
/// OpenSfM's JSON: the camera looks down with image x east and y south,
/// the rotation of pi about x; `t = -R c`.
fn scene(camera: &Value, reference: bool) -> Value {
    let mut shots = serde_json::Map::new();
    for (i, (x, y)) in [(0.0, 0.0), (10.0, 0.0), (0.0, 10.0), (10.0, 10.0)]
        .iter()
        .enumerate()
    {
        shots.insert(
            format!("IMG_{i}.png"),
            json!({"camera": "cam", "rotation": [std::f64::consts::PI, 0.0, 0.0],
                   "translation": [-x, *y, 40.0], "gps_position": [x, y, 41.0]}),
        );
    }
    let mut points = serde_json::Map::new();
    for i in 0..25 {
        let (x, y) = ((i % 5) as f64 * 5.0 - 5.0, (i / 5) as f64 * 5.0 - 5.0);
        points.insert(
            format!("{}", 100 + i),
            json!({"coordinates": [x, y, 0.0], "color": [200.0, 100.0, 50.0]}),
        );
    }
    let mut r = json!({"cameras": {"cam": camera}, "shots": shots, "points": points});
    if reference {
        r["reference_lla"] = json!({"latitude": 46.03, "longitude": 10.35, "altitude": 400.0});
    }
    json!([r])
}

fn write(dir: &Path, v: &Value) {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("reconstruction.json"), v.to_string()).unwrap();
}

fn camera(dir: &Path, cam: &Value) -> ColmapCamera {
    write(dir, &scene(cam, true));
    read_opensfm(dir).unwrap().reconstruction.cameras[&1].clone()
}

/// OpenSfM's projection of `p` (camera frame) to normalised coordinates.
fn opensfm_project(cam: &Value, p: [f64; 3]) -> [f64; 2] {
    let g = |n: &str| cam[n].as_f64().unwrap_or(0.0);
    match cam["projection_type"].as_str().unwrap() {
        "brown" => {
            let (x, y) = (p[0] / p[2], p[1] / p[2]);
            let r2 = x * x + y * y;
            let radial = 1.0 + g("k1") * r2 + g("k2") * r2 * r2 + g("k3") * r2 * r2 * r2;
            let xd = x * radial + 2.0 * g("p1") * x * y + g("p2") * (r2 + 2.0 * x * x);
            let yd = y * radial + 2.0 * g("p2") * x * y + g("p1") * (r2 + 2.0 * y * y);
            let aspect = g("focal_y") / g("focal_x");
            [
                g("focal_x") * xd + g("c_x"),
                g("focal_x") * aspect * yd + g("c_y"),
            ]
        }
        kind => {
            let r = p[0].hypot(p[1]);
            let th = r.atan2(p[2]);
            // OpenSfM's FisheyeProjection: x/z on the axis, where theta/r is 0/0.
            let (x, y) = if r < 1e-8 {
                (p[0] / p[2], p[1] / p[2])
            } else {
                (th / r * p[0], th / r * p[1])
            };
            let t2 = th * th;
            if kind == "fisheye" {
                let d = 1.0 + g("k1") * t2 + g("k2") * t2 * t2;
                [g("focal") * d * x, g("focal") * d * y]
            } else {
                let d = 1.0
                    + g("k1") * t2
                    + g("k2") * t2 * t2
                    + g("k3") * t2 * t2 * t2
                    + g("k4") * t2 * t2 * t2 * t2;
                [
                    g("focal_x") * d * x + g("c_x"),
                    g("focal_y") * d * y + g("c_y"),
                ]
            }
        }
    }
}

fn assert_same_projection(cam_json: &Value, cam: &ColmapCamera) {
    let size = cam.width.max(cam.height) as f64;
    for p in [
        [0.0, 0.0, 1.0],
        [0.3, -0.2, 1.0],
        [-0.5, 0.4, 1.2],
        [0.7, 0.6, 1.5],
    ] {
        let theirs = opensfm_project(cam_json, p);
        let (u, v) = cam.img_from_cam(p[0] / p[2], p[1] / p[2]).unwrap();
        let ours = [
            (u - cam.width as f64 / 2.0) / size,
            (v - cam.height as f64 / 2.0) / size,
        ];
        for k in 0..2 {
            assert!(
                (ours[k] - theirs[k]).abs() * size < 1e-6,
                "{cam_json}: {p:?}: ours {ours:?} vs OpenSfM's {theirs:?}"
            );
        }
    }
}

#[test]
fn brown_fisheye_and_fisheye_opencv_project_as_opensfm_does() {
    let dir = tempfile::tempdir().unwrap();
    // A DJI-like brown lens: principal point off centre, k3, tangential.
    let brown = json!({"projection_type": "brown", "width": 4000, "height": 2250,
        "focal_x": 0.70, "focal_y": 0.705, "c_x": 0.005, "c_y": -0.0047,
        "k1": -0.103, "k2": -0.015, "k3": 0.02, "p1": 0.0003, "p2": -0.0002});
    let fisheye = json!({"projection_type": "fisheye", "width": 1920, "height": 1080,
        "focal": 0.45, "k1": -0.02, "k2": 0.004});
    let fisheye_cv = json!({"projection_type": "fisheye_opencv", "width": 1920, "height": 1440,
        "focal_x": 0.45, "focal_y": 0.452, "c_x": -0.01, "c_y": 0.003,
        "k1": 0.03, "k2": -0.01, "k3": 0.002, "k4": -0.0004});
    for (cam, model) in [
        (&brown, CameraModel::FullOpenCv),
        (&fisheye, CameraModel::RadialFisheye),
        (&fisheye_cv, CameraModel::OpenCvFisheye),
    ] {
        let c = camera(dir.path(), cam);
        assert_eq!(c.model, model, "{cam}");
        assert!(c.is_distorted());
        assert_same_projection(cam, &c);
    }
    // Brown without k3 is COLMAP's OPENCV, principal point and all.
    let mut b = brown.clone();
    b["k3"] = json!(0.0);
    let c = camera(dir.path(), &b);
    assert_eq!(c.model, CameraModel::OpenCv);
    assert_same_projection(&b, &c);
}

#[test]
fn reference_from_the_reconstruction_beside_it_or_one_folder_up() {
    let dir = tempfile::tempdir().unwrap();
    let cam = json!({"projection_type": "perspective", "width": 64, "height": 48, "focal": 0.8});
    let osfm = dir.path().join("project/opensfm");
    write(&osfm, &scene(&cam, true));
    let m = read_opensfm(&dir.path().join("project")).unwrap();
    assert_eq!(m.file, osfm.join("reconstruction.json"));
    let f = m.frame.clone().unwrap();
    assert_eq!((f.origin.lat_deg, f.origin.alt_m), (46.03, 400.0));
    // Each centre 1 m below its GPS position.
    assert!((f.rms_m - 1.0).abs() < 1e-9, "{}", f.rms_m);
    // A nadir flight over its points in metric ENU passes the frame check.
    let check = m.check_frame().unwrap();
    assert!((check.median_spacing_m - 10.0).abs() < 1e-9);
    // OpenSfM's undistorted dataset: the reference one folder up.
    let und = osfm.join("undistorted");
    write(&und, &scene(&cam, false));
    std::fs::write(
        osfm.join("reference_lla.json"),
        r#"{"latitude": 46.1, "longitude": 10.4, "altitude": 0.0}"#,
    )
    .unwrap();
    let m = read_opensfm(&und).unwrap();
    assert_eq!(m.reference_file, Some(osfm.join("reference_lla.json")));
    assert!((m.frame.unwrap().origin.lat_deg - 46.1).abs() < 1e-12);
    // Without any reference, the frame check says how to get one.
    std::fs::remove_file(osfm.join("reference_lla.json")).unwrap();
    let e = read_opensfm(&und)
        .unwrap()
        .check_frame()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no geodetic reference") && e.contains("--frame-unchecked"),
        "{e}"
    );
}

#[test]
fn undistort_step_writes_a_pinhole_workspace_with_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    let cam = json!({"projection_type": "brown", "width": 64, "height": 48,
        "focal_x": 0.8, "focal_y": 0.8, "c_x": 0.01, "k1": -0.1, "p1": 0.001});
    let osfm = dir.path().join("opensfm");
    write(&osfm, &scene(&cam, true));
    let images = dir.path().join("images");
    std::fs::create_dir_all(&images).unwrap();
    for i in 0..4 {
        image::RgbImage::from_fn(64, 48, |x, y| image::Rgb([x as u8 * 4, y as u8 * 5, 90]))
            .save(images.join(format!("IMG_{i}.png")))
            .unwrap();
    }
    let ws = dir.path().join("ws");
    let report =
        undistort_opensfm_workspace(&osfm, &images, &ws, &UndistortOptions::default(), false)
            .unwrap();
    assert_eq!(report.n_images, 4);
    let sparse = ModelSource::Colmap(ws.join("sparse"));
    let posed = sparse.read_posed(false).unwrap();
    let rec = &posed.reconstruction;
    assert_eq!(rec.cameras[&1].model, CameraModel::Pinhole);
    assert!((posed.frame.unwrap().frame.origin.lat_deg - 46.03).abs() < 1e-12);
    let before = read_opensfm(&osfm).unwrap().reconstruction;
    for (id, im) in &rec.images {
        assert!((im.center() - before.images[id].center()).norm() < 1e-9);
    }
    assert!(ws.join("images/IMG_0.png").is_file());
}

fn error_of(dir: &Path, text: &str) -> String {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("reconstruction.json"), text).unwrap();
    let e = read_opensfm(dir).unwrap_err();
    assert!(e.is_input_error());
    e.to_string()
}

#[test]
fn bad_input_names_the_file_the_place_and_the_next_step() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cam = json!({"projection_type": "perspective", "width": 64, "height": 48, "focal": 0.8});
    let mut dual = scene(&cam, true);
    dual[0]["cameras"]["cam"]["projection_type"] = json!("dual");
    let e = error_of(d, &dual.to_string());
    assert!(
        e.contains("reconstruction.json")
            && e.contains("reconstruction 0")
            && e.contains("cameras.\"cam\"")
            && e.contains("\"dual\" is not supported")
            && e.contains("--camera-lens brown"),
        "{e}"
    );
    let e = error_of(d, "[{\"cameras\": {\"cam\": ");
    assert!(e.contains("line 1") && e.contains("not valid JSON"), "{e}");
    let mut bad = scene(&cam, true);
    bad[0]["shots"]["IMG_2.png"]["rotation"] = json!([0.1, 0.2]);
    let e = error_of(d, &bad.to_string());
    assert!(
        e.contains("shots.\"IMG_2.png\".rotation: expected 3 numbers"),
        "{e}"
    );
    let mut bad = scene(&cam, true);
    bad[0]["shots"]["IMG_1.png"]["camera"] = json!("other");
    let e = error_of(d, &bad.to_string());
    assert!(e.contains("refers to camera \"other\""), "{e}");
    let e = error_of(d, "[]");
    assert!(
        e.contains("no reconstruction with a registered image"),
        "{e}"
    );
    let e = error_of(d, "{\"cameras\": {}}");
    assert!(e.contains("expected a list of reconstructions"), "{e}");
    // tracks.csv beside it: read, and a bad line named.
    write(d, &scene(&cam, true));
    let tracks = "OPENSFM_TRACKS_VERSION_v2\nIMG_0.png\t100\t7\t0.01\t-0.02\t0.001\n\
                  IMG_1.png\t101\t8\tx\t0.1\n";
    std::fs::write(d.join("tracks.csv"), tracks).unwrap();
    let e = read_opensfm(d).unwrap_err().to_string();
    assert!(
        e.contains("tracks.csv") && e.contains("line 3") && e.contains("not numbers"),
        "{e}"
    );
    std::fs::write(d.join("tracks.csv"), tracks.replace("\tx\t", "\t0.2\t")).unwrap();
    let m = read_opensfm(d).unwrap();
    assert_eq!(m.observations, 2);
    m.reconstruction.validate().unwrap();
    std::fs::remove_file(d.join("tracks.csv")).unwrap();
    // Missing: a folder without a reconstruction, a path that is not there.
    let empty = d.join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let e = read_opensfm(&empty).unwrap_err();
    assert!(e.to_string().contains("no OpenSfM reconstruction"), "{e}");
    let e = read_opensfm(&d.join("nowhere")).unwrap_err();
    assert!(
        e.is_input_error() && e.to_string().contains("nowhere"),
        "{e}"
    );
    // A COLMAP reader pointed at an OpenSfM folder says which flag to use.
    write(&d.join("odm/opensfm"), &scene(&cam, true));
    let e = vp_scene::colmap::read_model(&d.join("odm"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("--opensfm"), "{e}");
}
