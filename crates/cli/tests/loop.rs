//! The manual loop of the README (`scene generate -> plan grid -> sim fly
//! -> predict -> plan -> sim fly`) run as written, and `sim fly`'s outputs.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::vpctl_in as vpctl;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// The shell block after `<!-- recipe: NAME -->` in the README.
fn readme_recipe(name: &str) -> Vec<String> {
    let readme = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../README.md");
    let text = std::fs::read_to_string(readme).unwrap();
    let marker = format!("<!-- recipe: {name} -->");
    let start = text.find(&marker).expect("recipe marker in the README");
    let block = &text[start..];
    let body = block
        .split_once("```sh\n")
        .and_then(|(_, rest)| rest.split_once("```"))
        .expect("a sh block after the marker")
        .0;
    body.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(str::to_owned)
        .collect()
}

/// A folder whose `vpctl` is this build's binary, for `sh -c`.
fn path_with_vpctl() -> String {
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_vpctl"));
    let dir = bin.parent().unwrap().to_str().unwrap().to_owned();
    format!("{dir}:{}", std::env::var("PATH").unwrap_or_default())
}

/// The README promised a loop nobody could run (`vpctl plan ...` without
/// arguments, no command wrote a COLMAP model of the simulated world).
#[test]
fn readme_manual_loop_runs_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let lines = readme_recipe("manual-loop");
    assert!(lines.len() >= 8, "{lines:?}");
    for line in &lines {
        assert!(line.starts_with("vpctl "), "{line}");
        let o = Command::new("sh")
            .arg("-c")
            .arg(line)
            .current_dir(dir.path())
            .env("PATH", path_with_vpctl())
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "`{line}` failed: {}\n{}",
            text(&o.stdout),
            text(&o.stderr)
        );
    }
    let d = dir.path();
    // The second flight holds the grid's images and the plan's.
    let grid = std::fs::read_dir(d.join("flight1/images")).unwrap().count();
    let both = std::fs::read_dir(d.join("flight2/images")).unwrap().count();
    assert!(grid > 10, "{grid} grid images");
    assert!(both > grid, "{both} images after the plan, {grid} before");
    // flight2's model is a valid COLMAP model `plan` accepts.
    let o = vpctl(d, &["colmap", "info", "flight2/sparse"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains(&format!("images: {both}")),
        "{}",
        text(&o.stdout)
    );
    assert!(d.join("flight2/sparse/frame.json").is_file());
}

#[test]
fn sim_fly_writes_exact_binary_models_with_points_seen_twice() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("site.toml"),
        "[site]\nseed = 3\ntarget_faces = 8000\nsize = 40.0\n\
         [planner.camera]\nwidth = 240\nheight = 160\nfocal_px = 320.0\n",
    )
    .unwrap();
    let o = vpctl(
        d,
        &[
            "plan",
            "grid",
            "--mesh",
            "site.ply",
            "--out",
            "g.json",
            "--config",
            "site.toml",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "no mesh yet: {}", text(&o.stderr));
    let o = vpctl(
        d,
        &[
            "scene",
            "generate",
            "--config",
            "site.toml",
            "--out",
            "site.ply",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("faces: "), "{}", text(&o.stdout));
    let o = vpctl(
        d,
        &[
            "plan",
            "grid",
            "--mesh",
            "site.ply",
            "--config",
            "site.toml",
            "--height",
            "35",
            "--overlap",
            "0.6",
            "--out",
            "g.json",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let fly = |extra: &[&str]| {
        let mut args = vec![
            "sim",
            "fly",
            "g.json",
            "--site",
            "site.toml",
            "--out",
            "f",
            "--exact",
            "--output-type",
            "bin",
        ];
        args.extend_from_slice(extra);
        vpctl(d, &args)
    };
    let o = fly(&[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(
        text(&o.stdout).contains("exact poses"),
        "{}",
        text(&o.stdout)
    );
    for f in ["cameras.bin", "images.bin", "points3D.bin", "frame.json"] {
        assert!(d.join("f/sparse").join(f).is_file(), "{f}");
    }
    assert!(d.join("f/images/g_0000.png").is_file());
    // Every sparse point has a track of at least two images.
    let o = vpctl(d, &["colmap", "info", "f/sparse"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let info = text(&o.stdout);
    assert!(info.contains("points: "), "{info}");
    // A second run refuses to overwrite (exit 2), then --force does.
    let o = fly(&[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--force"), "{}", text(&o.stderr));
    assert!(fly(&["--force"]).status.success());
    // A QGroundControl file is not a plan: the error says what it is.
    std::fs::write(d.join("g.plan"), r#"{"fileType": "Plan", "version": 1}"#).unwrap();
    let o = vpctl(
        d,
        &["sim", "fly", "g.plan", "--site", "site.toml", "--out", "h"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("QGroundControl"),
        "{}",
        text(&o.stderr)
    );
}

/// Regression (issue 39): `sim fly --out <folder> --force` wrote into any
/// folder, the current one or one holding its plans included.
#[test]
fn sim_fly_never_deletes_what_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("in")).unwrap();
    std::fs::write(
        d.join("in/site.toml"),
        "[site]\nseed = 3\ntarget_faces = 8000\nsize = 40.0\n\
         [planner.camera]\nwidth = 240\nheight = 160\nfocal_px = 320.0\n",
    )
    .unwrap();
    let o = vpctl(
        d,
        &[
            "scene",
            "generate",
            "--config",
            "in/site.toml",
            "--out",
            "in/site.ply",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = vpctl(
        d,
        &[
            "plan",
            "grid",
            "--mesh",
            "in/site.ply",
            "--config",
            "in/site.toml",
            "--height",
            "35",
            "--overlap",
            "0.5",
            "--out",
            "in/g.json",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    common::assert_output_guards(
        d,
        &[
            "sim",
            "fly",
            "in/g.json",
            "--site",
            "in/site.toml",
            "--exact",
        ],
        "in",
    );
}
