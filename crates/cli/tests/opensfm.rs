//! `vpctl plan --opensfm DIR`: an OpenDroneMap project plans as its
//! COLMAP twin does, and bad OpenSfM input exits 2 with nothing written.

mod common;

use std::path::Path;

use common::opensfm::as_opensfm;
use common::{plan_fixture, stderr, vpctl};
use serde_json::json;
use vp_scene::colmap;
use vp_scene::plan::Plan;

/// Gives the fixture's model the sparse points SfM would have found: every
/// 40th mesh vertex seen unoccluded from two images or more, with exact
/// observations in its track (the frame.json stays).
fn add_points(dir: &Path, mesh: &vp_scene::Mesh) {
    let model = dir.join("model");
    let rec = colmap::read_model(&model).unwrap();
    let cams: Vec<(String, vp_scene::Camera)> = rec
        .images
        .values()
        .map(|im| (im.name.clone(), rec.camera_of(im.id).unwrap()))
        .collect();
    let pts: Vec<_> = mesh.vertices.iter().step_by(40).copied().collect();
    let caster = vp_scene::raycast::RayCaster::new(mesh);
    let with_points = vp_labelgen::synthetic::sparse_model(&cams, &caster, &pts);
    assert!(
        with_points.points.len() > 100,
        "{}",
        with_points.points.len()
    );
    colmap::write_text(&model, &with_points).unwrap();
}

fn plan_args(dir: &Path, flag: &str, model: &str, out: &str) -> Vec<String> {
    let p = |f: &str| dir.join(f).to_str().unwrap().to_string();
    vec![
        "plan".into(),
        "--mesh".into(),
        p("site.ply"),
        flag.into(),
        p(model),
        "--config".into(),
        p("plan.toml"),
        "--out".into(),
        p(out),
        "--no-timings".into(),
    ]
}

fn run(v: &[String]) -> std::process::Output {
    vpctl(&v.iter().map(String::as_str).collect::<Vec<_>>())
}

#[test]
fn an_odm_project_plans_as_its_colmap_twin() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let site = plan_fixture(d);
    add_points(d, &site.mesh);
    // The fixture's config plans with exact positions (no position
    // margin): the twins then plan with the same small clearance. (Under
    // standard GNSS's margin the candidate set left two triplets of equal
    // gain, to 3e-15, and the 1e-15 rounding between the readers picked
    // either: a tie, not a reader difference.)
    as_opensfm(&d.join("model"), &d.join("odm"));
    // The same cameras, points and tracks read back from either.
    let a = colmap::read_model(&d.join("model")).unwrap();
    let b = vp_scene::opensfm::read_opensfm(&d.join("odm")).unwrap();
    let n_obs: usize = a.points.values().map(|p| p.track.len()).sum();
    assert_eq!(b.observations, n_obs);
    assert_eq!(a.points.len(), b.reconstruction.points.len());
    eprintln!("twin: {} points, {n_obs} observations", a.points.len());
    let o = run(&plan_args(d, "--colmap", "model", "colmap.json"));
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&plan_args(d, "--opensfm", "odm", "odm.json"));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("frame: "), "{}", stderr(&o));
    assert!(stderr(&o).contains("reconstruction.json"), "{}", stderr(&o));
    let a = Plan::load(&d.join("colmap.json")).unwrap();
    let b = Plan::load(&d.join("odm.json")).unwrap();
    assert_eq!(a.origin, b.origin);
    assert_eq!(a.waypoints.len(), b.waypoints.len());
    // The reconstructions differ by the rounding of a quaternion through an
    // axis-angle vector and back, and of pixels through normalised
    // coordinates: the plans by no more than that.
    let mut worst = 0.0f64;
    for (x, y) in a.waypoints.iter().zip(&b.waypoints) {
        let d: f64 = (0..3)
            .map(|k| (x.position[k] - y.position[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        worst = worst.max(d);
        assert!((x.yaw_deg - y.yaw_deg).abs() < 1e-6, "{x:?} vs {y:?}");
        assert!((x.pitch_deg - y.pitch_deg).abs() < 1e-6);
        assert_eq!(x.role, y.role);
    }
    eprintln!("largest waypoint difference, COLMAP vs OpenSfM input: {worst:e} m");
    assert!(worst < 1e-6, "{worst} m");
    // The surface from the sparse points, from either input.
    for (flag, model, out) in [
        ("--colmap", "model", "a.ply"),
        ("--opensfm", "odm", "b.ply"),
    ] {
        let o = vpctl(&[
            "mesh",
            "build",
            flag,
            d.join(model).to_str().unwrap(),
            "--method",
            "height-field",
            "--out",
            d.join(out).to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let ma = vp_scene::io::read_mesh(&d.join("a.ply")).unwrap();
    let mb = vp_scene::io::read_mesh(&d.join("b.ply")).unwrap();
    assert!(ma.faces.len() > 100, "{}", ma.faces.len());
    assert_eq!(ma.faces, mb.faces);
    let far = ma
        .vertices
        .iter()
        .zip(&mb.vertices)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max);
    assert!(far < 1e-6, "{far} m");
    // What the two frames say differently: OpenSfM's heights are the photos'
    // GPS altitudes (EGM96 on most drones); this frame.json says nothing.
    assert_eq!(a.vertical_datum, None);
    assert_eq!(
        b.vertical_datum,
        Some(vp_scene::datum::VerticalDatum::Egm96)
    );
}

#[test]
fn bad_opensfm_input_exits_2_naming_the_file_with_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    plan_fixture(d);
    as_opensfm(&d.join("model"), &d.join("odm"));
    let file = d.join("odm/opensfm/reconstruction.json");
    let good = std::fs::read_to_string(&file).unwrap();
    let cases = [
        (
            good.replace("\"perspective\"", "\"dual\""),
            vec![
                "reconstruction 0",
                "\"dual\" is not supported",
                "--camera-lens brown",
            ],
        ),
        (
            good.replace("\"k1\":0.0", "\"k1\":-0.1"),
            vec!["lens distortion", "vpctl colmap undistort --opensfm"],
        ),
        (
            good[..good.len() / 2].to_string(),
            vec!["not valid JSON", "line 1"],
        ),
    ];
    for (text, expect) in cases {
        assert_ne!(text, good);
        std::fs::write(&file, &text).unwrap();
        let o = run(&plan_args(d, "--opensfm", "odm", "x.json"));
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains("reconstruction.json"), "{err}");
        for e in expect {
            assert!(err.contains(e), "{e:?} in {err}");
        }
        assert!(!d.join("x.json").exists());
    }
    let o = run(&plan_args(d, "--opensfm", "nowhere", "x.json"));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("nowhere"), "{}", stderr(&o));
    // Both kinds at once is a usage error.
    let mut both = plan_args(d, "--opensfm", "odm", "x.json");
    both.extend(["--colmap".into(), d.join("model").to_str().unwrap().into()]);
    let o = run(&both);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!d.join("x.json").exists());
}

#[test]
fn colmap_undistort_takes_an_odm_project_and_keeps_its_reference() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Two nadir shots 40 m up, a brown lens with distortion.
    let shot = |x: f64| {
        json!({"camera": "c", "rotation": [std::f64::consts::PI, 0.0, 0.0],
                               "translation": [-x, 0.0, 40.0]})
    };
    let doc = json!([{
        "cameras": {"c": {"projection_type": "brown", "width": 64, "height": 48,
                          "focal_x": 0.8, "focal_y": 0.8, "k1": -0.1, "p2": 0.001}},
        "shots": {"a.png": shot(0.0), "b.png": shot(8.0)},
        "points": {"1": {"coordinates": [4.0, 0.0, 0.0], "color": [9, 9, 9]}},
        "reference_lla": {"latitude": 50.8, "longitude": -0.14, "altitude": 0.0},
    }]);
    std::fs::create_dir_all(d.join("odm/opensfm")).unwrap();
    std::fs::create_dir_all(d.join("odm/images")).unwrap();
    std::fs::write(d.join("odm/opensfm/reconstruction.json"), doc.to_string()).unwrap();
    for n in ["a.png", "b.png"] {
        image::RgbImage::from_pixel(64, 48, image::Rgb([120, 80, 40]))
            .save(d.join("odm/images").join(n))
            .unwrap();
    }
    let s = |p: &str| d.join(p).to_str().unwrap().to_string();
    let mut args: Vec<String> = ["colmap", "undistort", "--opensfm"]
        .map(String::from)
        .to_vec();
    args.extend([
        s("odm"),
        "--images".into(),
        s("odm/images"),
        "--out".into(),
        s("ws"),
    ]);
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let frame = colmap::ModelFrame::load(&d.join("ws/sparse")).unwrap();
    assert!((frame.origin.lat_deg - 50.8).abs() < 1e-12);
    let rec = colmap::read_model(&d.join("ws/sparse")).unwrap();
    assert_eq!(rec.cameras[&1].model, colmap::CameraModel::Pinhole);
    // A missing photo: exit 2, naming it, nothing written.
    std::fs::remove_file(d.join("odm/images/b.png")).unwrap();
    args[7] = s("ws2");
    let o = run(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("b.png"), "{}", stderr(&o));
    assert!(!d.join("ws2").exists());
}
