//! `vpctl demo` and `vpctl sim run|config`: the table, the report files,
//! model reuse and exit codes.

use std::path::{Path, PathBuf};
use std::process::Command;

use vp_forest::Forest;
use vp_scene::colmap::{read_model, ModelFrame, Reconstruction};
use vp_scene::plan::Plan;
use vp_scene::raster::ConfidenceImage;

mod common;
use common::vpctl;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A folder whose `vpctl` is this build's binary, for `sh -c`.
fn path_with_vpctl() -> String {
    let bin = PathBuf::from(env!("CARGO_BIN_EXE_vpctl"));
    let dir = bin.parent().unwrap().to_str().unwrap().to_owned();
    format!("{dir}:{}", std::env::var("PATH").unwrap_or_default())
}

/// `dir` (an `iter<i>-acquired` folder) holds a valid COLMAP model of
/// `n_images` images, sparse points seen at least twice, the site's frame,
/// a planning mesh, the ROI and, when `predicted`, a confidence file per image.
fn assert_acquired_model(dir: &Path, n_images: usize, predicted: bool) -> Reconstruction {
    let sparse = dir.join("sparse");
    let rec = read_model(&sparse).unwrap_or_else(|e| panic!("{}: {e}", sparse.display()));
    rec.validate().unwrap();
    assert_eq!(rec.images.len(), n_images, "{}", dir.display());
    assert!(rec.points.len() > 50, "{} points", rec.points.len());
    assert!(rec.points.values().all(|p| p.track.len() >= 2));
    ModelFrame::load(&sparse).unwrap();
    let mesh = vp_scene::io::read_mesh(&dir.join("mesh.ply")).unwrap();
    assert!(mesh.n_faces() > 100);
    vp_scene::roi::Roi::load(&dir.join("roi.json")).unwrap();
    if predicted {
        for img in rec.images.values() {
            let c = ConfidenceImage::load(&dir.join(format!("confidence/{}.vpconf", img.name)))
                .unwrap();
            let cam = &rec.cameras[&img.camera_id];
            assert_eq!(
                (u64::from(c.width()), u64::from(c.height())),
                (cam.width, cam.height)
            );
        }
    }
    rec
}

/// The triplets of a plan file: distinct triplet ids of its triplet views.
fn planned_triplets(plan: &Path) -> usize {
    let p = Plan::load(plan).unwrap();
    let mut ids: Vec<u32> = p
        .waypoints
        .iter()
        .filter(|w| w.role == vp_scene::plan::Role::TripletMember)
        .filter_map(|w| w.triplet_id)
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids.len()
}

/// Issue 34, item 4: `triplets.csv` holds one row per flown triplet (as
/// many as the one held-out site's plans hold), each with consistent
/// counts, success falls as the threshold rises, and `depth_error_rock.csv`
/// holds each flight's 52 bins adding up to its pixels; the report shows
/// both and draws Fig. 6 per flight.
fn check_triplet_outcomes(out: &Path, strategies: &[&str]) {
    let csv = std::fs::read_to_string(out.join("triplets.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("strategy,site,iteration,triplet,planned_angle_deg,roi_pixels,depth_pixels,within_pixels,depth_share,within_share,success")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == 11), "{csv}");
    for name in strategies {
        let mine: Vec<&Vec<&str>> = rows.iter().filter(|r| r[0] == *name).collect();
        let mut planned = 0;
        for i in 1.. {
            let p = out.join(format!("plans/{name}/iter{i}.json"));
            if !p.is_file() {
                break;
            }
            planned += planned_triplets(&p);
        }
        assert!(planned > 0, "{name}: no triplet planned");
        assert_eq!(
            mine.len(),
            planned,
            "{name}: one row per flown triplet\n{csv}"
        );
        let mut success = [0usize; 2];
        for r in &mine {
            let n: Vec<usize> = r[5..8].iter().map(|x| x.parse().unwrap()).collect();
            assert!(n[2] <= n[1] && n[1] <= n[0], "{r:?}");
            let angle: f64 = r[4].parse().expect("a planned angle");
            assert!((0.0..=90.0).contains(&angle), "{r:?}");
            let share: f64 = r[9].parse().unwrap();
            success[0] += usize::from(n[2] > 0);
            success[1] += usize::from(share >= 0.25);
        }
        assert!(success[0] >= success[1], "{name}: {success:?}");
    }
    let err = std::fs::read_to_string(out.join("depth_error_rock.csv")).unwrap();
    assert!(err.starts_with("strategy,bin,error_lo_m,error_hi_m,pixels,share,"));
    // Fig. 6 for the baselines too, as the paper's has the Grid.
    for name in ["Init", "Grid"].iter().chain(strategies) {
        let bins: Vec<Vec<&str>> = err
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|r| r[0] == *name)
            .collect();
        assert_eq!(bins.len(), 52, "{name}\n{err}");
        assert_eq!((bins[0][2], bins[51][3]), ("-inf", "inf"));
        let sum: u64 = bins.iter().map(|r| r[4].parse::<u64>().unwrap()).sum();
        assert_eq!(sum, bins[0][6].parse::<u64>().unwrap(), "{name}");
        let png = out.join(format!("depth_error_rock_{name}.png"));
        assert!(png.is_file(), "{}", png.display());
    }
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    for s in [
        "The outcome per triplet",
        "success > 0 px",
        "median predicted 1 sigma",
        "68.3 % within",
    ] {
        assert!(md.contains(s), "{s} missing from table.md");
    }
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("id=\"depth-error-rock\""));
}

/// The report in `out` names the forest it flew, saved to `model`: the
/// file's checksum, as the save message (in `stderr`), `report.json` and
/// `table.md` say it.
fn assert_the_report_names_the_forest(out: &Path, model: &Path, stderr: &str) {
    let forest = Forest::load(model).expect("the saved forest loads");
    let fingerprint = format!("{:016x}", forest.fingerprint());
    let file = std::fs::read(model).unwrap();
    let tail = file.last_chunk::<8>().unwrap();
    assert_eq!(fingerprint, format!("{:016x}", u64::from_le_bytes(*tail)));
    assert!(
        stderr.contains(&format!("(fingerprint {fingerprint})")),
        "{stderr}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["forest_fingerprint"], fingerprint.as_str());
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(md.contains(&format!("fingerprint {fingerprint}")), "{md}");
}

/// The demo wrote plans but not what they were planned from: nobody could
/// run `vpctl plan` on an iteration by hand.
#[test]
fn quick_demo_prints_the_table_and_writes_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let model = dir.path().join("forest.vpf");
    let o = vpctl(&[
        "demo",
        "--quick",
        "--out",
        s(&out),
        "--save-forest",
        s(&model),
    ]);
    assert!(o.status.success(), "stderr: {}", text(&o.stderr));
    // The forest is saved as soon as it is trained, before any flight: a
    // campaign that fails on a held-out site keeps hours of training.
    let stderr = text(&o.stderr);
    let saved = stderr.find("forest saved to").expect("saved, said");
    let flying = stderr.find("held-out site").expect("a held-out site");
    assert!(saved < flying, "{stderr}");
    assert_the_report_names_the_forest(&out, &model, &stderr);
    let stdout = text(&o.stdout);
    // One held-out site: no std column ("± 0.0" said nothing).
    assert!(!stdout.contains('±'), "{stdout}");
    for row in [
        "| Init |",
        "| Grid |",
        "| F1x2 |",
        "| NP1x2 |",
        "| G+F1x2 |",
        "| G+NP1x2 |",
    ] {
        assert!(stdout.contains(row), "{row} missing from\n{stdout}");
    }
    assert!(stdout.contains("spearman"), "{stdout}");
    // Issue 34, item 7: the curves measured apart on the flown triplets and
    // on the random set no planner chose.
    assert!(
        stdout.contains("measured on the random triplets"),
        "{stdout}"
    );
    assert!(stdout.contains("Label quality"), "{stdout}");
    // The report: table, CSV with one line per row, plots, plans and missions.
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(md.contains("| F1x2 |"));
    let csv = std::fs::read_to_string(out.join("table.csv")).unwrap();
    assert_eq!(csv.lines().count(), 7, "{csv}");
    for f in [
        "report.json",
        "curves.csv",
        "label_quality.csv",
        "config.toml",
        "confidence_rock.png",
        "plan_F1x2.png",
        "fulfillment_Grid.png",
        "fulfillment_Gplus_F1x2.png",
        "plans/F1x2/iter1.json",
        "plans/NP1x2/iter1.plan",
        "plans/Grid/iter1.plan",
        // Checked by the glTF validator and in Chromium in views.rs.
        "report.html",
        "scene.glb",
    ] {
        let p = out.join(f);
        assert!(
            p.is_file() && std::fs::metadata(&p).unwrap().len() > 0,
            "{f} missing"
        );
    }
    let plan: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("plans/F1x2/iter1.plan")).unwrap())
            .unwrap();
    assert_eq!(plan["fileType"], "Plan");
    assert!(plan["mission"]["items"]
        .as_array()
        .is_some_and(|a| !a.is_empty()));
    assert!(model.is_file());
    check_triplet_outcomes(&out, &["F1x2", "NP1x2"]);

    // What iteration 1 planned from: the initial flight's COLMAP model, its
    // confidence, the planning mesh and the ROI.
    let init = Plan::load(&out.join("plans/Init/iter1.json")).unwrap();
    let f = out.join("plans/F1x2/iter1-acquired");
    let rec = assert_acquired_model(&f, init.waypoints.len(), true);
    assert!(rec.images.values().all(|i| i.name.starts_with("init_")));
    let np = out.join("plans/NP1x2/iter1-acquired");
    assert_acquired_model(&np, init.waypoints.len(), false);
    assert!(
        !np.join("confidence").exists(),
        "NP plans without prediction"
    );
    // ... and the report says how to plan it again by hand: run as written.
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    let script = md
        .split_once("```sh\nA=plans/F1x2/iter1-acquired\n")
        .and_then(|(_, rest)| rest.split_once("```"))
        .map(|(body, _)| format!("A=plans/F1x2/iter1-acquired\n{body}"))
        .expect("a vpctl plan recipe in table.md");
    assert!(script.contains("vpctl plan "), "{script}");
    let o = Command::new("sh")
        .arg("-c")
        .arg(&script)
        .current_dir(&out)
        .env("PATH", path_with_vpctl())
        .output()
        .unwrap();
    assert!(o.status.success(), "`{script}`: {}", text(&o.stderr));
    let again = Plan::load(&out.join("again.json")).unwrap();
    assert!(!again.waypoints.is_empty(), "{}", text(&o.stdout));
    assert!(again.origin.is_some(), "the origin comes from frame.json");

    // The report exists: refused without --force (exit 2), nothing changed.
    let o = vpctl(&["demo", "--quick", "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "stderr: {}", text(&o.stderr));
    assert!(text(&o.stderr).contains("--force"));
}

/// The quick preset on the virtual MVS stand-in (seconds): the saved forest
/// is reused without training and gives the same table.
#[test]
fn a_saved_forest_is_reused_and_gives_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let o = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(o.status.success());
    let toml = text(&o.stdout);
    assert!(toml.contains("mvs = \"patchmatch\""), "{toml}");
    let cfg = dir.path().join("virtual.toml");
    std::fs::write(
        &cfg,
        toml.replace("mvs = \"patchmatch\"", "mvs = \"virtual\""),
    )
    .unwrap();
    let (first, again, model) = (
        dir.path().join("first"),
        dir.path().join("again"),
        dir.path().join("forest.vpf"),
    );
    let run = |out: &Path, model_flag: &str| {
        vpctl(&[
            "sim",
            "run",
            "--config",
            s(&cfg),
            "--out",
            s(out),
            model_flag,
            s(&model),
        ])
    };
    let o = run(&first, "--save-forest");
    assert!(o.status.success(), "stderr: {}", text(&o.stderr));
    let o2 = run(&again, "--forest");
    assert!(o2.status.success(), "stderr: {}", text(&o2.stderr));
    assert!(!text(&o2.stderr).contains("training site"));
    assert_eq!(
        std::fs::read_to_string(again.join("table.csv")).unwrap(),
        std::fs::read_to_string(first.join("table.csv")).unwrap(),
        "a saved and reloaded forest must give the same table"
    );
}

/// Each iteration's acquired model holds the images of the iterations
/// before it: iteration 2's is iteration 1's plus the images its plan took.
#[test]
fn each_iterations_acquired_model_adds_the_images_flown_before_it() {
    let dir = tempfile::tempdir().unwrap();
    let o = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(o.status.success());
    let toml = text(&o.stdout)
        .replace("mvs = \"patchmatch\"", "mvs = \"virtual\"")
        .replace(
            "strategies = [\"F1x2\", \"NP1x2\"]",
            "strategies = [\"F2x1\"]",
        );
    assert!(
        toml.contains("\"F2x1\"") && toml.contains("\"virtual\""),
        "{toml}"
    );
    let cfg = dir.path().join("q.toml");
    std::fs::write(&cfg, toml).unwrap();
    let out = dir.path().join("r");
    let o = vpctl(&["sim", "run", "--config", s(&cfg), "--out", s(&out)]);
    assert!(o.status.success(), "stderr: {}", text(&o.stderr));
    let plans = out.join("plans/F2x1");
    let init = Plan::load(&out.join("plans/Init/iter1.json")).unwrap();
    let iter1 = Plan::load(&plans.join("iter1.json")).unwrap();
    assert!(!iter1.waypoints.is_empty(), "iteration 1 planned nothing");
    let first = assert_acquired_model(&plans.join("iter1-acquired"), init.waypoints.len(), true);
    let second = assert_acquired_model(
        &plans.join("iter2-acquired"),
        init.waypoints.len() + iter1.waypoints.len(),
        true,
    );
    // The same initial images, with the same poses, then iteration 1's.
    for (id, img) in &first.images {
        assert_eq!(second.images[id].name, img.name);
        assert_eq!(second.images[id].cam_from_world, img.cam_from_world);
    }
    let added: Vec<&str> = second
        .images
        .values()
        .filter(|i| !first.images.contains_key(&i.id))
        .map(|i| i.name.as_str())
        .collect();
    assert_eq!(added.len(), iter1.waypoints.len());
    assert!(added.iter().all(|n| n.starts_with("iter1_")), "{added:?}");
    // The images iteration 1 added sit where its plan put them (to SfM's noise).
    for (name, w) in added.iter().zip(&iter1.waypoints) {
        let img = second.images.values().find(|i| i.name == *name).unwrap();
        let c = img.center();
        let d = (c - nalgebra::Point3::from(w.position)).norm();
        assert!(d < 2.0, "{name}: {d} m from its waypoint");
    }
}

#[test]
fn sim_config_prints_a_loadable_config_and_sim_run_checks_it() {
    let dir = tempfile::tempdir().unwrap();
    let o = vpctl(&["sim", "config"]);
    assert!(o.status.success());
    let toml = text(&o.stdout);
    let quick = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(quick.status.success() && text(&quick.stdout) != toml);
    let o2 = vpctl(&["sim", "config", "--preset", "nope"]);
    assert_eq!(o2.status.code(), Some(2));
    assert!(text(&o2.stderr).contains("expected one of demo, quick, paper"));
    assert!(toml.contains("held_out_seeds") && toml.contains("[training.forest]"));
    // A typo in the config: exit 2, the message names the file and the key.
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, toml.replace("roi_margin_m", "roi_margn_m")).unwrap();
    let o = vpctl(&[
        "sim",
        "run",
        "--config",
        s(&bad),
        "--out",
        s(&dir.path().join("r")),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("bad.toml") && err.contains("roi_margn_m"),
        "{err}"
    );
    // A missing config: exit 2.
    let o = vpctl(&["sim", "run", "--config", s(&dir.path().join("none.toml"))]);
    assert_eq!(o.status.code(), Some(2));
    // A broken model file: exit 2, no report left behind.
    let model = dir.path().join("broken.vpf");
    std::fs::write(&model, b"not a model").unwrap();
    let out = dir.path().join("r2");
    let o = vpctl(&["demo", "--quick", "--forest", s(&model), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2), "stderr: {}", text(&o.stderr));
    assert!(!out.exists());
}

/// The quick preset on the virtual MVS stand-in, written to `in/virtual.toml`.
fn virtual_quick_config(dir: &Path) {
    let o = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(o.status.success());
    std::fs::create_dir_all(dir.join("in")).unwrap();
    std::fs::write(
        dir.join("in/virtual.toml"),
        text(&o.stdout).replace("mvs = \"patchmatch\"", "mvs = \"virtual\""),
    )
    .unwrap();
}

/// Regression (issue 39): `sim run --out . --force` deleted every file in
/// the current folder, its own config included.
#[test]
fn sim_run_never_deletes_what_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    virtual_quick_config(dir.path());
    common::assert_output_guards(
        dir.path(),
        &["sim", "run", "--config", "in/virtual.toml"],
        "in",
    );
}

/// Regression (issue 39): `demo --quick --force --out .` deleted every file
/// in the current folder; `demo --force --out rep` deleted a user's files in rep/.
#[test]
fn demo_never_deletes_what_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    virtual_quick_config(dir.path());
    // A forest to read (an input): trained on the virtual stand-in, in seconds.
    let o = common::vpctl_in(
        dir.path(),
        &[
            "sim",
            "run",
            "--config",
            "in/virtual.toml",
            "--out",
            "first",
            "--save-forest",
            "in/forest.vpf",
        ],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    std::fs::remove_dir_all(dir.path().join("first")).unwrap();
    common::assert_output_guards(
        dir.path(),
        &["demo", "--quick", "--forest", "in/forest.vpf"],
        "in",
    );
}
