//! `vpctl` as a user runs it: outputs, files and exit codes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn vpctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vpctl"))
        .args(args)
        .output()
        .expect("vpctl runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Test data of vp-scene: real files written by MeshLab and COLMAP.
fn scene_data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scene/tests/data")
        .join(rel)
}

#[test]
fn scene_generate_is_deterministic_and_refuses_to_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.ply");
    let b = dir.path().join("b.ply");
    let a_str = a.to_str().unwrap();
    let o = vpctl(&[
        "scene", "generate", "--seed", "3", "--faces", "20000", "--out", a_str,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("rock:"));
    let o = vpctl(&[
        "scene",
        "generate",
        "--seed",
        "3",
        "--faces",
        "20000",
        "--out",
        b.to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let (bytes_a, bytes_b) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert_eq!(bytes_a, bytes_b, "same seed must give the same bytes");

    // The file is a valid mesh of about the requested size, with materials.
    let o = vpctl(&["mesh", "info", a_str]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let faces: usize = text
        .lines()
        .find_map(|l| l.strip_prefix("faces: "))
        .and_then(|n| n.trim().parse().ok())
        .expect("faces line");
    assert!((18_000..=22_000).contains(&faces), "{faces} faces");
    assert!(
        text.contains("rock") && text.contains("problems: none"),
        "{text}"
    );

    // Without --force an existing file is left alone, with exit code 2.
    let o = vpctl(&[
        "scene", "generate", "--seed", "4", "--faces", "20000", "--out", a_str,
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("already exists"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&a).unwrap(), bytes_a);
    let o = vpctl(&[
        "scene", "generate", "--seed", "4", "--faces", "20000", "--out", a_str, "--force",
    ]);
    assert!(o.status.success());
    assert_ne!(std::fs::read(&a).unwrap(), bytes_a);
}

#[test]
fn mesh_info_reads_meshlab_and_obj_files() {
    let o = vpctl(&[
        "mesh",
        "info",
        scene_data("meshes/colored_airplane.ply").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("vertices: 7017") && text.contains("faces: 10796"),
        "{text}"
    );
    let o = vpctl(&[
        "mesh",
        "info",
        scene_data("meshes/cow.obj").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("faces: 5804"));
}

/// `mesh info` exited 2 both for "problems found" and for a missing file.
#[test]
fn mesh_info_reports_problems_with_their_own_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(
        &bad,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 2\n",
    )
    .unwrap();
    let o = vpctl(&["mesh", "info", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(8), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("1 faces using a non-finite vertex"), "{text}");
    assert!(text.contains("1 degenerate faces"), "{text}");
    assert!(stderr(&o).contains("bad.obj"));
}

#[test]
fn bad_and_missing_files_name_the_file_and_place() {
    let dir = tempfile::tempdir().unwrap();
    let trunc = dir.path().join("trunc.ply");
    std::fs::write(
        &trunc,
        b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0",
    )
    .unwrap();
    let o = vpctl(&["mesh", "info", trunc.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = stderr(&o);
    assert!(err.contains("trunc.ply") && err.contains("byte"), "{err}");
    assert!(!err.contains("panicked"));

    let missing = dir.path().join("nope.ply");
    let o = vpctl(&["mesh", "info", missing.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nope.ply"));

    let o = vpctl(&["colmap", "info", dir.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));

    let o = vpctl(&["mesh", "info"]);
    assert_eq!(o.status.code(), Some(2), "usage error");
}

#[test]
fn colmap_info_reads_a_model_written_by_colmap() {
    for form in ["sfm/bin", "sfm/txt"] {
        let o = vpctl(&[
            "colmap",
            "info",
            scene_data(&format!("colmap/{form}")).to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let text = stdout(&o);
        assert!(
            text.contains("images: 4") && text.contains("points: 140"),
            "{text}"
        );
        assert!(text.contains("SIMPLE_PINHOLE"), "{text}");
        assert!(text.contains("mean track length: 2.7"), "{text}");
    }
}

#[test]
fn depth_info_summarises_a_depth_map() {
    let o = vpctl(&[
        "depth",
        "info",
        scene_data("colmap/depth/ramp_5x3.geometric.bin")
            .to_str()
            .unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(text.contains("size: 5x3"), "{text}");
}

#[test]
fn mesh_build_meshes_colmap_points_and_refuses_too_few() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.ply");
    let model = scene_data("colmap/sfm/txt");
    let o = vpctl(&[
        "mesh",
        "build",
        "--colmap",
        model.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--max-edge",
        "10",
        "--method",
        "height-field",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("points: 140"), "{}", stdout(&o));
    let info = stdout(&vpctl(&["mesh", "info", out.to_str().unwrap()]));
    let faces: usize = info
        .lines()
        .find_map(|l| l.strip_prefix("faces: "))
        .and_then(|n| n.trim().parse().ok())
        .unwrap();
    assert!(faces > 100, "{info}");
    assert!(info.contains("problems: none"), "{info}");

    // Two points make no surface: exit 2 and no output file.
    let pts = dir.path().join("two.obj");
    std::fs::write(&pts, "v 0 0 0\nv 1 0 0\n").unwrap();
    let out2 = dir.path().join("none.ply");
    let o = vpctl(&[
        "mesh",
        "build",
        "--points",
        pts.to_str().unwrap(),
        "--out",
        out2.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!out2.exists());
}

/// A binary little-endian PLY in the layout of vp-mvs's fused.ply (x y z
/// nx ny nz as float, red green blue as uchar).
fn write_fused_ply(path: &Path, points: &[([f32; 3], [f32; 3])]) {
    let mut bytes = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nproperty float nx\nproperty float ny\n\
         property float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
         end_header\n",
        points.len()
    )
    .into_bytes();
    for (p, n) in points {
        for v in p.iter().chain(n) {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        bytes.extend_from_slice(&[128, 128, 128]);
    }
    std::fs::write(path, bytes).unwrap();
}

/// Faces of `mesh` whose centroid is within 1 m of the vertical axis and
/// within 0.2 m of height `z`.
fn faces_at(mesh: &vp_scene::Mesh, z: f64) -> usize {
    (0..mesh.n_faces())
        .filter(|&f| {
            let c = mesh.face_centroid(f);
            c.x.hypot(c.y) < 1.0 && (c.z - z).abs() < 0.2
        })
        .count()
}

#[test]
fn mesh_build_keeps_ground_under_a_roof_from_fused_points_unlike_the_height_field() {
    // Ground z = 0 over 16 m x 16 m, and a 6 m x 6 m slab at 3.8..4 m seen
    // from above and below (a canopy), on the same x-y grid.
    let mut pts = Vec::new();
    for i in 0..=64 {
        for j in 0..=64 {
            let (x, y) = (-8.0 + 0.25 * i as f32, -8.0 + 0.25 * j as f32);
            pts.push(([x, y, 0.0], [0.0, 0.0, 1.0]));
            if x.abs() <= 3.0 && y.abs() <= 3.0 {
                pts.push(([x, y, 4.0], [0.0, 0.0, 1.0]));
                pts.push(([x, y, 3.8], [0.0, 0.0, -1.0]));
            }
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let fused = dir.path().join("fused.ply");
    write_fused_ply(&fused, &pts);
    let build = |method: &str, out: &Path| {
        vpctl(&[
            "mesh",
            "build",
            "--points",
            fused.to_str().unwrap(),
            "--method",
            method,
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let out3d = dir.path().join("imls.ply");
    let o = build("imls", &out3d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("normals: 5475 given, 0 estimated"),
        "{}",
        stdout(&o)
    );
    let mesh = vp_scene::io::read_mesh(&out3d).unwrap();
    assert!(faces_at(&mesh, 0.0) > 10, "no ground under the roof");
    assert!(faces_at(&mesh, 4.0) > 10, "no roof");

    let out25 = dir.path().join("hf.ply");
    let o = build("height-field", &out25);
    assert!(o.status.success(), "{}", stderr(&o));
    let mesh = vp_scene::io::read_mesh(&out25).unwrap();
    assert_eq!(
        faces_at(&mesh, 0.0),
        0,
        "a height field keeps the highest point"
    );
    assert!(faces_at(&mesh, 4.0) > 10);

    // Points without normals and without cameras: a 3D surface cannot
    // orient them. Exit 2, the file named, no output.
    let obj = dir.path().join("pts.obj");
    let mut text = String::new();
    for (p, _) in &pts {
        writeln!(text, "v {} {} {}", p[0], p[1], p[2]).unwrap();
    }
    std::fs::write(&obj, text).unwrap();
    let out = dir.path().join("none.ply");
    let o = vpctl(&[
        "mesh",
        "build",
        "--points",
        obj.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("pts.obj: point 0 has no normal"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

#[test]
fn every_subcommand_has_help() {
    for args in [
        vec!["--help"],
        vec!["scene", "generate", "--help"],
        vec!["mesh", "info", "--help"],
        vec!["mesh", "build", "--help"],
        vec!["mission", "upload", "--help"],
        vec!["colmap", "info", "--help"],
        vec!["depth", "info", "--help"],
    ] {
        let o = vpctl(&args);
        assert!(o.status.success(), "{args:?}");
        assert!(stdout(&o).contains("Usage"), "{args:?}");
    }
}

/// A COLMAP dense workspace of three rendered 128x96 views of a small
/// site, without 3D points; returns a depth range covering the views.
fn mvs_workspace(dir: &Path) -> (f64, f64) {
    use vp_scene::colmap::{self, CameraModel, ColmapCamera, ColmapImage, Reconstruction};
    let site = vp_scene::procedural::generate_site(&vp_scene::procedural::SiteParams {
        seed: 2,
        target_faces: 20_000,
        ..Default::default()
    })
    .unwrap();
    let caster = vp_scene::raycast::RayCaster::new(&site.mesh);
    let k = vp_scene::Intrinsics::from_hfov(128, 96, 60.0).unwrap();
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let mut rec = Reconstruction::default();
    rec.cameras.insert(
        1,
        ColmapCamera {
            id: 1,
            model: CameraModel::Pinhole,
            width: 128,
            height: 96,
            params: vec![k.fx, k.fy, k.cx, k.cy],
        },
    );
    let target = nalgebra::Point3::new(0.0, 0.0, 2.0);
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for i in 0..3u32 {
        let a = f64::from(i) * 2.1;
        let centre = nalgebra::Point3::new(-12.0 + 2.5 * a.cos(), -12.0 + 2.5 * a.sin(), 18.0);
        let cam = vp_scene::Camera::look_at(k, centre, target).unwrap();
        let r =
            vp_sim::render(&site.mesh, &caster, &cam, &vp_sim::RenderParams::default()).unwrap();
        for &d in r.depth.data.iter().filter(|&&d| d > 0.0) {
            lo = lo.min(f64::from(d));
            hi = hi.max(f64::from(d));
        }
        let name = format!("im{i}.png");
        r.rgb.save(dir.join("images").join(&name)).unwrap();
        rec.images.insert(
            i + 1,
            ColmapImage {
                id: i + 1,
                camera_id: 1,
                name,
                cam_from_world: cam.cam_from_world(),
                points2d: Vec::new(),
            },
        );
    }
    colmap::write_text(&dir.join("sparse"), &rec).unwrap();
    (0.8 * lo, 1.2 * hi)
}

#[test]
fn mvs_run_writes_colmap_layout_and_refuses_bad_input() {
    let o = vpctl(&["mvs", "defaults"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let defaults = stdout(&o);
    assert!(defaults.contains("# Geometric filter"), "{defaults}");
    let parsed = vp_mvs::MvsParams::from_toml(Path::new("defaults"), &defaults).unwrap();
    assert_eq!(parsed, vp_mvs::MvsParams::default());

    let dir = tempfile::tempdir().unwrap();
    let ws = dir.path().join("ws");
    let (lo, hi) = mvs_workspace(&ws);
    let config = dir.path().join("mvs.toml");
    std::fs::write(&config, "iterations = 3\n").unwrap();
    let range = format!("{lo},{hi}");
    let ws_str = ws.to_str().unwrap();
    let cfg_str = config.to_str().unwrap();
    let args = [
        "mvs",
        "run",
        "--workspace",
        ws_str,
        "--depth-range",
        &range,
        "--config",
        cfg_str,
        "--images",
        "im0.png,im1.png,im2.png",
        "--seed",
        "4",
    ];
    let o = vpctl(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("fused: "), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("mvs: [1/3] patch match im0.png"),
        "{}",
        stderr(&o)
    );
    for i in 0..3 {
        for kind in ["photometric", "geometric"] {
            let d = ws.join(format!("stereo/depth_maps/im{i}.png.{kind}.bin"));
            assert!(vp_scene::colmap::read_depth_map(&d).unwrap().stats().valid > 0);
            assert!(ws
                .join(format!("stereo/normal_maps/im{i}.png.{kind}.bin"))
                .is_file());
        }
    }
    let fused = std::fs::read(ws.join("fused.ply")).unwrap();
    // Existing output is not overwritten without --force.
    let o = vpctl(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let mut forced = args.to_vec();
    forced.push("--force");
    let o = vpctl(&forced);
    assert!(o.status.success(), "{}", stderr(&o));
    // Same seed, same bytes.
    assert_eq!(std::fs::read(ws.join("fused.ply")).unwrap(), fused);

    // Bad input: exit 2 and a message naming the problem.
    let bad_range = format!("{hi},{lo}");
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws_str,
        "--depth-range",
        &bad_range,
        "--force",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("empty or inverted"), "{}", stderr(&o));
    let o = vpctl(&["mvs", "run", "--workspace", ws_str, "--force"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--depth-range"), "{}", stderr(&o));
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws_str,
        "--depth-range",
        &range,
        "--images",
        "im0.png",
        "--force",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("at least two"), "{}", stderr(&o));
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        dir.path().join("none").to_str().unwrap(),
        "--depth-range",
        &range,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn mvs_run_triplets_writes_the_layout_labelgen_reads() {
    use vp_labelgen::triplets::{write_triplet_list, Triplet};
    let dir = tempfile::tempdir().unwrap();
    let ws = dir.path().join("ws");
    let (lo, hi) = mvs_workspace(&ws);
    let list = dir.path().join("triplets.json");
    let images = ["im0.png", "im1.png", "im2.png"].map(String::from);
    write_triplet_list(
        &list,
        &[Triplet {
            bin: 1,
            angle_deg: 10.0,
            images,
        }],
    )
    .unwrap();
    let config = dir.path().join("mvs.toml");
    std::fs::write(&config, "iterations = 2\n").unwrap();
    let depth = dir.path().join("depth");
    let range = format!("{lo},{hi}");
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws.to_str().unwrap(),
        "--triplets",
        list.to_str().unwrap(),
        "--levels",
        "1,2",
        "--out",
        depth.to_str().unwrap(),
        "--depth-range",
        &range,
        "--config",
        config.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (level, w, h) in [(1, 128, 96), (2, 64, 48)] {
        for i in 0..3 {
            let p = depth.join(format!("t0000/level{level}/im{i}.png.geometric.bin"));
            let d = vp_scene::colmap::read_depth_map(&p).unwrap();
            assert_eq!((d.width, d.height), (w, h));
            assert!(d.stats().valid > 0, "{}", p.display());
        }
    }
    // A triplet naming an unknown image: exit 2, nothing written.
    let images = ["im0.png", "im1.png", "ghost.png"].map(String::from);
    write_triplet_list(
        &list,
        &[Triplet {
            bin: 1,
            angle_deg: 10.0,
            images,
        }],
    )
    .unwrap();
    let out2 = dir.path().join("depth2");
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws.to_str().unwrap(),
        "--triplets",
        list.to_str().unwrap(),
        "--out",
        out2.to_str().unwrap(),
        "--depth-range",
        &range,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("t0000") && stderr(&o).contains("ghost.png"),
        "{}",
        stderr(&o)
    );
    assert!(!out2.exists());
}

#[test]
fn colmap_undistort_writes_a_pinhole_workspace_and_refuses_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let data = scene_data("colmap/undistort/input");
    let (model, images) = (data.join("model"), data.join("images"));
    let ws = dir.path().join("ws");
    let run = |model: &Path, out: &Path| {
        vpctl(&[
            "colmap",
            "undistort",
            "--colmap",
            model.to_str().unwrap(),
            "--images",
            images.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let o = run(&model, &ws);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains("camera 3: SIMPLE_RADIAL 160x120 -> PINHOLE 167x122"),
        "{text}"
    );
    assert!(text.contains("wrote 11 undistorted images"), "{text}");
    let o = vpctl(&["colmap", "info", ws.join("sparse").to_str().unwrap()]);
    assert!(stdout(&o).contains("images: 11"), "{}", stdout(&o));
    assert!(ws.join("stereo/patch-match.cfg").is_file());
    // Refuses to overwrite: exit 2, names the folder.
    let o = run(&model, &ws);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("already exists"), "{}", stderr(&o));
    // An unknown camera model: exit 2, names the file and line, writes nothing.
    let bad = dir.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    for f in ["images.txt", "points3D.txt"] {
        std::fs::copy(model.join(f), bad.join(f)).unwrap();
    }
    let cams = std::fs::read_to_string(model.join("cameras.txt"))
        .unwrap()
        .replace("RADIAL_FISHEYE", "KANNALA_BRANDT");
    std::fs::write(bad.join("cameras.txt"), cams).unwrap();
    let out = dir.path().join("ws2");
    let o = run(&bad, &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("cameras.txt") && err.contains("line 9") && err.contains("KANNALA_BRANDT"),
        "{err}"
    );
    assert!(!out.exists());
    // An equirectangular camera has no pinhole: exit 2, names cameras.txt.
    let cams = "1 EQUIRECTANGULAR 160 120 160 120\n";
    let pano = dir.path().join("pano");
    std::fs::create_dir(&pano).unwrap();
    std::fs::write(pano.join("cameras.txt"), cams).unwrap();
    std::fs::write(
        pano.join("images.txt"),
        "1 1 0 0 0 0 0 0 1 m00_simple_pinhole.png\n\n",
    )
    .unwrap();
    std::fs::write(pano.join("points3D.txt"), "").unwrap();
    let o = run(&pano, &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cameras.txt") && stderr(&o).contains("EQUIRECTANGULAR"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// Positions CSV of the `sfm` model's four views (rendered from known
/// centres, reconstructed by COLMAP; see scene's data README): the true
/// centres in ENU metres at `origin`, plus `offsets` (noise, outliers).
fn sfm_positions(offsets: &[[f64; 3]; 4]) -> String {
    let frame = vp_mission::geodesy::LocalFrame::new(vp_scene::plan::GeodeticOrigin {
        lat_deg: 47.07,
        lon_deg: 15.44,
        alt_m: 350.0,
    })
    .unwrap();
    let mut csv = String::from("name,lat,lon,alt\n");
    for (i, az) in [-24.0f64, -8.0, 8.0, 24.0].iter().enumerate() {
        let az = az.to_radians();
        let enu = [
            8.0 * az.cos() - 2.0 + offsets[i][0],
            8.0 * az.sin() + offsets[i][1],
            5.0 + offsets[i][2],
        ];
        let g = frame.to_geodetic(enu);
        writeln!(
            csv,
            "view_{i:02}.png,{:.10},{:.10},{:.4}",
            g.lat_deg, g.lon_deg, g.alt_m
        )
        .unwrap();
    }
    csv
}

#[test]
fn colmap_align_recovers_metric_scale_and_flags_a_bad_position() {
    let dir = tempfile::tempdir().unwrap();
    let model = scene_data("colmap/sfm/txt");
    // 3 cm noise; view_02's position is 40 m off (a GPS glitch).
    let noise = [
        [0.03, -0.02, 0.01],
        [-0.01, 0.03, -0.02],
        [40.0, -10.0, 5.0],
        [0.02, 0.01, 0.03],
    ];
    std::fs::write(dir.path().join("pos.csv"), sfm_positions(&noise)).unwrap();
    let out = dir.path().join("aligned");
    let align = |csv: &str, out: &Path| {
        vpctl(&[
            "colmap",
            "align",
            "--colmap",
            model.to_str().unwrap(),
            "--positions",
            dir.path().join(csv).to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let o = align("pos.csv", &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    eprintln!("{text}");
    assert!(
        text.contains("positions: 3 of 4 used (1 outliers"),
        "{text}"
    );
    assert!(
        text.contains("view_02.png") && text.contains("(outlier)"),
        "{text}"
    );
    let frame = vp_scene::colmap::ModelFrame::load(&out).unwrap();
    assert!(frame.rms_m < 0.1, "rms {}", frame.rms_m);
    // Scale: aligned distances equal the true ones within 1 %.
    let rec = vp_scene::colmap::read_model(&out).unwrap();
    let c = |n: &str| {
        rec.images
            .values()
            .find(|im| im.name == n)
            .unwrap()
            .center()
    };
    let truth = |az: f64| {
        let a = az.to_radians();
        nalgebra::Point3::new(8.0 * a.cos() - 2.0, 8.0 * a.sin(), 5.0)
    };
    let true_d = (truth(-24.0) - truth(24.0)).norm();
    let d = (c("view_00.png") - c("view_03.png")).norm();
    let scale_error = (d / true_d - 1.0).abs();
    eprintln!(
        "scale error {:.4} %, rms {:.4} m",
        100.0 * scale_error,
        frame.rms_m
    );
    assert!(scale_error < 0.01, "scale error {scale_error}");
    // The aligned model plans: its frame passes the check.
    vp_scene::colmap::check_frame(&out, &rec).unwrap();
    // No overwrite.
    let o = align("pos.csv", &out);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn colmap_align_refuses_bad_positions_with_exit_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("aligned");
    let run = |model: &Path, csv: &str, body: &str| {
        let path = dir.path().join(csv);
        std::fs::write(&path, body).unwrap();
        vpctl(&[
            "colmap",
            "align",
            "--colmap",
            model.to_str().unwrap(),
            "--positions",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let sfm = scene_data("colmap/sfm/txt");
    let good = sfm_positions(&[[0.0; 3]; 4]);
    // Too few positions of model images.
    let two: String = good.lines().take(3).collect::<Vec<_>>().join("\n") + "\n";
    let o = run(&sfm, "two.csv", &two);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("two.csv") && stderr(&o).contains("at least 3"),
        "{}",
        stderr(&o)
    );
    // Inconsistent positions: no similarity explains most of them.
    let wild = "view_00.png,47.0,15.0,300\nview_01.png,47.001,15.0,300\n\
                view_02.png,47.0,15.0001,450\nview_03.png,47.0004,15.003,301\n";
    let o = run(&sfm, "wild.csv", wild);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("wild.csv") && stderr(&o).contains("inconsistent"),
        "{}",
        stderr(&o)
    );
    // A malformed line names the file and line.
    let o = run(
        &sfm,
        "bad.csv",
        "view_00.png,47.0,15.0,300\nview_01.png,north,15,300\n",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("bad.csv") && stderr(&o).contains("line 2"),
        "{}",
        stderr(&o)
    );
    // A model that cannot be aligned: the real visp-cube photos were taken
    // along a straight line, so the rotation about it is undetermined.
    let cube =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/real-mvs/visp-cube/sparse");
    let mut csv = String::new();
    for (k, i) in [17, 23, 30, 36, 43, 49, 56, 62, 69].iter().enumerate() {
        writeln!(
            csv,
            "cube_{i}.png,{},{},300",
            47.0 + 1e-5 * k as f64,
            15.0 + 2e-5 * (k % 3) as f64
        )
        .unwrap();
    }
    let o = run(&cube, "cube.csv", &csv);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("lie on a line"), "{}", stderr(&o));
    assert!(!out.exists(), "nothing written");
}
