//! What a new user runs into: one flag per kind of input with the old
//! spellings still working (and saying so), negative numbers reaching
//! validation, formats from extensions, errors that say what to do next,
//! no silent empty success. Each test names the habit it guards.

use std::path::Path;

mod common;
use common::vpctl_in as vpctl;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// A small site, its mesh and a grid plan over it in `dir`.
fn site(dir: &Path) {
    std::fs::write(
        dir.join("site.toml"),
        "[site]\nseed = 5\ntarget_faces = 8000\nsize = 40.0\n\
         [planner.camera]\nwidth = 240\nheight = 160\nfocal_px = 320.0\n",
    )
    .unwrap();
    let o = vpctl(
        dir,
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
}

/// `plan grid --height -10` failed with "unexpected argument '-1'": the
/// value never reached the check that says what is wrong with it.
#[test]
fn negative_numbers_reach_validation() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    site(d);
    let o = vpctl(
        d,
        &[
            "plan", "grid", "--mesh", "site.ply", "--height", "-10", "--out", "g.json",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(err.contains("height -10 m must be positive"), "{err}");
    assert!(!err.contains("unexpected argument"), "{err}");
    let o = vpctl(
        d,
        &[
            "plan",
            "grid",
            "--mesh",
            "site.ply",
            "--overlap",
            "-0.5",
            "--out",
            "g.json",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("overlaps -0.5"),
        "{}",
        text(&o.stderr)
    );
}

/// `scene generate --out s.obj` wrote... or failed naming a format the
/// user never chose; an unknown extension must be named.
#[test]
fn output_format_comes_from_the_extension() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = vpctl(
        d,
        &["scene", "generate", "--faces", "8000", "--out", "s.obj"],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let head = std::fs::read_to_string(d.join("s.obj")).unwrap();
    assert!(head.lines().any(|l| l.starts_with("v ")), "an OBJ file");
    let o = vpctl(
        d,
        &["scene", "generate", "--faces", "8000", "--out", "s.stl"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("'stl'"), "{}", text(&o.stderr));
    assert!(!d.join("s.stl").exists());
    // A format that contradicts the extension is refused, naming both.
    let o = vpctl(
        d,
        &[
            "scene", "generate", "--faces", "8000", "--out", "t.ply", "--format", "obj",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("--format obj") && err.contains(".ply"),
        "{err}"
    );
    // The names Python's write_mesh takes work on the CLI.
    let o = vpctl(
        d,
        &[
            "scene",
            "generate",
            "--faces",
            "8000",
            "--out",
            "a.ply",
            "--format",
            "ply-ascii",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(std::fs::read(d.join("a.ply"))
        .unwrap()
        .starts_with(b"ply\nformat ascii"));
}

/// `--roi` read like inline JSON but wanted a file: both work now.
#[test]
fn roi_takes_inline_json_or_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    site(d);
    let roi = r#"{"kind": "box", "min": [-6, -6, -10], "max": [6, 6, 20]}"#;
    let grid = |roi: &str, out: &str| {
        vpctl(
            d,
            &[
                "plan", "grid", "--mesh", "site.ply", "--height", "30", "--roi", roi, "--out", out,
            ],
        )
    };
    let o = grid(roi, "inline.json");
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::write(d.join("roi.json"), roi).unwrap();
    let o = grid("roi.json", "file.json");
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(
        std::fs::read(d.join("inline.json")).unwrap(),
        std::fs::read(d.join("file.json")).unwrap()
    );
    let o = grid(r#"{"kind": "sphere"}"#, "bad.json");
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--roi"), "{}", text(&o.stderr));
}

/// `--model` was a COLMAP folder in `labelgen` and a forest in `predict`;
/// the old spellings keep working, with a note on stderr.
#[test]
fn old_flag_spellings_work_with_a_deprecation_note() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("imgs")).unwrap();
    for flag in ["--model", "--forest"] {
        let o = vpctl(d, &["predict", flag, "nope.vpforest", "--out", "c", "imgs"]);
        assert_eq!(o.status.code(), Some(2), "{flag}");
        let err = text(&o.stderr);
        assert!(err.contains("nope.vpforest"), "{err}");
        assert_eq!(
            err.contains("`vpctl predict --model` is deprecated") && err.contains("--forest"),
            flag == "--model",
            "{err}"
        );
    }
    let o = vpctl(d, &["plan", "--help"]);
    let help = text(&o.stdout);
    assert!(help.contains("--colmap <DIR>"), "{help}");
    assert!(!help.contains("--cameras"), "hidden alias: {help}");
    let o = vpctl(
        d,
        &["labelgen", "triplets", "--model", "nope", "--out", "t.txt"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("use --colmap"),
        "{}",
        text(&o.stderr)
    );
}

/// Errors that only said what was wrong now say what to do next.
#[test]
fn errors_say_what_to_do_next() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    site(d);
    // A refused grid names the constraint.
    let o = vpctl(
        d,
        &[
            "plan", "grid", "--mesh", "site.ply", "--height", "1", "--out", "g.json",
        ],
    );
    assert!(!o.status.success());
    let err = text(&o.stderr);
    assert!(
        err.contains("safety distance") && err.contains("--height"),
        "{err}"
    );
    // A plan without geodetic origin: the mission error mentions --origin.
    let o = vpctl(
        d,
        &[
            "plan", "grid", "--mesh", "site.ply", "--height", "30", "--out", "g.json",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = vpctl(d, &["mission", "export", "g.json", "--out", "g.plan"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("--origin"), "{}", text(&o.stderr));
    // With an origin it exports; the .plan handed back is named for what it is.
    let o = vpctl(
        d,
        &[
            "plan",
            "grid",
            "--mesh",
            "site.ply",
            "--height",
            "30",
            "--origin",
            "46.03,10.35,400",
            // The generated site's origin is on its ground: the take-off point.
            "--home",
            "46.03,10.35,400",
            "--out",
            "o.json",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = vpctl(d, &["mission", "export", "o.json", "--out", "o.plan"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let o = vpctl(d, &["mission", "export", "o.plan"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("QGroundControl plan"),
        "{}",
        text(&o.stderr)
    );
}

/// Empty inputs and results: a message saying what to run, never exit 0
/// with nothing written.
#[test]
fn empty_inputs_and_results_are_not_silent() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    site(d);
    let o = vpctl(
        d,
        &[
            "plan", "grid", "--mesh", "site.ply", "--height", "30", "--out", "o.json",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    // An empty confidence folder: run `vpctl predict`.
    let o = vpctl(
        d,
        &["sim", "fly", "o.json", "--site", "site.toml", "--out", "f"],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::create_dir(d.join("conf")).unwrap();
    let o = vpctl(
        d,
        &[
            "plan",
            "--mesh",
            "site.ply",
            "--colmap",
            "f/sparse",
            "--confidence-dir",
            "conf",
            "--out",
            "p.json",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("vpctl predict"),
        "{}",
        text(&o.stderr)
    );
    // No triplet found is not a silent success.
    let o = vpctl(
        d,
        &[
            "labelgen",
            "triplets",
            "--colmap",
            "f/sparse",
            "--min-shared-points",
            "1000000",
            "--out",
            "t.txt",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stdout));
    assert!(
        text(&o.stderr).contains("no triplet"),
        "{}",
        text(&o.stderr)
    );
    assert!(!d.join("t.txt").exists());
    // Predicting on an empty folder fails, naming what it looked for.
    std::fs::create_dir(d.join("empty")).unwrap();
    let o = vpctl(
        d,
        &["predict", "--forest", "x.vpforest", "--out", "c", "empty"],
    );
    assert_eq!(o.status.code(), Some(2));
}

/// File formats and exit codes were documented only in rustdoc and source.
#[test]
fn formats_doc_lists_every_own_file_and_exit_code() {
    let doc = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/formats.md"),
    )
    .unwrap();
    for code in 0..=8 {
        assert!(doc.contains(&format!("\n| {code} |")), "exit code {code}");
    }
    for what in [
        "`format_version` 1",
        "VPCONF",
        "VPLABEL",
        "VPFOREST",
        "vpctl labelgen triplets v1",
        "frame.json",
        "vpctl config --defaults",
        "vpctl sim config",
    ] {
        assert!(doc.contains(what), "{what}");
    }
}

/// Output extensions were not checked: `plan --png x.jpg` wrote a PNG named
/// .jpg, `mission export --out m.txt` a QGC file named .txt.
#[test]
fn output_extensions_are_checked_and_pick_the_format() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    site(d);
    let grid = |extra: &[&str]| {
        let mut args = vec![
            "plan",
            "grid",
            "--mesh",
            "site.ply",
            "--height",
            "30",
            "--origin",
            "46.03,10.35,400",
            "--home",
            "46.03,10.35,400",
        ];
        args.extend_from_slice(extra);
        vpctl(d, &args)
    };
    let o = grid(&["--out", "g.json", "--png", "top.jpg"]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("--png") && err.contains("'.jpg'") && err.contains(".png"),
        "{err}"
    );
    assert!(!d.join("g.json").exists(), "refused before any output");
    let o = grid(&["--out", "g.txt"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("'.txt'"), "{}", text(&o.stderr));
    let o = grid(&["--out", "g.json", "--png", "top.png"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    // mission export: the format from the extension; a contradiction is refused.
    let o = vpctl(d, &["mission", "export", "g.json", "--out", "m.waypoints"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(std::fs::read_to_string(d.join("m.waypoints"))
        .unwrap()
        .starts_with("QGC WPL 110"));
    let o = vpctl(d, &["mission", "export", "g.json", "--out", "m.plan"]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(std::fs::read_to_string(d.join("m.plan"))
        .unwrap()
        .contains("\"fileType\""));
    let o = vpctl(
        d,
        &[
            "mission", "export", "g.json", "--format", "qgc", "--out", "n.txt",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("'.txt'"), "{}", text(&o.stderr));
    // (.kml is the Google Earth preview now: a shapefile is no mission.)
    let o = vpctl(d, &["mission", "export", "g.json", "--out", "m.shp"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("'.shp'"), "{}", text(&o.stderr));
}
