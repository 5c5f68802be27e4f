//! `vpctl` as a user runs it: scene, mesh, COLMAP and depth files, help.

use std::fmt::Write as _;
use std::path::Path;

mod common;

use common::{scene_data, stderr, stdout, vpctl};

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

/// The PLY reader returns its warnings and the CLI prints them: a header
/// line without a keyword (old Blender exporters) reads as a comment, and
/// `mesh info` says so on standard error, naming the file and the line,
/// while its report on standard output stays clean.
#[test]
fn a_ply_read_with_a_warning_is_read_and_the_warning_printed() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("blender.ply");
    std::fs::write(
        &mesh,
        "ply\nformat ascii 1.0\nCreated by Blender3D 2.49\nelement vertex 3\nproperty float x\n\
         property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n\
         end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    let o = vpctl(&["mesh", "info", mesh.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("faces: 1"), "{}", stdout(&o));
    assert!(!stdout(&o).contains("warning"), "{}", stdout(&o));
    let err = stderr(&o);
    assert!(
        err.contains("warning: ")
            && err.contains(
                "blender.ply: line 3: header line without a PLY keyword read as a comment"
            ),
        "{err}"
    );
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

/// Regression (issue 39, item 6): `[site]`, `[render]`, `[training.site]`
/// and `[profile.*]` took a typo such as `sizee = 3` silently and ran with
/// the default; every section now refuses it with the file, line, column
/// and the valid keys, exit 2, nothing written.
#[test]
fn a_typo_in_any_config_section_is_refused_with_line_column_and_valid_keys() {
    let dir = tempfile::tempdir().unwrap();
    for (section, valid) in [
        ("site", "`size`"),
        ("render", "`shadows`"),
        ("training.site", "`size`"),
        ("profile.grass", "`angles_deg`"),
    ] {
        let cfg = dir.path().join("typo.toml");
        std::fs::write(&cfg, format!("seed = 1\n[{section}]\nsizee = 3\n")).unwrap();
        let out = dir.path().join("site.ply");
        let o = vpctl(&[
            "scene",
            "generate",
            "--config",
            cfg.to_str().unwrap(),
            "--faces",
            "5000",
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "[{section}]: {err}");
        assert!(
            err.contains("typo.toml: line 3: column 1: unknown field `sizee`, expected one of")
                && err.contains(valid),
            "[{section}]: {err}"
        );
        assert!(!out.exists(), "[{section}]");
    }
}

/// Issue 32: `scene generate --config` took the campaign's `[site]` through
/// the simulator's campaign config, so the keys a file left out took the
/// demo preset's site (44 m, 8 trees, a 12 m rock), not the site's own
/// documented defaults. It reads the `[site]` section alone now.
#[test]
fn scene_generate_config_takes_the_sites_own_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("c.toml");
    std::fs::write(&cfg, "seed = 1\n[site]\nseed = 3\n").unwrap();
    let out = dir.path().join("site.ply");
    let o = vpctl(&[
        "scene",
        "generate",
        "--config",
        cfg.to_str().unwrap(),
        "--faces",
        "5000",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let half = vp_scene::procedural::SiteParams::default().size / 2.0;
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        stdout.contains(&format!("flight volume: [{:.2}, {:.2},", -half, -half)),
        "{stdout}"
    );
}
