//! `vpctl sim render`: images, depth maps and exit codes.

use std::process::Output;

mod common;
use common::vpctl;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn sim_render_writes_a_deterministic_image_and_depth_map() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b, d) = (
        dir.path().join("a.png"),
        dir.path().join("b.png"),
        dir.path().join("a.bin"),
    );
    let args = |out: &str| {
        vec![
            "sim",
            "render",
            "--seed",
            "2",
            "--faces",
            "20000",
            "--width",
            "96",
            "--height",
            "64",
            "--from",
            "-30,-25,30",
            "--at",
            "0,0,0",
            "--out",
            out,
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>()
    };
    let mut first = args(a.to_str().unwrap());
    first.extend(["--depth".into(), d.to_str().unwrap().into()]);
    let o = vpctl(&first.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("rock:") && text.contains("surface:"),
        "{text}"
    );
    let o = vpctl(
        &args(b.to_str().unwrap())
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let image = vp_scene::raster::load_rgb(&a).unwrap();
    assert_eq!(image.dimensions(), (96, 64));
    let depth = vp_scene::colmap::read_depth_map(&d).unwrap();
    assert_eq!((depth.width, depth.height), (96, 64));
    assert!(depth.stats().valid_share > 0.5);
    // Refuses to overwrite without --force: input error, exit 2.
    let o = vpctl(
        &args(a.to_str().unwrap())
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn sim_render_rejects_bad_arguments_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let out = out.to_str().unwrap();
    let o = vpctl(&["sim", "render", "--from", "1,2", "--out", out]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("x,y,z"), "{}", stderr(&o));
    let o = vpctl(&[
        "sim", "render", "--faces", "20000", "--hfov", "200", "--out", out,
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("field of view"), "{}", stderr(&o));
    let o = vpctl(&[
        "sim", "render", "--faces", "20000", "--from", "0,0,5", "--at", "0,0,5", "--out", out,
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("same point"), "{}", stderr(&o));
    assert!(!dir.path().join("x.png").exists(), "no output on failure");
}
