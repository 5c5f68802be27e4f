//! `vpctl sim evaluate`: the forest scored leave-one-site-out on the quick
//! preset's training sites (forest_eval.csv, reliability diagrams, label
//! quality, measured success per angle), and the refusal of a single site.

use std::path::Path;
use std::process::Output;

mod common;
use common::{stderr, stdout, vpctl};

fn both(o: &Output) -> String {
    format!("{}{}", stdout(o), stderr(o))
}

/// The quick preset's config and its `site_seeds = ...` line.
fn quick_config() -> (String, String) {
    let quick = vpctl(&["sim", "config", "--preset", "quick"]);
    assert!(quick.status.success(), "{}", both(&quick));
    let toml = String::from_utf8(quick.stdout).unwrap();
    let seeds = toml
        .lines()
        .find(|l| l.starts_with("site_seeds = "))
        .expect("the quick preset lists its training sites")
        .to_string();
    (toml, seeds)
}

/// `vpctl sim evaluate` on two quick training sites: one row per fold,
/// material and angle bin whose pixels add up to the printed total; one
/// site is refused with the config named and nothing written.
#[test]
fn sim_evaluate_scores_each_held_out_site_and_refuses_a_single_site() {
    let dir = tempfile::tempdir().unwrap();
    let (toml, seeds) = quick_config();
    let write = |name: &str, line: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, toml.replace(&seeds, line)).unwrap();
        p
    };
    let one = write("one.toml", "site_seeds = [101]");
    let out = dir.path().join("eval-one");
    let o = vpctl(&[
        "sim",
        "evaluate",
        "--config",
        one.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", both(&o));
    assert!(
        both(&o).contains("one.toml") && both(&o).contains("at least 2"),
        "{}",
        both(&o)
    );
    assert!(!out.exists());

    let two = write("two.toml", "site_seeds = [101, 102]");
    let out = dir.path().join("eval");
    let o = vpctl(&[
        "sim",
        "evaluate",
        "--config",
        two.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", both(&o));
    let printed = String::from_utf8_lossy(&o.stdout).into_owned();
    let csv = std::fs::read_to_string(out.join("forest_eval.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some(
            "matcher,forest,fold,material,angle_bin,pixels,accuracy_labels,accuracy_truth,\
             majority_rate,brier,brier_angle_only"
        )
    );
    let mut folds = std::collections::BTreeSet::new();
    let mut pixels = 0u64;
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 11, "{l}");
        assert_eq!(f[0], "patchmatch");
        folds.insert(f[2].to_string());
        pixels += f[5].parse::<u64>().unwrap();
        let v: Vec<f64> = f[6..].iter().map(|x| x.parse().unwrap()).collect();
        assert!(v.iter().all(|x| (0.0..=1.0).contains(x)), "{l}");
        assert!(
            v[2] >= 0.5,
            "the majority label's share is at least half: {l}"
        );
    }
    assert_eq!(folds.into_iter().collect::<Vec<_>>(), ["101", "102"]);
    assert!(pixels > 0);
    assert!(
        printed.contains(&format!("over 2 folds, {pixels} labelled pixels")),
        "{printed}"
    );
    let summary = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(printed.starts_with(&summary), "{printed}\n---\n{summary}");

    check_angle_success(&out, &summary);
    check_reliability_and_label_quality(&out, pixels);

    // Same config and seed: the same bytes, file by file.
    let again = dir.path().join("eval-again");
    let o = vpctl(&[
        "sim",
        "evaluate",
        "--config",
        two.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", both(&o));
    let mut names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() >= 7, "{names:?}");
    for n in names {
        assert!(
            std::fs::read(out.join(&n)).unwrap() == std::fs::read(again.join(&n)).unwrap(),
            "{n:?} differs between two runs of one config"
        );
    }
}

/// `reliability.csv` (one line per forest, angle group and confidence bin:
/// its pixels are every labelled pixel scored, `pixels`, the diagram's PNG
/// beside it) and `label_quality.csv` (per material and angle bin, labelled
/// within surface, correct within labelled) of `vpctl sim evaluate` in `out`.
fn check_reliability_and_label_quality(out: &Path, pixels: u64) {
    let rel = std::fs::read_to_string(out.join("reliability.csv")).unwrap();
    let mut lines = rel.lines();
    assert_eq!(
        lines.next(),
        Some(
            "matcher,forest,angle_lo,angle_hi,conf_lo,conf_hi,pixels,mean_confidence,\
             label_success,truth_success"
        )
    );
    let mut sum = 0u64;
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 10, "{l}");
        sum += f[6].parse::<u64>().unwrap();
        let (lo, hi): (f64, f64) = (f[4].parse().unwrap(), f[5].parse().unwrap());
        let mean: f64 = f[7].parse().unwrap();
        assert!(mean >= lo - 1e-4 && mean <= hi + 1e-4, "{l}");
        assert!(out
            .join(format!("reliability_{}_{}.png", f[0], f[1]))
            .is_file());
    }
    assert_eq!(sum, pixels, "the diagram holds every scored pixel once");
    let q = std::fs::read_to_string(out.join("label_quality.csv")).unwrap();
    assert!(q.starts_with(
        "material,angle_bin,angle_lo,angle_hi,surface_pixels,labelled,labelled_share,correct,"
    ));
    let mut labelled = 0u64;
    for l in q.lines().skip(1) {
        let f: Vec<u64> = [4, 5, 7, 9, 10]
            .iter()
            .map(|&i| l.split(',').nth(i).unwrap().parse().unwrap())
            .collect();
        assert!(
            f[1] <= f[0] && f[2] <= f[1] && f[4] <= f[3] && f[3] <= f[1],
            "{l}"
        );
        labelled += f[1];
    }
    assert!(labelled >= pixels, "{labelled} labelled, {pixels} scored");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("data:image/png;base64,") && html.contains("label-quality-angle"));
}

/// `angle_success.csv` of `vpctl sim evaluate` in `out`: the matcher's
/// measured success per site, material and angle bin, and its fall from
/// 5-15 to 35-45 deg on ground and rock in `summary` where both ranges have
/// pixels on a site.
fn check_angle_success(out: &Path, summary: &str) {
    let success = std::fs::read_to_string(out.join("angle_success.csv")).unwrap();
    let mut lines = success.lines();
    assert_eq!(
        lines.next(),
        Some("matcher,site,material,angle_bin,angle_lo,angle_hi,visible,reconstructed,success")
    );
    let mut ranges = std::collections::BTreeMap::<&str, [bool; 2]>::new();
    for l in lines {
        let f: Vec<&str> = l.split(',').collect();
        assert_eq!(f.len(), 9, "{l}");
        assert!(f[1] == "101" || f[1] == "102", "{l}");
        let (lo, hi): (f64, f64) = (f[4].parse().unwrap(), f[5].parse().unwrap());
        let (visible, ok): (u64, u64) = (f[6].parse().unwrap(), f[7].parse().unwrap());
        assert!(visible > 0 && ok <= visible, "{l}");
        let share: f64 = f[8].parse().unwrap();
        assert!((share - ok as f64 / visible as f64).abs() < 1e-4, "{l}");
        if f[2] == "ground" || f[2] == "rock" {
            let r = ranges.entry(f[1]).or_default();
            r[0] |= lo >= 5.0 && hi <= 15.0;
            r[1] |= lo >= 35.0 && hi <= 45.0;
        }
    }
    let both = ranges.values().filter(|r| r[0] && r[1]).count();
    assert_eq!(
        summary.contains(&format!("mean over {both} sites: 5-15 deg")),
        both > 0,
        "{both} sites with both ranges:\n{summary}"
    );
}

/// `vpctl sim evaluate --versus`: the quick preset on PatchMatch against the
/// same sites on SGM. Each matcher's own files (the second's in versus/),
/// and cross.csv with each fold's labels of each matcher scored by both
/// matchers' fold forests, where the own forest's Brier score is the one
/// its own evaluation reports for that fold; configs whose training sites
/// differ are refused with nothing written.
#[test]
fn sim_evaluate_versus_scores_each_matchers_labels_with_both_forests() {
    let dir = tempfile::tempdir().unwrap();
    let (toml, seeds) = quick_config();
    let mvs = toml.lines().find(|l| l.starts_with("mvs = ")).unwrap();
    let pm = toml.replace(&seeds, "site_seeds = [101, 102]");
    let write = |name: &str, text: String| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let sgm = write("sgm.toml", pm.replace(mvs, "mvs = \"sgm\""));
    let pm = write("pm.toml", pm);
    let other_sites = write(
        "other.toml",
        toml.replace(&seeds, "site_seeds = [101, 103]"),
    );
    let run = |versus: &Path, out: &Path| {
        vpctl(&[
            "sim",
            "evaluate",
            "--config",
            pm.to_str().unwrap(),
            "--versus",
            versus.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let refused = dir.path().join("refused");
    let o = run(&other_sites, &refused);
    assert_eq!(o.status.code(), Some(2), "{}", both(&o));
    assert!(
        both(&o).contains("other.toml") && both(&o).contains("same training sites"),
        "{}",
        both(&o)
    );
    assert!(!refused.exists());

    let out = dir.path().join("eval");
    let o = run(&sgm, &out);
    assert!(o.status.success(), "{}", both(&o));
    let first = std::fs::read_to_string(out.join("forest_eval.csv")).unwrap();
    let second = std::fs::read_to_string(out.join("versus/forest_eval.csv")).unwrap();
    assert!(first.lines().skip(1).all(|l| l.starts_with("patchmatch,")));
    assert!(second.lines().skip(1).all(|l| l.starts_with("sgm,")));
    check_cross(&out, &first, &second);
    let summary = std::fs::read_to_string(out.join("summary.txt")).unwrap();
    assert!(
        summary.contains("on patchmatch's labels the patchmatch forest wins"),
        "{summary}"
    );
    assert!(
        summary.contains("on sgm's labels the sgm forest wins"),
        "{summary}"
    );
}

/// `cross.csv` in `out`: four rows per fold, both forests scoring the same
/// pixels, and the own forest's Brier score as the matcher's own
/// `forest_eval.csv` (`first`: PatchMatch's, `second`: SGM's) pools it.
fn check_cross(out: &Path, first: &str, second: &str) {
    // The own forest's pooled Brier score per fold, from forest_eval.csv.
    let own_brier = |csv: &str, fold: &str| {
        let (mut sum, mut n) = (0.0, 0.0);
        for f in csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect::<Vec<_>>())
        {
            if f[2] == fold {
                let px: f64 = f[5].parse().unwrap();
                sum += px * f[9].parse::<f64>().unwrap();
                n += px;
            }
        }
        sum / n
    };
    let cross = std::fs::read_to_string(out.join("cross.csv")).unwrap();
    let rows: Vec<Vec<&str>> = cross
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 8, "{cross}");
    for labels_of in ["patchmatch", "sgm"] {
        for fold in ["101", "102"] {
            let find = |forest_of: &str| {
                rows.iter()
                    .find(|r| r[0] == labels_of && r[1] == forest_of && r[2] == fold)
                    .unwrap_or_else(|| panic!("{labels_of} {forest_of} {fold}: {cross}"))
            };
            let (own, other) = (
                find(labels_of),
                find(if labels_of == "sgm" {
                    "patchmatch"
                } else {
                    "sgm"
                }),
            );
            assert_eq!(own[3], other[3], "both forests score the same pixels");
            let csv = if labels_of == "sgm" { second } else { first };
            let expected = own_brier(csv, fold);
            let got: f64 = own[5].parse().unwrap();
            assert!(
                (got - expected).abs() < 1e-3,
                "{labels_of} fold {fold}: {got} vs {expected}"
            );
        }
    }
}
