//! The views people look at, checked by the tools that show them: `plan
//! --glb` and the report's `scene.glb` by the Khronos glTF validator (npm
//! `gltf-validator`), the report's `report.html` in headless Chromium
//! (npm `playwright-core` driving the system's Chromium).
//!
//! Needs node with `npm ci --prefix tests/js` run (scripts/test.sh does) and
//! Chromium at /usr/bin/chromium or $CHROMIUM. Without them these tests
//! FAIL, saying what to install: a view check that skips silently checks
//! nothing.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{plan_fixture, stderr, stdout, vpctl};

/// tests/js with its pinned node packages installed.
fn js_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/js");
    for pkg in ["gltf-validator", "playwright-core"] {
        assert!(
            dir.join("node_modules").join(pkg).is_dir(),
            "{pkg} is not installed in {}: run `npm ci --prefix tests/js` (scripts/test.sh does; \
             needs node and npm: `apt-get install -y nodejs npm`)",
            dir.display()
        );
    }
    dir
}

/// Runs a script of tests/js with node; its stdout is JSON lines.
fn node(script: &str, args: &[&Path]) -> (bool, Vec<serde_json::Value>, String) {
    let dir = js_dir();
    let o = Command::new("node")
        .arg(dir.join(script))
        .args(args)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run node ({e}): install nodejs and npm (`apt-get install -y nodejs npm`)"
            )
        });
    let lines = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    (o.status.success(), lines, stderr(&o))
}

/// The Khronos validator's report of one file: 0 errors, or the messages.
fn assert_valid_gltf(file: &Path) {
    let (ok, lines, err) = node("validate_gltf.cjs", &[file]);
    assert_eq!(lines.len(), 1, "validator output: {lines:?} {err}");
    let r = &lines[0];
    assert!(ok && r["errors"] == 0, "{}: {r}\n{err}", file.display());
}

/// The names of the nodes of a GLB (its JSON chunk).
fn node_names(glb: &[u8]) -> Vec<String> {
    assert_eq!(&glb[..4], b"glTF");
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + len]).unwrap();
    json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n["name"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn plan_glb_passes_the_khronos_validator_and_bad_paths_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let site = plan_fixture(dir.path());
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let b = site.rock_bounds;
    let roi = format!(
        "{},{},{},{},{},{}",
        b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
    );
    let plan = |out: &str, glb: &str| {
        vpctl(&[
            "plan",
            "--mesh",
            &p("site.ply"),
            "--colmap",
            &p("model"),
            "--config",
            &p("plan.toml"),
            "--roi-box",
            &roi,
            "--no-timings",
            "--out",
            &p(out),
            "--glb",
            &p(glb),
        ])
    };
    let o = plan("a.json", "a.glb");
    assert!(o.status.success(), "{}", stderr(&o));
    let glb_path = dir.path().join("a.glb");
    assert_valid_gltf(&glb_path);
    let glb = std::fs::read(&glb_path).unwrap();
    let names = node_names(&glb);
    for n in [
        "mesh",
        "acquired cameras",
        "plan: triplet views",
        "plan: flight path",
    ] {
        assert!(names.iter().any(|x| x == n), "{n} missing from {names:?}");
    }
    // Same inputs, same bytes.
    let o = plan("b.json", "b.glb");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(glb, std::fs::read(dir.path().join("b.glb")).unwrap());

    // A wrong extension, a missing folder: exit 2 naming the file, before
    // any work, and no output at all (not even the plan).
    for (glb, says) in [
        ("c.gltf", "c.gltf"),
        ("no/such/dir/c.glb", "does not exist"),
    ] {
        let o = plan("c.json", glb);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("--glb") && stderr(&o).contains(says),
            "{}",
            stderr(&o)
        );
        assert!(!dir.path().join("c.json").exists());
        assert!(!dir.path().join("c.gltf").exists());
    }
}

#[test]
fn report_scene_glb_validates_and_report_html_shows_the_table_in_chromium() {
    let dir = tempfile::tempdir().unwrap();
    // The quick preset on the virtual MVS stand-in: seconds, same files.
    let o = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cfg = dir.path().join("virtual.toml");
    std::fs::write(
        &cfg,
        stdout(&o).replace("mvs = \"patchmatch\"", "mvs = \"virtual\""),
    )
    .unwrap();
    let out = dir.path().join("report");
    let o = vpctl(&[
        "sim",
        "run",
        "--config",
        cfg.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    let glb = out.join("scene.glb");
    assert_valid_gltf(&glb);
    let names = node_names(&std::fs::read(&glb).unwrap());
    for n in ["mesh", "acquired cameras", "Grid: grid views"] {
        assert!(names.iter().any(|x| x == n), "{n} missing from {names:?}");
    }
    // A triplet strategy's path (which of F1x2 and NP1x2 plans anything on
    // the quick site depends on the planner, not on the writer).
    assert!(
        names
            .iter()
            .any(|x| x.ends_with(": flight path") && !x.starts_with("Grid")),
        "no triplet strategy's flight path in {names:?}"
    );

    let html = out.join("report.html");
    let shot = dir.path().join("report.png");
    let (ok, lines, err) = node("check_report.cjs", &[&html, &shot]);
    assert_eq!(lines.len(), 1, "{lines:?} {err}");
    let r = &lines[0];
    assert!(ok, "the page had errors: {r}\n{err}");
    // The table, its rows, the plots and the embedded plan views are there.
    let table = r["table_text"].as_str().unwrap();
    for row in ["strategy", "Init", "Grid", "F1x2", "NP1x2", "G+F1x2"] {
        assert!(table.contains(row), "{row} not in the table: {table}");
    }
    assert!(r["svgs"].as_u64().unwrap() >= 3, "{r}");
    assert!(r["images"]["total"].as_u64().unwrap() >= 2, "{r}");
    // The table is on the first screen, and the screenshot shows it: dark
    // text on the light cells, not a blank area.
    let b = &r["table_box"];
    let (x, y, w, h) = (
        b["x"].as_f64().unwrap(),
        b["y"].as_f64().unwrap(),
        b["width"].as_f64().unwrap(),
        b["height"].as_f64().unwrap(),
    );
    let img = vp_scene::raster::load_rgb(&shot).unwrap();
    assert!(
        y + h <= f64::from(img.height()) && x + w <= f64::from(img.width()),
        "table {b} outside the {}x{} screenshot",
        img.width(),
        img.height()
    );
    let mut dark = 0usize;
    let mut light = 0usize;
    for py in y as u32..(y + h) as u32 {
        for px in x as u32..(x + w) as u32 {
            let [r, g, b] = img.get_pixel(px, py).0;
            let l = (u32::from(r) + u32::from(g) + u32::from(b)) / 3;
            if l < 100 {
                dark += 1;
            } else if l > 200 {
                light += 1;
            }
        }
    }
    let area = (w * h) as usize;
    assert!(
        dark > area / 100 && light > area / 2,
        "table area {w}x{h}: {dark} dark and {light} light pixels"
    );
}
