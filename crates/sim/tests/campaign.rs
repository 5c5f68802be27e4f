//! Issue 7's acceptance: the paper's qualitative findings on held-out sites
//! (long: `#[ignore]`d, run in the named step of scripts/test.sh with
//! `--release`), and determinism of the whole campaign.

use vp_sim::campaign::{run_campaign, CampaignConfig, CampaignReport, TableRow};

fn quiet(_: &str) {}

fn row<'a>(r: &'a CampaignReport, name: &str) -> &'a TableRow {
    r.row(name)
        .unwrap_or_else(|| panic!("no row {name} in\n{}", r.table_markdown()))
}

/// The combinations with F (G+F5x4, G+F1x20) above every standalone
/// strategy in overall f.
fn combinations_with_f_lead(r: &CampaignReport) {
    let best_alone = ["F5x4", "F1x20", "NP5x4", "Grid", "Init"]
        .iter()
        .map(|s| row(r, s).f_mean)
        .fold(f64::NEG_INFINITY, f64::max);
    for combo in ["G+F5x4", "G+F1x20"] {
        let c = row(r, combo);
        assert!(
            c.f_mean > best_alone,
            "{combo} f {} is not above the best standalone f {best_alone}",
            c.f_mean
        );
    }
}

/// The findings campaign: the demo preset with the paper's strategies on
/// two held-out sites.
fn findings_config() -> CampaignConfig {
    let mut c = CampaignConfig::demo();
    c.strategies = vec!["F5x4".into(), "F1x20".into(), "NP5x4".into()];
    c.held_out_seeds = vec![7, 8];
    c
}

#[test]
#[ignore = "long: about 40 s in release; run by scripts/test.sh"]
fn paper_findings_hold_on_held_out_sites() {
    let cfg = findings_config();
    let r = run_campaign(&cfg, &mut |m| eprintln!("{m}")).unwrap();
    println!("{}", r.table_markdown());
    println!("{}", r.curves_summary());
    let (f5, np, grid) = (row(&r, "F5x4"), row(&r, "NP5x4"), row(&r, "Grid"));
    // Triplet success: prediction keeps triplets matchable, NP goes too wide.
    assert!(
        f5.triplet_success_mean >= 90.0,
        "F5x4 success {}",
        f5.triplet_success_mean
    );
    assert!(
        np.triplet_success_mean <= f5.triplet_success_mean - 20.0,
        "NP5x4 success {} is not clearly below F5x4's {}",
        np.triplet_success_mean,
        f5.triplet_success_mean
    );
    // Fewer images than the Grid.
    assert!(f5.n_images_mean < grid.n_images_mean);
    combinations_with_f_lead(&r);
    // F with prediction above NP in overall f.
    let f1 = row(&r, "F1x20");
    assert!(f5.f_mean > np.f_mean && f1.f_mean > np.f_mean);
    // Every material's learned confidence falls with the angle as its truth
    // does (rank correlation over the bins; a forest whose confidences are
    // pulled towards 0.5 fails this for the rock).
    assert_eq!(r.curves.len(), 5, "{}", r.curves_summary());
    for c in &r.curves {
        assert!(
            c.spearman >= 0.5,
            "{} rank correlation {}",
            c.material,
            c.spearman
        );
    }
}

/// The demo on the paper-scaled site of `examples/paper-site.toml`
/// (vegetation at the rock, the paper's field of view and footprint-to-ROI
/// ratio, a safe Grid taking more images than F5x4): the coverage finding,
/// which the demo world does not show, and the combinations' lead. Not the
/// NP findings: NP5x4's triplets succeed about as often as F5x4's here and
/// its f is level with F1x20's (docs/campaign-findings.md).
#[test]
#[ignore = "long: about 75 s in release; run by scripts/test.sh"]
fn f5x4_covers_more_than_grid_with_fewer_images_on_the_paper_scaled_site() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/paper-site.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let cfg = CampaignConfig::from_toml(&text, &path).unwrap();
    let r = run_campaign(&cfg, &mut quiet).unwrap();
    println!("{}", r.table_markdown());
    let (f5, grid) = (row(&r, "F5x4"), row(&r, "Grid"));
    assert!(
        f5.coverage_mean > grid.coverage_mean + 5.0,
        "F5x4 coverage {} is not above Grid's {}",
        f5.coverage_mean,
        grid.coverage_mean
    );
    assert!(f5.n_images_mean < grid.n_images_mean);
    assert!(f5.triplet_success_mean >= 90.0);
    combinations_with_f_lead(&r);
}

#[test]
#[ignore = "long in debug builds; run by scripts/test.sh"]
fn same_config_and_seed_give_the_same_table_bytes() {
    let cfg = CampaignConfig::quick();
    let a = run_campaign(&cfg, &mut quiet).unwrap();
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
