//! OpenSfM's `reconstruction.json`, read from a file OpenSfM wrote (its
//! Berlin example, tests/data/opensfm/README.md), checked against
//! OpenSfM's conventions computed here from its documented formulas
//! (axis-angle world-to-camera rotation, centre `-R^T t`, normalised image
//! coordinates by the larger side) and against where OpenSfM's feature
//! detector found the points (`tracks.csv`).

use std::path::{Path, PathBuf};

use serde_json::Value;
use vp_scene::colmap::{CameraModel, ColmapCamera};
use vp_scene::opensfm::{read_opensfm, ModelSource};

fn berlin() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/opensfm/berlin")
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn v3(v: &Value) -> [f64; 3] {
    let a = v.as_array().unwrap();
    [0, 1, 2].map(|i| a[i].as_f64().unwrap())
}

/// Rodrigues' formula, written out: the rotation of angle |r| about r.
fn rodrigues(r: [f64; 3]) -> [[f64; 3]; 3] {
    let th = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let k = r.map(|x| x / th);
    let (s, c) = th.sin_cos();
    let mut m = [[0.0; 3]; 3];
    let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            let kk: f64 = (0..3).map(|l| kx[i][l] * kx[l][j]).sum();
            m[i][j] = f64::from(u8::from(i == j)) + s * kx[i][j] + (1.0 - c) * kk;
        }
    }
    m
}

/// `R x + t`.
fn to_camera(shot: &Value, x: [f64; 3]) -> [f64; 3] {
    let r = rodrigues(v3(&shot["rotation"]));
    let t = v3(&shot["translation"]);
    [0, 1, 2].map(|i| (0..3).map(|j| r[i][j] * x[j]).sum::<f64>() + t[i])
}

/// OpenSfM's `perspective` projection to normalised image coordinates:
/// `focal * (1 + k1 r^2 + k2 r^4) * (x/z, y/z)`.
fn opensfm_perspective(cam: &Value, p: [f64; 3]) -> [f64; 2] {
    let (x, y) = (p[0] / p[2], p[1] / p[2]);
    let r2 = x * x + y * y;
    let k = |n: &str| cam[n].as_f64().unwrap_or(0.0);
    let d = 1.0 + k("k1") * r2 + k("k2") * r2 * r2;
    [k("focal") * d * x, k("focal") * d * y]
}

/// A COLMAP pixel (corner at 0) as OpenSfM's normalised coordinate.
fn normalised(cam: &ColmapCamera, px: (f64, f64)) -> [f64; 2] {
    let size = cam.width.max(cam.height) as f64;
    [
        (px.0 - cam.width as f64 / 2.0) / size,
        (px.1 - cam.height as f64 / 2.0) / size,
    ]
}

#[test]
fn berlin_cameras_shots_points_and_reference_as_opensfm_wrote_them() {
    let m = read_opensfm(&berlin()).unwrap();
    assert_eq!(m.file, berlin().join("reconstruction.json"));
    let rec = &m.reconstruction;
    assert_eq!(
        (rec.cameras.len(), rec.images.len(), rec.points.len()),
        (1, 3, 40)
    );
    let cam = &rec.cameras[&1];
    assert_eq!(cam.model, CameraModel::Radial);
    assert_eq!((cam.width, cam.height), (3264, 2448));
    // focal 0.8696658484855359 of the larger side; principal point at the
    // image centre (COLMAP's corner-at-0 pixels).
    assert!((cam.params[0] - 0.869_665_848_485_535_9 * 3264.0).abs() < 1e-9);
    assert_eq!(&cam.params[1..3], &[1632.0, 1224.0]);
    assert!(cam.is_distorted(), "k1, k2 kept: never a silent pinhole");
    let frame = m.frame.as_ref().unwrap();
    assert_eq!(
        (
            frame.origin.lat_deg,
            frame.origin.lon_deg,
            frame.origin.alt_m
        ),
        (52.518_962_962_962_95, 13.400_376_851_851_851, 0.0)
    );
    assert_eq!(m.reference_file.as_deref(), Some(m.file.as_path()));
    assert!((frame.sim3.scale - 1.0).abs() < 1e-15);
    // Point ids are OpenSfM's track ids.
    let file = json(&m.file);
    let r0 = &file[0];
    for (id, p) in r0["points"].as_object().unwrap() {
        let ours = &rec.points[&id.parse::<u64>().unwrap()];
        assert_eq!(ours.xyz.coords.as_slice(), &v3(&p["coordinates"]));
    }
    // Camera centres: -R^T t, with R from the axis-angle vector; and each
    // centre's distance to the shot's own GPS position is the frame's
    // residual (OpenSfM keeps both in the same topocentric frame).
    for im in rec.images.values() {
        let shot = &r0["shots"][&im.name];
        let r = rodrigues(v3(&shot["rotation"]));
        let t = v3(&shot["translation"]);
        let c: [f64; 3] = [0, 1, 2].map(|j| -(0..3).map(|i| r[i][j] * t[i]).sum::<f64>());
        let ours = im.center();
        for j in 0..3 {
            assert!(
                (ours[j] - c[j]).abs() < 1e-9,
                "{}: {ours} vs {c:?}",
                im.name
            );
        }
        let g = v3(&shot["gps_position"]);
        let d = ((c[0] - g[0]).powi(2) + (c[1] - g[1]).powi(2) + (c[2] - g[2]).powi(2)).sqrt();
        let res = frame.residuals.iter().find(|x| x.name == im.name).unwrap();
        assert!((res.residual_m - d).abs() < 1e-9);
        // OpenSfM's GPS prior held the centres within its 5 m DOP, about.
        assert!(d < 10.0, "{}: {d} m from its GPS position", im.name);
    }
}

#[test]
fn berlin_points_project_where_opensfm_projects_them_and_where_it_found_them() {
    let m = read_opensfm(&berlin()).unwrap();
    let file = json(&m.file);
    let r0 = &file[0];
    let cam_json = r0["cameras"].as_object().unwrap().values().next().unwrap();
    let cam = &m.reconstruction.cameras[&1];
    let size = 3264.0;
    let tracks = std::fs::read_to_string(berlin().join("tracks.csv")).unwrap();
    let mut errors_px = Vec::new();
    for line in tracks.lines().skip(1) {
        let f: Vec<&str> = line.split('\t').collect();
        let (name, track) = (f[0], f[1]);
        let seen = [f[3].parse::<f64>().unwrap(), f[4].parse::<f64>().unwrap()];
        let xyz = v3(&r0["points"][track]["coordinates"]);
        let pc = to_camera(&r0["shots"][name], xyz);
        let theirs = opensfm_perspective(cam_json, pc);
        // Our pose and our camera model, through the COLMAP projection.
        let im = m
            .reconstruction
            .images
            .values()
            .find(|i| i.name == name)
            .unwrap();
        let p = im.cam_from_world * nalgebra::Point3::from(xyz);
        let px = cam.img_from_cam(p.x / p.z, p.y / p.z).unwrap();
        let ours = normalised(cam, px);
        for k in 0..2 {
            assert!(
                (ours[k] - theirs[k]).abs() * size < 1e-6,
                "{name} point {track}: ours {ours:?} vs OpenSfM's {theirs:?}"
            );
        }
        errors_px.push(((ours[0] - seen[0]).hypot(ours[1] - seen[1])) * size);
    }
    assert_eq!(errors_px.len(), 120, "40 points in 3 photos");
    errors_px.sort_by(f64::total_cmp);
    let median = errors_px[errors_px.len() / 2];
    eprintln!(
        "Berlin: reprojection to OpenSfM's features, median {median:.3} px, max {:.3} px",
        errors_px[errors_px.len() - 1]
    );
    // OpenSfM's bundle adjustment left its reprojection errors at about a
    // pixel of the 3264-pixel photo; a wrong convention (principal point,
    // focal normalisation, rotation direction) puts them far off.
    assert!(median < 2.0, "median reprojection error {median} px");
}

#[test]
fn a_distorted_opensfm_camera_is_refused_for_planning_with_the_undistort_step() {
    let src = ModelSource::OpenSfm(berlin());
    let e = src.read_posed(true).unwrap_err().to_string();
    assert!(
        e.contains("reconstruction.json")
            && e.contains("reconstruction 0")
            && e.contains("v2 apple iphone4,1 3264 2448 perspective 0.9722")
            && e.contains("vpctl colmap undistort --opensfm"),
        "{e}"
    );
    // Read as it is, the full model is kept.
    assert!(src.read().unwrap().cameras[&1].is_distorted());
    assert_eq!(ModelSource::detect(&berlin()), src);
}

#[test]
fn berlin_tracks_become_observations_of_the_points() {
    let m = read_opensfm(&berlin()).unwrap();
    assert_eq!(m.observations, 120);
    let rec = &m.reconstruction;
    rec.validate().unwrap();
    assert!(rec.points.values().all(|p| p.track.len() == 3));
    let tracks = std::fs::read_to_string(berlin().join("tracks.csv")).unwrap();
    for line in tracks.lines().skip(1) {
        let f: Vec<&str> = line.split('\t').collect();
        let point = &rec.points[&f[1].parse::<u64>().unwrap()];
        let im = rec.images.values().find(|i| i.name == f[0]).unwrap();
        let &(_, idx) = point.track.iter().find(|(id, _)| *id == im.id).unwrap();
        let xy = im.points2d[idx as usize].xy;
        // Normalised (i + 0.5 - w/2) / size is COLMAP's i + 0.5.
        let x = f[3].parse::<f64>().unwrap() * 3264.0 + 1632.0;
        let y = f[4].parse::<f64>().unwrap() * 3264.0 + 1224.0;
        assert!((xy.x - x).abs() < 1e-9 && (xy.y - y).abs() < 1e-9);
    }
}
