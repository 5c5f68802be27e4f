//! `vpctl plan`, `vpctl plan grid` and `vpctl config --defaults` as a user runs them.

use std::path::Path;
use std::process::{Command, Output};

use vp_planner::grid::{grid_views, GridParams};
use vp_scene::colmap::{self, CameraModel, ColmapCamera, ColmapImage, Reconstruction};
use vp_scene::io::{write_mesh, MeshFormat};
use vp_scene::plan::{Plan, Role};
use vp_scene::procedural::{generate_site, Site, SiteParams};
use vp_scene::{Aabb, Intrinsics};

fn vpctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vpctl"))
        .args(args)
        .output()
        .expect("vpctl runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A site mesh, a COLMAP model of an initial grid flight over it, and a small config.
fn fixture(dir: &Path) -> Site {
    let site = generate_site(&SiteParams {
        seed: 2,
        target_faces: 20_000,
        ..SiteParams::default()
    })
    .unwrap();
    write_mesh(
        &dir.join("site.ply"),
        &site.mesh,
        MeshFormat::PlyBinaryLittleEndian,
    )
    .unwrap();
    let k = Intrinsics {
        width: 1200,
        height: 800,
        fx: 1800.0,
        fy: 1800.0,
        cx: 600.0,
        cy: 400.0,
    };
    let b = site.rock_bounds;
    let c = nalgebra::center(&b.min, &b.max);
    let fp = Aabb {
        min: nalgebra::Point3::new(c.x - 22.0, c.y - 22.0, b.min.z),
        max: nalgebra::Point3::new(c.x + 22.0, c.y + 22.0, b.max.z),
    };
    let params = GridParams {
        height_m: 50.0,
        role: Role::Initial,
        ..GridParams::default()
    };
    let mut rec = Reconstruction::default();
    rec.cameras.insert(
        1,
        ColmapCamera {
            id: 1,
            model: CameraModel::Pinhole,
            width: 1200,
            height: 800,
            params: vec![1800.0, 1800.0, 600.0, 400.0],
        },
    );
    for (i, v) in grid_views(&fp, &params, k).unwrap().iter().enumerate() {
        let id = i as u32 + 1;
        rec.images.insert(
            id,
            ColmapImage {
                id,
                camera_id: 1,
                name: format!("img_{id:03}.jpg"),
                cam_from_world: v.to_camera(k).cam_from_world(),
                points2d: Vec::new(),
            },
        );
    }
    std::fs::create_dir_all(dir.join("model")).unwrap();
    colmap::write_text(&dir.join("model"), &rec).unwrap();
    // The model is already metric ENU: its frame is the identity.
    colmap::ModelFrame {
        origin: vp_scene::plan::GeodeticOrigin::default(),
        sim3: colmap::Sim3 {
            scale: 1.0,
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            translation: [0.0; 3],
        },
        rms_m: 0.0,
        residuals: Vec::new(),
    }
    .save(&dir.join("model"))
    .unwrap();
    let v = site.flight_volume;
    std::fs::write(
        dir.join("plan.toml"),
        format!(
            "n_triangles = 300\nn_surrogates = 600\nn_selected = 60\nn_triplets = 2\nflight_volume = [[{}, {}, {}], [{}, {}, {}]]\n",
            v.min.x, v.min.y, v.min.z, v.max.x, v.max.y, v.max.z
        ),
    )
    .unwrap();
    site
}

#[test]
fn plan_writes_plan_ply_and_png_and_refuses_to_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let site = fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let b = site.rock_bounds;
    let roi = format!(
        "{},{},{},{},{},{}",
        b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
    );
    let args = |out: &str| {
        vec![
            "plan".to_string(),
            "--mesh".into(),
            p("site.ply"),
            "--colmap".into(),
            p("model"),
            "--config".into(),
            p("plan.toml"),
            "--roi-box".into(),
            roi.clone(),
            "--out".into(),
            p(out),
            "--no-timings".into(),
        ]
    };
    let mut a = args("a.json");
    a.extend(["--ply".into(), p("cams.ply"), "--png".into(), p("top.png")]);
    let run = |v: &[String]| vpctl(&v.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(&a);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("waypoints:") && out.contains("6 triplet members"),
        "{out}"
    );
    assert!(stderr(&o).contains("triplet 1: mean f"), "{}", stderr(&o));
    let plan = Plan::load(&dir.path().join("a.json")).unwrap();
    assert_eq!(
        plan.waypoints
            .iter()
            .filter(|w| w.role == Role::TripletMember)
            .count(),
        6
    );
    assert_eq!(plan.safety_distance_m, Some(5.0));
    let png = std::fs::read(dir.path().join("top.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // The top view had no title, legend or colour key: the panel below
    // the map holds the legend swatches (triplet orange) and the f(t) ramp
    // from red to green.
    let img = vp_scene::raster::load_rgb(&dir.path().join("top.png")).unwrap();
    let panel: Vec<[u8; 3]> = (img.height() - 60..img.height())
        .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
        .map(|(x, y)| img.get_pixel(x, y).0)
        .collect();
    for colour in [[255, 150, 0], [255, 0, 40], [0, 255, 40], [235, 235, 235]] {
        assert!(panel.contains(&colour), "{colour:?} in the legend panel");
    }
    let cams = vp_scene::io::read_mesh(&dir.path().join("cams.ply")).unwrap();
    assert_eq!(cams.n_faces(), 6 * plan.waypoints.len());
    // Same inputs, same bytes.
    let o = run(&args("b.json"));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(dir.path().join("a.json")).unwrap(),
        std::fs::read(dir.path().join("b.json")).unwrap()
    );
    // No overwrite without --force, and exit 2.
    let o = run(&a);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("a.json"), "{}", stderr(&o));
}

#[test]
fn bad_inputs_exit_2_without_output() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    std::fs::write(dir.path().join("bad.toml"), "alpha = 3.0\n").unwrap();
    let o = vpctl(&[
        "plan",
        "--mesh",
        &p("site.ply"),
        "--colmap",
        &p("model"),
        "--config",
        &p("bad.toml"),
        "--out",
        &p("x.json"),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("bad.toml") && stderr(&o).contains("alpha = 3"),
        "{}",
        stderr(&o)
    );
    // ROI outside the mesh.
    let o = vpctl(&[
        "plan",
        "--mesh",
        &p("site.ply"),
        "--colmap",
        &p("model"),
        "--config",
        &p("plan.toml"),
        "--roi-box",
        "500,500,0,600,600,10",
        "--out",
        &p("x.json"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("selects no face"), "{}", stderr(&o));
    // An empty confidence folder: the error says to run `vpctl predict`;
    // one image's confidence missing: the error names its file.
    std::fs::create_dir(dir.path().join("conf")).unwrap();
    let plan_conf = || {
        vpctl(&[
            "plan",
            "--mesh",
            &p("site.ply"),
            "--colmap",
            &p("model"),
            "--config",
            &p("plan.toml"),
            "--confidence-dir",
            &p("conf"),
            "--out",
            &p("x.json"),
        ])
    };
    let o = plan_conf();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("vpctl predict"), "{}", stderr(&o));
    std::fs::write(dir.path().join("conf/other.jpg.vpconf"), b"").unwrap();
    let o = plan_conf();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("img_001.jpg.vpconf"), "{}", stderr(&o));
    assert!(!dir.path().join("x.json").exists());
}

#[test]
fn grid_and_config_defaults() {
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let o = vpctl(&[
        "plan",
        "grid",
        "--mesh",
        &p("site.ply"),
        "--height",
        "50",
        "--overlap",
        "0.5",
        "--out",
        &p("grid.json"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let plan = Plan::load(&dir.path().join("grid.json")).unwrap();
    // Default camera at 50 m: 75 m x 50 m footprint, steps 37.5 m and 25 m
    // over the 60 m site: 1 line of ceil((60-50)/25)+1 = 2 images.
    assert_eq!(plan.waypoints.len(), 2);
    assert!(plan
        .waypoints
        .iter()
        .all(|w| w.role == Role::Grid && (w.pitch_deg + 90.0).abs() < 1e-9));
    let o = vpctl(&["config", "--defaults"]);
    assert!(o.status.success());
    let text = String::from_utf8(o.stdout).unwrap();
    let cfg = vp_planner::PlannerConfig::from_toml(&text, Path::new("-")).unwrap();
    assert_eq!(cfg, vp_planner::PlannerConfig::default());
}

#[test]
fn plan_refuses_a_distorted_model_and_points_at_colmap_undistort() {
    // Regression: every COLMAP camera was approximated as a pinhole, so a
    // RADIAL/OPENCV model from real photos planned with the wrong geometry.
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let cams = dir.path().join("model/cameras.txt");
    let text = std::fs::read_to_string(&cams).unwrap();
    let line = text.lines().find(|l| !l.starts_with('#')).unwrap();
    let distorted = line.replace("PINHOLE", "OPENCV") + " -0.05 0.01 0 0";
    std::fs::write(&cams, text.replace(line, &distorted)).unwrap();
    let o = vpctl(&[
        "plan",
        "--mesh",
        &p("site.ply"),
        "--colmap",
        &p("model"),
        "--config",
        &p("plan.toml"),
        "--out",
        &p("x.json"),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("OPENCV") && err.contains("vpctl colmap undistort") && err.contains("model"),
        "{err}"
    );
    assert!(!dir.path().join("x.json").exists());
}

#[test]
fn plan_refuses_a_model_without_frame_unless_told() {
    // Regression: a raw COLMAP model (arbitrary scale and orientation) was
    // planned as if metric ENU, and no error said so.
    let dir = tempfile::tempdir().unwrap();
    fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    std::fs::remove_file(dir.path().join("model/frame.json")).unwrap();
    let args = |extra: &[&str]| {
        let mut v = vec![
            "plan".to_string(),
            "--mesh".into(),
            p("site.ply"),
            "--colmap".into(),
            p("model"),
            "--config".into(),
            p("plan.toml"),
            "--out".into(),
            p("x.json"),
            "--no-timings".into(),
        ];
        v.extend(extra.iter().map(|s| (*s).to_string()));
        v
    };
    let run = |v: &[String]| vpctl(&v.iter().map(String::as_str).collect::<Vec<_>>());
    let o = run(&args(&[]));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("frame.json")
            && err.contains("vpctl colmap align")
            && err.contains("--frame-unchecked"),
        "{err}"
    );
    assert!(!dir.path().join("x.json").exists());
    let o = run(&args(&["--frame-unchecked"]));
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    // Regression: views that could not be bridged appeared neither in the
    // output nor in the plan JSON.
    assert!(text.contains("unbridged views: [0]"), "{text}");
    let plan = Plan::load(&dir.path().join("x.json")).unwrap();
    assert_eq!(plan.unbridged, vec![0]);
    // A frame whose scale is implausible (cameras 1000x too far apart).
    colmap::ModelFrame {
        origin: vp_scene::plan::GeodeticOrigin::default(),
        sim3: colmap::Sim3 {
            scale: 1.0,
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            translation: [0.0; 3],
        },
        rms_m: 0.0,
        residuals: Vec::new(),
    }
    .save(&dir.path().join("model"))
    .unwrap();
    let model = colmap::read_model(&dir.path().join("model")).unwrap();
    let far = colmap::transform_reconstruction(
        &model,
        &colmap::Sim3 {
            scale: 1000.0,
            rotation_wxyz: [1.0, 0.0, 0.0, 0.0],
            translation: [0.0; 3],
        },
    );
    colmap::write_text(&dir.path().join("model"), &far).unwrap();
    let o = run(&args(&["--force"]));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("implausible scale"), "{}", stderr(&o));
}
