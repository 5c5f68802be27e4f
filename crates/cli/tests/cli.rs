//! `vpctl` as a user runs it: outputs, files and exit codes.

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

#[test]
fn mesh_info_reports_problems_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(
        &bad,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 2\n",
    )
    .unwrap();
    let o = vpctl(&["mesh", "info", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
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
