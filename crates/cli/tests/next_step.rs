//! Wrong files get errors that say what the file is, what was expected and
//! which command makes the right one (issue "What an operator sees").

use std::process::Output;

mod common;

use common::vpctl_in as vpctl;

fn refused(o: &Output, words: &[&str]) {
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    for w in words {
        assert!(e.contains(w), "missing {w:?} in: {e}");
    }
}

#[test]
fn a_mission_or_a_config_given_as_the_plan_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("m.waypoints"),
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t46.03\t10.35\t400\t1\n",
    )
    .unwrap();
    std::fs::write(d.join("plan.toml"), "[planner]\nseed = 1\n").unwrap();
    let o = vpctl(d, &["mission", "export", "m.waypoints", "--out", "x.plan"]);
    refused(&o, &["m.waypoints", "QGC WPL mission", "vpctl plan"]);
    let o = vpctl(d, &["mission", "export", "plan.toml", "--out", "x.plan"]);
    refused(&o, &["plan.toml", "TOML configuration", "vpctl plan"]);
    assert!(!d.join("x.plan").exists());
}

#[test]
fn an_image_given_as_the_forest_says_what_it_is_and_what_makes_a_forest() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::RgbImage::new(8, 6)
        .save(d.join("photo.png"))
        .unwrap();
    std::fs::create_dir(d.join("imgs")).unwrap();
    image::RgbImage::new(8, 6)
        .save(d.join("imgs/a.png"))
        .unwrap();
    let o = vpctl(
        d,
        &["predict", "--forest", "photo.png", "--out", "conf", "imgs"],
    );
    refused(&o, &["photo.png", "PNG image", "vpctl train"]);
    assert!(!d.join("conf").exists());
}

#[test]
fn a_folder_that_is_not_a_workspace_says_which_command_makes_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("photos")).unwrap();
    let o = vpctl(
        d,
        &["mvs", "run", "--workspace", "photos", "--out", "depth"],
    );
    refused(
        &o,
        &["photos", "not an MVS workspace", "vpctl colmap undistort"],
    );
}
