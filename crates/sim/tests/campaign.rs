//! Issue 15's acceptance: the closed loop on vp-mvs, with nothing planted on
//! the default path. The long runs are `#[ignore]`d and run in the named
//! step of scripts/test.sh (in the test profile, where vp-mvs is optimised
//! as in release: Cargo.toml). They assert what the measured
//! experiment shows (docs/campaign-findings.md), not the paper's findings
//! that it does not reproduce.

use std::path::Path;

use vp_scene::outdir::OutDir;
use vp_sim::campaign::report::two_matchers;
use vp_sim::campaign::{
    run_campaign, write_report, CampaignConfig, CampaignReport, MvsKind, TableRow,
};

fn quiet(_: &str) {}

fn row<'a>(r: &'a CampaignReport, name: &str) -> &'a TableRow {
    r.row(name)
        .unwrap_or_else(|| panic!("no row {name} in\n{}", r.table_markdown()))
}

/// The findings campaign: the demo preset with F5x4 and NP5x4 on one
/// held-out site (the note's figures add F1x20 and site 7:
/// docs/campaign-findings.md; here the test command's time budget rules).
fn findings_config() -> CampaignConfig {
    let mut c = CampaignConfig::demo();
    // The geometric pass the measured experiments flew (the demo now runs
    // vp-mvs's default, 1 since stop 54).
    c.patchmatch.geom_iterations = 4;
    c.strategies = vec!["F5x4".into(), "NP5x4".into()];
    c.held_out_seeds = vec![8];
    c
}

#[test]
fn the_default_path_runs_vp_mvs_not_the_planted_stand_in() {
    for name in vp_sim::campaign::PRESETS {
        assert_eq!(
            CampaignConfig::preset(name).unwrap().mvs,
            MvsKind::Patchmatch,
            "{name}"
        );
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/paper-site.toml");
    assert_eq!(
        CampaignConfig::load(&path).unwrap().mvs,
        MvsKind::Patchmatch
    );
}

#[test]
#[ignore = "long: several minutes; run by scripts/test.sh"]
fn measured_findings_hold_on_held_out_sites() {
    let cfg = findings_config();
    let r = run_campaign(&cfg, &mut |m| eprintln!("{m}")).unwrap();
    println!("{}", r.table_markdown());
    println!("{}", r.curves_summary());
    let training = r.training.as_ref().unwrap();
    println!("{}", training.label_quality.markdown());
    let (f5, grid) = (row(&r, "F5x4"), row(&r, "Grid"));
    // Planned triplets produce 3D output (the paper's F5x4 finding).
    assert!(
        f5.triplet_success_mean >= 90.0,
        "F5x4 success {}",
        f5.triplet_success_mean
    );
    // Every combination with Grid covers at least what Grid covers alone,
    // and is above Grid in f: the triplets add what the nadir grid lacks.
    for s in ["F5x4", "NP5x4"] {
        let c = row(&r, &format!("G+{s}"));
        assert!(c.coverage_mean >= grid.coverage_mean, "G+{s} coverage");
        assert!(
            c.f_mean > grid.f_mean,
            "G+{s} f {} vs Grid {}",
            c.f_mean,
            grid.f_mean
        );
    }
    // The paper's combination finding (G+F5x4 above every standalone
    // strategy in f) is not asserted: on the geometry reconstructed from
    // what was seen it held without a geometry margin (60.9 vs NP5x4 56.7)
    // and does not with the 0.5 m margin the simulator now plans with
    // (50.6 vs 54.8); docs/campaign-findings.md, "Geometry from what was
    // seen".
    // Labels from vp-mvs output without ground truth: most are right and a
    // good share of the pixels is labelled (the paper on KITTI: 98.7 % at
    // 35 %; see the findings for this world's figure).
    let all = training.label_quality.total();
    assert!(
        all.correct_pct() >= 95.0 && all.labelled_pct() >= 35.0,
        "labels {:.1} % correct at {:.1} % labelled",
        all.correct_pct(),
        all.labelled_pct()
    );
    // For the materials that fill the ROI, vp-mvs succeeds more often at
    // the widest angle bin than at the narrowest, and the learned
    // confidence rises with it. (Rank correlation over all bins does not
    // reach the paper's: ground 0.58-0.72, rock 0.20-0.45, see the findings.)
    for c in r
        .curves
        .iter()
        .filter(|c| c.material == "ground" || c.material == "rock")
    {
        let (m0, m1) = (c.measured[0], c.measured[c.measured.len() - 1]);
        let (l0, l1) = (c.learned[0], c.learned[c.learned.len() - 1]);
        assert!(
            m1 > m0 && l1 > l0,
            "{}: measured {m0} -> {m1}, learned {l0} -> {l1}",
            c.material
        );
    }
    two_matchers_on_the_same_site(&cfg, &r);
}

/// Issue 35's two-matcher experiment on this one site: the same campaign
/// flown with SGM and its own forest (the full run, 8 training and 8
/// held-out sites, is in docs/campaign-findings.md), compared with the
/// PatchMatch run `pm`. Only what held on the full run is asserted.
fn two_matchers_on_the_same_site(pm_cfg: &CampaignConfig, pm: &CampaignReport) {
    let sgm = run_campaign(&with_sgm(pm_cfg), &mut |m| eprintln!("{m}")).unwrap();
    println!("{}", sgm.table_markdown());
    // `vpctl sim compare` reads report.json; it holds what the run had.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sgm");
    write_report(&sgm, &OutDir::check(&out, "test", &[], false).unwrap()).unwrap();
    let from_json = two_matchers::read_campaign(&out).unwrap();
    let sgm = two_matchers::MatcherCampaign::from_report(&sgm);
    assert_eq!(from_json, sgm);
    let pm = two_matchers::MatcherCampaign::from_report(pm);
    let c = two_matchers::compare(&sgm, &pm, ("F5x4", "NP5x4"), 0).unwrap();
    println!("{}", c.markdown());
    // A test on one site asserts only what held on every site of the full
    // run (docs/campaign-findings.md, "The two-matcher experiment"): H3, F
    // plans narrower triangulation angles with SGM than with PatchMatch
    // (8 of 8 sites). H4's second half (F's lead over NP larger with SGM)
    // held as a mean over the 8 sites (+4.4 points, interval +1.1 .. +8.0)
    // but site by site on 6 of 8, so one site cannot check it (flown
    // again with stop 61's PatchMatch it no longer holds over the 8 sites
    // either; at 30 % vegetation, below, it holds over the 8 but not site
    // by site). H1, H4's first half, H5 and H6 did not hold and are not
    // asserted; H2 needs the leave-one-site-out folds (`sim evaluate
    // --versus`, tested in the CLI's tests).
    let (sgm_angle, pm_angle) = c.angle[0];
    assert!(sgm_angle < pm_angle, "H3: {sgm_angle} vs {pm_angle}");
}

/// `pm_cfg` flown with SGM instead of PatchMatch.
fn with_sgm(pm_cfg: &CampaignConfig) -> CampaignConfig {
    let mut cfg = pm_cfg.clone();
    cfg.mvs = MvsKind::Sgm;
    // As in the full run: a 45-degree pair of the training images needs
    // more than the default 512 disparities, and a refused pair would
    // "fail" at wide angles by construction.
    cfg.patchmatch.sgm.max_disparities = 2048;
    cfg
}

/// Issue 35's vegetation sweep on one site: the findings campaign with the
/// sweep's 30 % level (`meadow = 0.3` and one tree at the rock, on the
/// flown and the training sites; docs/campaign-findings.md, "The
/// vegetation sweep"), flown with each matcher and its own forest, trained
/// on the demo's two sites where the sweep's used eight. Only what held on
/// every site of the full run is asserted: H3, F plans narrower angles with
/// SGM than with PatchMatch (8 of 8 sites at 8f7f258 and again with stop
/// 61's PatchMatch). H4 held on 8 of 8 sites in both halves at 8f7f258;
/// flown again with stop 61's PatchMatch (docs/campaign-findings.md,
/// "Flown again with stop 61's PatchMatch") it still holds over the 8
/// sites, but SGM's F ahead of NP on 7 of 8 and the difference of the gaps
/// above 0 on 6 of 8, so one site can no longer check it, as on bare
/// ground. H5 and H6 did not hold and are not asserted.
#[test]
#[ignore = "long: minutes; run by scripts/test.sh"]
fn at_thirty_percent_vegetation_f_plans_narrower_with_sgm() {
    let mut pm_cfg = findings_config();
    for site in [&mut pm_cfg.site, &mut pm_cfg.training.site] {
        site.meadow = 0.3;
        site.n_trees_at_rock = 1;
    }
    let sgm_cfg = with_sgm(&pm_cfg);
    let flown = [&pm_cfg, &sgm_cfg].map(|cfg| {
        let r = run_campaign(cfg, &mut |m| eprintln!("{m}")).unwrap();
        println!("{}", r.table_markdown());
        two_matchers::MatcherCampaign::from_report(&r)
    });
    let c = two_matchers::compare(&flown[1], &flown[0], ("F5x4", "NP5x4"), 0).unwrap();
    println!("{}", c.markdown());
    let (sgm_angle, pm_angle) = c.angle[0];
    assert!(sgm_angle < pm_angle, "H3: {sgm_angle} vs {pm_angle}");
}

#[test]
#[ignore = "long: minutes; run by scripts/test.sh"]
fn same_config_and_seed_give_the_same_table_bytes() {
    let mut cfg = CampaignConfig::quick();
    // Issue 35's baseline rides along: the industry's five-route oblique
    // capture, at no more images than the largest triplet strategy (NP1x6:
    // 18; five routes over the quick site's footprint need 14 images even
    // at zero overlap, so the preset's 6 cannot hold them), reconstructed
    // and scored as the Grid is.
    cfg.grid.oblique = true;
    cfg.strategies.push("NP1x6".into());
    let a = run_campaign(&cfg, &mut quiet).unwrap();
    let oblique = row(&a, "Oblique");
    assert!(
        (14.0..=18.0).contains(&oblique.n_images_mean),
        "five routes within the budget of 18: {}",
        oblique.n_images_mean
    );
    assert!(
        oblique.coverage_mean > 0.0,
        "the oblique images reconstruct"
    );
    // Issue 34, item 4: every triplet strategy's flown triplets and rock
    // depth errors are in the report (and so in the bytes compared below).
    for site in &a.sites {
        // Init, Grid, Oblique, then each triplet strategy.
        assert_eq!(site.rock_errors.len(), 3 + cfg.strategies.len());
        assert!(site.rock_errors.iter().all(|(_, h)| h.pixels > 0));
        for st in &cfg.strategies {
            assert!(site.triplets.iter().any(|t| &t.strategy == st), "{st}");
        }
    }
    let b = run_campaign(&cfg, &mut quiet).unwrap();
    assert_eq!(a.table_csv(), b.table_csv());
    assert_eq!(
        serde_json::to_string(&a).unwrap(),
        serde_json::to_string(&b).unwrap()
    );
    // A different campaign seed changes the flights (not only the bytes of a header).
    let mut other = cfg.clone();
    other.seed += 1;
    let c = run_campaign(&other, &mut quiet).unwrap();
    assert_ne!(a.table_csv(), c.table_csv());
}
