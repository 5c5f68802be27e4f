//! `vpctl demo` and `vpctl sim run|config`: the table, the report files,
//! model reuse and exit codes.

use std::path::Path;
use std::process::{Command, Output};

fn vpctl(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vpctl"))
        .args(args)
        .output()
        .expect("vpctl runs")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

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
    assert!(stdout.contains("Label quality"), "{stdout}");
    // The report: table, CSV with one line per row, plots, plans and missions.
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(md.contains("| F1x2 |"));
    let csv = std::fs::read_to_string(out.join("table.csv")).unwrap();
    assert_eq!(csv.lines().count(), 7, "{csv}");
    for f in [
        "report.json",
        "curves.csv",
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
