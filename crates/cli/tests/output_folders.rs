//! One rule for outputs in folders that do not exist, for every command:
//! refused before any work with one line naming the missing folder and the
//! `mkdir -p` that fixes it, exit 2, nothing written (vpctl creates the
//! output, never the folders above it, as gdal and COLMAP). And range
//! messages that say the range that is checked.

mod common;

use common::{stderr, vpctl};

/// The error part of stderr: one line, no "caused by" chain.
fn assert_one_line_naming(err: &str, folder: &str) {
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line expected: {err}");
    assert!(
        !err.contains("caused by") && !err.contains("No such file"),
        "{err}"
    );
    assert!(
        err.contains(&format!("the folder {folder} does not exist")),
        "{err}"
    );
    assert!(err.contains(&format!("mkdir -p {folder}")), "{err}");
}

#[test]
fn scene_generate_into_a_missing_folder_is_one_line_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nodir");
    let out = missing.join("x.ply");
    let o = vpctl(&[
        "scene",
        "generate",
        "--faces",
        "5000",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_one_line_naming(&stderr(&o), missing.to_str().unwrap());
    assert!(!missing.exists(), "no folder created");
}

#[test]
fn a_report_folder_in_a_missing_folder_is_refused_the_same_way() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nodir");
    let out = missing.join("report");
    let o = vpctl(&["demo", "--quick", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_one_line_naming(&stderr(&o), missing.to_str().unwrap());
    assert!(!missing.exists(), "no folder created");
}

/// A plan of two views with origin and home, for `mission export`.
const PLAN: &str = r#"{"format_version":1,
 "origin":{"lat_deg":46.03,"lon_deg":10.35,"alt_m":400.0},
 "home":{"position":{"lat_deg":46.03,"lon_deg":10.35,"alt_m":400.0},"source":"test"},
 "waypoints":[
  {"position":[0.0,10.0,30.0],"yaw_deg":0.0,"pitch_deg":-90.0,"role":"grid"},
  {"position":[10.0,10.0,30.0],"yaw_deg":0.0,"pitch_deg":-90.0,"role":"grid"}]}"#;

#[test]
fn speed_out_of_range_names_the_range_that_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("p.json");
    std::fs::write(&plan, PLAN).unwrap();
    for bad in ["NaN", "0", "-3", "50"] {
        let o = vpctl(&[
            "mission",
            "export",
            plan.to_str().unwrap(),
            "--format",
            "qgc",
            "--speed",
            bad,
        ]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "--speed {bad}: {err}");
        assert!(
            err.contains("allowed 0.5 to 20 m/s"),
            "--speed {bad}: {err}"
        );
        assert!(
            !err.contains("must be >= 0") && !err.contains("(> 0)"),
            "--speed {bad}: {err}"
        );
    }
    let missing = dir.path().join("nodir");
    let out = missing.join("m.plan");
    let o = vpctl(&[
        "mission",
        "export",
        plan.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_one_line_naming(&stderr(&o), missing.to_str().unwrap());
}
