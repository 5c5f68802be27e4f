use super::*;
use crate::campaign::reconstruct::OutputStats;
use crate::campaign::report::SiteResult;
use crate::campaign::CampaignConfig;

fn outcome(
    strategy: &str,
    site: u64,
    triplet: u32,
    angle: Option<f64>,
    (pixels, measured): (usize, usize),
) -> TripletOutcome {
    TripletOutcome {
        strategy: strategy.into(),
        site,
        iteration: 1,
        triplet,
        planned_angle_deg: angle,
        stats: OutputStats {
            pixels,
            output: measured,
            measured,
        },
        success: measured > 0,
    }
}

fn errors(pixels: &[(f64, Option<f64>)]) -> DepthErrorHistogram {
    let mut h = DepthErrorHistogram::default();
    for &(e, s) in pixels {
        h.add(e, s);
    }
    h
}

/// Two sites, F1x2 and NP1x2, hand-made outcomes.
fn report(with_triplets: bool) -> CampaignReport {
    let site = |seed, triplets: Vec<TripletOutcome>, f, np| SiteResult {
        seed,
        scores: Vec::new(),
        triplets: if with_triplets { triplets } else { Vec::new() },
        rock_errors: if with_triplets {
            let grid = errors(&[(0.0005, None)]);
            vec![
                ("Grid".into(), grid),
                ("F1x2".into(), f),
                ("NP1x2".into(), np),
            ]
        } else {
            Vec::new()
        },
    };
    let seven = vec![
        outcome("F1x2", 7, 0, Some(27.5), (100, 50)),
        outcome("F1x2", 7, 1, Some(27.5), (100, 0)),
        outcome("NP1x2", 7, 0, Some(32.5), (100, 20)),
        outcome("NP1x2", 7, 1, Some(42.5), (100, 5)),
    ];
    let eight = vec![
        outcome("F1x2", 8, 0, Some(12.5), (100, 30)),
        outcome("NP1x2", 8, 0, None, (0, 0)),
    ];
    CampaignReport {
        rows: Vec::new(),
        sites: vec![
            site(
                7,
                seven,
                errors(&[(0.0105, Some(0.0205))]),
                errors(&[(-0.6005, None)]),
            ),
            site(
                8,
                eight,
                errors(&[(0.0305, Some(0.0205))]),
                DepthErrorHistogram::default(),
            ),
        ],
        curves: Vec::new(),
        material_ranking: Vec::new(),
        material_ranking_random: Vec::new(),
        training: None,
        forest_fingerprint: "0123456789abcdef".into(),
        config: CampaignConfig::quick(),
        artifacts: None,
    }
}

#[test]
fn outcomes_are_pooled_over_sites_per_strategy_in_table_order() {
    let r = report(true);
    let all = by_strategy(&r);
    let names: Vec<&str> = all.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["Grid", "F1x2", "NP1x2"]);
    let planned: Vec<bool> = all.iter().map(|s| s.planned).collect();
    assert_eq!(planned, [false, true, true]);
    assert!(all[0].triplets.is_empty() && all[0].rock.pixels == 2);
    let all = &all[1..];
    let sites: Vec<(u64, u32)> = all[0]
        .triplets
        .iter()
        .map(|t| (t.site, t.triplet))
        .collect();
    assert_eq!(sites, [(7, 0), (7, 1), (8, 0)]);
    assert_eq!((all[0].rock.pixels, all[0].rock.within_sigma), (2, 1));
    assert_eq!(all[1].rock.pixels, 1);
}

#[test]
fn the_angle_histogram_shows_where_f_and_np_planned() {
    let r = report(true);
    let all = by_strategy(&r);
    let (header, rows) = angle_cells(&all);
    assert_eq!(header.len(), 1 + 9 + 2);
    assert_eq!((header[3].as_str(), header[9].as_str()), ("10-15", "40-45"));
    // F: 12.5 in 10-15, 27.5 twice in 25-30; NP: 32.5, 42.5, one without.
    assert_eq!(
        rows[0],
        ["F1x2", "0", "0", "1", "0", "0", "2", "0", "0", "0", "0", "3"]
    );
    assert_eq!(
        rows[1],
        ["NP1x2", "0", "0", "0", "0", "0", "0", "1", "0", "1", "1", "3"]
    );
    // |1| + |2| + |1| + |1| = 5 over the bins: 3 triplets moved.
    let lines = f_vs_np_angles(&all);
    assert_eq!(
        lines,
        ["F1x2 and NP1x2: the planned-angle histograms differ by 3 triplets (F1x2 flew 3, NP1x2 flew 3)."]
    );
}

#[test]
fn the_share_table_gives_quartiles_and_success_at_each_threshold() {
    let r = report(true);
    let (header, rows) = share_cells(&by_strategy(&r));
    assert_eq!(
        header[7..],
        [
            "success > 0 px",
            "success ≥ 1 %",
            "success ≥ 10 %",
            "success ≥ 25 %"
        ]
    );
    // F: shares 0.5, 0, 0.3 -> 0, 0.15, 0.3, 0.4, 0.5; 2 of 3 above 0 and
    // at or above 1, 10 and 25 %.
    assert_eq!(
        rows[0],
        ["F1x2", "3", "0.0", "15.0", "30.0", "40.0", "50.0", "66.7", "66.7", "66.7", "66.7"]
    );
    // NP: 0.2, 0.05, 0 (no ROI pixel) -> 0, 0.025, 0.05, 0.125, 0.2.
    assert_eq!(
        rows[1],
        ["NP1x2", "3", "0.0", "2.5", "5.0", "12.5", "20.0", "66.7", "66.7", "33.3", "0.0"]
    );
}

#[test]
fn the_rock_table_and_csvs_hold_fig6_and_every_triplet() {
    let r = report(true);
    let all = by_strategy(&r);
    let (_, rows) = rock_cells(&all);
    // F: errors 10.5 mm (within its 20.5 mm sigma) and 30.5 mm (not);
    // 68.3 % of 2 pixels is the 2nd smallest |error|.
    assert_eq!(rows[1], ["F1x2", "2", "30.5", "2", "20.5", "50.0", "100.0"]);
    // The Grid: one pixel 0.5 mm off on each site, without a sigma.
    assert_eq!(rows[0], ["Grid", "2", "0.5", "0", "-", "-", "100.0"]);
    // NP: one pixel 60 cm in front, seen by one camera only: no sigma.
    assert_eq!(rows[2], ["NP1x2", "1", "600.5", "0", "-", "-", "0.0"]);
    let csv = triplets_csv(&all);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 1 + 6);
    assert_eq!(lines[1], "F1x2,7,1,0,27.50,100,50,50,0.5000,0.5000,true");
    assert_eq!(lines[6], "NP1x2,8,1,0,,0,0,0,0.0000,0.0000,false");
    let err = depth_error_csv(&all);
    assert_eq!(err.lines().count(), 1 + 3 * 52);
    assert!(
        err.contains("\nF1x2,0,-inf,-0.5000,0,0.0000,2,0.0305,2,1,0.0205\n"),
        "{err}"
    );
    assert!(
        err.contains("\nNP1x2,0,-inf,-0.5000,1,1.0000,1,0.6005,0,0,\n"),
        "{err}"
    );
    let md = markdown(&r).unwrap();
    assert!(md.contains("| F1x2 | 3 | 0.0 | 15.0 |"), "{md}");
    let page = html(&r, &[]);
    for id in ["triplet-angles", "triplet-shares", "depth-error-rock"] {
        assert!(page.contains(&format!("id=\"{id}\"")), "{id}");
    }
}

#[test]
fn without_triplet_strategies_there_is_no_section() {
    let r = report(false);
    assert!(markdown(&r).is_none());
    assert!(html(&r, &[]).is_empty());
}

#[test]
fn the_fig6_plot_draws_bars_and_the_sigma_lines() {
    let h = errors(&[(0.01, Some(0.1)), (0.01, Some(0.1)), (-0.9, None)]);
    let img = depth_error_plot("F1x2", &h);
    assert_eq!((img.width(), img.height()), (W, H));
    let count = |c: Rgb<u8>| img.pixels().filter(|p| **p == c).count();
    assert!(count(BAR) > 100, "the bar of 0-2 cm");
    assert!(count(OVERFLOW) > 10, "the bar below -0.5 m");
    assert!(count(SIGMA) > 100, "the median 1 sigma lines");
}
