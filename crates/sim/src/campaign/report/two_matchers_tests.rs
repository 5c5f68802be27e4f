use std::path::Path;

use serde_json::Value;

use super::*;

fn fig(coverage: f64, f: f64, success: f64, images: f64) -> Figures {
    Figures {
        coverage,
        f,
        success: Some(success),
        images,
    }
}

/// A site whose F and NP reach `f` and `np`, with triplet successes `fs`
/// and `ns`, F's triplets planned at `angles`, and a Grid and an oblique
/// capture F out-covers.
fn site(seed: u64, (f, np): (f64, f64), (fs, ns): (f64, f64), angles: &[f64]) -> SiteFigures {
    let mut s = SiteFigures {
        seed,
        ..SiteFigures::default()
    };
    s.strategies.insert("F5x4".into(), fig(90.0, f, fs, 60.0));
    s.strategies.insert("NP5x4".into(), fig(88.0, np, ns, 60.0));
    s.strategies
        .insert("Grid".into(), fig(80.0, 20.0, 100.0, 72.0));
    s.strategies
        .insert("Oblique".into(), fig(85.0, 20.0, 100.0, 60.0));
    s.planned_angles.insert("F5x4".into(), angles.to_vec());
    s
}

fn campaign(matcher: &str, sites: Vec<SiteFigures>) -> MatcherCampaign {
    MatcherCampaign {
        matcher: matcher.into(),
        sites,
        forest: None,
    }
}

fn verdict<'a>(c: &'a Comparison, name: &str) -> &'a Verdict {
    c.verdicts.iter().find(|v| v.name == name).unwrap()
}

/// SGM's F ahead on 7 of 8 sites with narrower plans, PatchMatch's even:
/// H3, H4 and H5 hold; one more site where SGM's F trails breaks H4's count.
#[test]
fn hypotheses_count_sites_as_the_issue_fixed_them() {
    let sgm: Vec<SiteFigures> = (1..=8)
        .map(|i| {
            let gap = if i == 8 { -1.0 } else { 5.0 };
            site(i, (40.0 + gap, 40.0), (100.0, 60.0), &[7.5, 12.5])
        })
        .collect();
    let pm: Vec<SiteFigures> = (1..=8)
        .map(|i| {
            site(
                i,
                (40.0, 40.0 + 0.1 * i as f64),
                (97.0, 95.0),
                &[32.5, 42.5],
            )
        })
        .collect();
    let c = compare(
        &campaign("sgm", sgm.clone()),
        &campaign("patchmatch", pm.clone()),
        ("F5x4", "NP5x4"),
        3,
    )
    .unwrap();
    assert!(verdict(&c, "H3").holds, "{}", c.markdown());
    assert!(verdict(&c, "H3").figures.contains("on 8 of 8 sites"));
    assert!(verdict(&c, "H4").holds, "{}", c.markdown());
    assert!(verdict(&c, "H4").figures.contains("on 7 of 8 sites"));
    assert!(verdict(&c, "H5").holds, "{}", c.markdown());
    assert!(verdict(&c, "H6 (sgm)").holds && verdict(&c, "H6 (patchmatch)").holds);
    assert!(
        c.markdown().contains("| 8 | 39.0 | 40.0 | -1.0 |"),
        "{}",
        c.markdown()
    );

    // Two sites behind: 6 of 8 is not enough for H4.
    let mut sgm2 = sgm;
    sgm2[0] = site(1, (39.0, 40.0), (100.0, 60.0), &[7.5]);
    let c = compare(
        &campaign("sgm", sgm2),
        &campaign("patchmatch", pm.clone()),
        ("F5x4", "NP5x4"),
        3,
    )
    .unwrap();
    assert!(!verdict(&c, "H4").holds, "{}", c.markdown());
    // The same gaps on both matchers: the interval of the difference holds 0.
    let c = compare(
        &campaign("sgm", pm.clone()),
        &campaign("patchmatch", pm),
        ("F5x4", "NP5x4"),
        3,
    )
    .unwrap();
    assert!(
        !verdict(&c, "H4").holds && !verdict(&c, "H3").holds,
        "{}",
        c.markdown()
    );
}

/// H6 needs F to out-cover the Grid with fewer images and the oblique
/// capture; H5 needs PatchMatch's F and NP within 5 points; different sites
/// are refused.
#[test]
fn coverage_success_and_site_rules() {
    let sites = |n: u64| -> Vec<SiteFigures> {
        (1..=n)
            .map(|i| site(i, (41.0, 40.0), (100.0, 80.0), &[10.0]))
            .collect()
    };
    let mut poor = sites(8);
    for s in poor.iter_mut().take(3) {
        s.strategies.get_mut("F5x4").unwrap().coverage = 84.0; // below the oblique's 85
    }
    let mut far = sites(8);
    for s in &mut far {
        s.strategies.get_mut("NP5x4").unwrap().success = Some(90.0); // F 100: 10 points
    }
    let c = compare(
        &campaign("sgm", poor),
        &campaign("patchmatch", far),
        ("F5x4", "NP5x4"),
        1,
    )
    .unwrap();
    assert!(!verdict(&c, "H6 (sgm)").holds, "{}", c.markdown());
    assert!(verdict(&c, "H6 (sgm)")
        .figures
        .contains("on 5 of 8 sites (needs 6)"));
    assert!(verdict(&c, "H6 (sgm)").figures.contains(
        "more than the Grid on 8 (with fewer images on 8), more than the oblique capture on 5"
    ));
    assert!(verdict(&c, "H6 (patchmatch)").holds);
    assert!(!verdict(&c, "H5").holds, "{}", c.markdown());
    let e = compare(
        &campaign("sgm", sites(8)),
        &campaign("patchmatch", sites(7)),
        ("F5x4", "NP5x4"),
        1,
    );
    assert!(e.unwrap_err().to_string().contains("same held-out sites"));
    // One site: every count needs 1 of 1.
    let c = compare(
        &campaign("sgm", sites(1)),
        &campaign("patchmatch", sites(1)),
        ("F5x4", "NP5x4"),
        1,
    )
    .unwrap();
    assert!(
        verdict(&c, "H4")
            .figures
            .contains("on 1 of 1 sites (needs 1)"),
        "{}",
        c.markdown()
    );
}

/// A `report.json` as `sim run` writes it (the fields compare reads) for
/// `matcher` and the sites `seeds`, in `dir`, flown with `forest` (a
/// fingerprint; `None`: a report from before they were recorded).
fn write_report_json(dir: &Path, matcher: &str, seeds: &[u64]) {
    write_report_json_with(dir, matcher, seeds, None);
}

fn write_report_json_with(dir: &Path, matcher: &str, seeds: &[u64], forest: Option<&str>) {
    write_report_json_f(dir, (matcher, forest), seeds, |s| 40.0 + s as f64);
}

/// As [`write_report_json_with`], F5x4's f on site `s` being `f_of(s)`
/// (NP5x4's is 40).
fn write_report_json_f(
    dir: &Path,
    (matcher, forest): (&str, Option<&str>),
    seeds: &[u64],
    f_of: impl Fn(u64) -> f64,
) {
    let score = |cov: f64, f: f64, images: f64| {
        serde_json::json!({"coverage": cov, "f": f, "triplet_success": 100.0, "n_images": images,
            "f_res": 0.0, "f_unc": 0.0, "rock_coverage": 0.0, "min_clearance_m": null, "safety_violations": 0})
    };
    let sites: Vec<Value> = seeds
        .iter()
        .map(|&s| {
            serde_json::json!({
                "seed": s,
                "scores": [["Grid", score(80.0, 20.0, 36.0)], ["Oblique", score(85.0, 20.0, 60.0)],
                           ["F5x4", score(90.0, f_of(s), 60.0)], ["NP5x4", score(88.0, 40.0, 60.0)]],
                "triplets": [{"strategy": "F5x4", "planned_angle_deg": 12.5}, {"strategy": "F5x4", "planned_angle_deg": null}],
            })
        })
        .collect();
    std::fs::create_dir_all(dir).unwrap();
    let mut json = serde_json::json!({"config": {"mvs": matcher}, "sites": sites});
    if let Some(f) = forest {
        json["forest_fingerprint"] = f.into();
    }
    std::fs::write(dir.join("report.json"), json.to_string()).unwrap();
}

/// Batches of held-out sites merge in seed order; a site in two batches,
/// a folder of the other matcher and a folder without a report are
/// refused, naming the folders.
#[test]
fn compare_dirs_merges_batches_of_sites() {
    let t = tempfile::tempdir().unwrap();
    let d = |n: &str| t.path().join(n);
    write_report_json(&d("sgm-a"), "sgm", &[3]);
    write_report_json(&d("sgm-b"), "sgm", &[1, 2]);
    write_report_json(&d("pm"), "patchmatch", &[2, 1, 3]);
    let md = compare_dirs(
        (&[vec![d("sgm-a"), d("sgm-b")]][..], &[vec![d("pm")]][..]),
        "F5x4",
        0,
    )
    .unwrap();
    let rows: Vec<&str> = md
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| site"))
        .collect();
    assert!(
        rows[0].starts_with("| 1 | 41.0 |") && rows[2].starts_with("| 3 | 43.0 |"),
        "{md}"
    );
    assert!(
        md.contains("12.5 / 12.5"),
        "a triplet without a planned angle is left out: {md}"
    );

    write_report_json(&d("sgm-c"), "sgm", &[2]);
    let e = compare_dirs(
        (&[vec![d("sgm-b"), d("sgm-c")]][..], &[vec![d("pm")]][..]),
        "F5x4",
        0,
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("held-out site 2 is in") && e.to_string().contains("sgm-c"),
        "{e}"
    );
    let e = compare_dirs((&[vec![d("pm")]][..], &[vec![d("pm")]][..]), "F5x4", 0).unwrap_err();
    assert!(e.to_string().contains("not \"sgm\""), "{e}");
    let e = compare_dirs((&[vec![d("nothing")]][..], &[vec![d("pm")]][..]), "F5x4", 0).unwrap_err();
    assert!(e.to_string().contains("report.json"), "{e}");
    let e = compare_dirs((&[vec![d("sgm-b")]][..], &[vec![d("pm")]][..]), "NP5x4", 0).unwrap_err();
    assert!(e.to_string().contains("not an F strategy"), "{e}");
}

/// The comparison names the forest each matcher flew. Batches of one
/// draw that flew two forests are refused, naming both folders; so are
/// two draws that flew one forest (it would count twice), and draws of
/// other sites.
#[test]
fn compare_dirs_names_the_forests_and_checks_the_draws() {
    let t = tempfile::tempdir().unwrap();
    let d = |n: &str| t.path().join(n);
    write_report_json_with(&d("sgm-a"), "sgm", &[1], Some("00000000000000aa"));
    write_report_json_with(&d("sgm-b"), "sgm", &[2], Some("00000000000000aa"));
    write_report_json(&d("pm"), "patchmatch", &[1, 2]);
    let pm = [vec![d("pm")]];
    let md = compare_dirs((&[vec![d("sgm-a"), d("sgm-b")]][..], &pm[..]), "F5x4", 0).unwrap();
    assert!(
        md.contains("SGM 00000000000000aa, PatchMatch not recorded"),
        "{md}"
    );
    write_report_json_with(&d("sgm-c"), "sgm", &[2], Some("00000000000000bb"));
    let e = compare_dirs((&[vec![d("sgm-a"), d("sgm-c")]][..], &pm[..]), "F5x4", 0);
    let e = e.unwrap_err().to_string();
    assert!(
        e.contains("sgm-a") && e.contains("sgm-c") && e.contains("00000000000000bb"),
        "{e}"
    );
    let e = compare_dirs(
        (&[vec![d("sgm-a")], vec![d("sgm-b")]][..], &pm[..]),
        "F5x4",
        0,
    );
    let e = e.unwrap_err().to_string();
    assert!(e.contains("the same forest 00000000000000aa"), "{e}");
    let e = compare_dirs(
        (&[vec![d("sgm-a")], vec![d("sgm-c")]][..], &pm[..]),
        "F5x4",
        0,
    );
    let e = e.unwrap_err().to_string();
    assert!(
        e.contains("sgm-c") && e.contains("00000000000000bb") && e.contains("same held-out sites"),
        "{e}"
    );
}

/// Over forest draws, H4 reads each site's mean over a matcher's draws:
/// two SGM draws each ahead on 5 of 8 sites, on different sites, are
/// ahead on 8 of 8 together. And its interval resamples the draws: SGM
/// draws at +3 and -2 points on every site give a mean of +0.5 on every
/// site, which a bootstrap over sites alone would put at +0.5 .. +0.5;
/// over draws too it spans the two draws, -2 .. +3, and H4 does not hold.
#[test]
fn h4_over_draws_reads_draw_means_and_resamples_the_draws() {
    let t = tempfile::tempdir().unwrap();
    let d = |n: &str| t.path().join(n);
    let seeds: Vec<u64> = (1..=8).collect();
    let pm = |name: &str, forest: &str| {
        write_report_json_f(&d(name), ("patchmatch", Some(forest)), &seeds, |_| 40.0);
    };
    pm("pm-1", "00000000000000c1");
    pm("pm-2", "00000000000000c2");
    let sgm = |name: &str, forest: &str, f_of: fn(u64) -> f64| {
        write_report_json_f(&d(name), ("sgm", Some(forest)), &seeds, f_of);
    };
    sgm("sgm-1", "00000000000000a1", |s| {
        if s <= 5 {
            44.0
        } else {
            39.0
        }
    });
    sgm("sgm-2", "00000000000000a2", |s| {
        if s >= 4 {
            44.0
        } else {
            39.0
        }
    });
    let pms = [vec![d("pm-1")], vec![d("pm-2")]];
    let sgms = [vec![d("sgm-1")], vec![d("sgm-2")]];
    let md = compare_dirs((&sgms[..], &pms[..]), "F5x4", 0).unwrap();
    assert!(
        md.contains("| SGM | 1 | 00000000000000a1 |") && md.contains("| 5 of 8 |"),
        "{md}"
    );
    assert!(
        md.contains("| 1 | +1.5 | +0.0 | +1.5 |"),
        "site 1: (4 - 1) / 2: {md}"
    );
    assert!(
        md.contains("**H4 over draws: holds.**") && md.contains("on 8 of 8 sites"),
        "{md}"
    );

    sgm("sgm-up", "00000000000000b1", |_| 43.0);
    sgm("sgm-down", "00000000000000b2", |_| 38.0);
    let sgms = [vec![d("sgm-up")], vec![d("sgm-down")]];
    let md = compare_dirs((&sgms[..], &pms[..]), "F5x4", 0).unwrap();
    assert!(
        md.contains("**H4 over draws: does not hold.**")
            && md.contains("on 8 of 8 sites")
            && md.contains("PatchMatch's +0.5 points (95 % bootstrap interval over sites and draws -2.0 .. +3.0"),
        "{md}"
    );
}
