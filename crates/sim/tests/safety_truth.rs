//! Issue 16's acceptance: no flown path comes closer than the safety
//! distance to the TRUE surface when the planner plans on what was seen
//! (reconstructed planning mesh, observed-free space with
//! `unknown_space = "occupied"`). The long run (50 random sites, both
//! policies) is `#[ignore]`d: `cargo test --release -p vp-sim --test
//! safety_truth -- --ignored --nocapture` (`VPCTL_SITES=n` for fewer).

use vp_forest::Forest;
use vp_planner::UnknownSpace;
use vp_sim::campaign::{run_campaign_with_forest, train_forest, CampaignConfig};

/// The quick preset, NP strategy over three iterations (the free-space map
/// grows between them), on held-out site `seed`.
fn config(seed: u64, unknown: UnknownSpace) -> CampaignConfig {
    let mut c = CampaignConfig::quick();
    c.held_out_seeds = vec![seed];
    c.strategies = vec!["NP3x2".into()];
    c.planner.unknown_space = unknown;
    // Issue 16's question is unseen geometry: the vehicle flies exactly
    // and the planner keeps no position margin. Position error is
    // tests/position_error.rs's (issue 39).
    c.flight_error.enabled = false;
    c.planner.safety = vp_planner::SafetyConfig::exact();
    c
}

/// Over `sites` random sites: (violations, smallest clearance, triplet
/// images flown).
fn fly(forest: &Forest, sites: &[u64], unknown: UnknownSpace) -> (usize, f64, f64) {
    let (mut violations, mut clearance, mut images) = (0, f64::INFINITY, 0.0);
    for &seed in sites {
        let cfg = config(seed, unknown);
        let r = run_campaign_with_forest(&cfg, forest, &mut |line| {
            if line.contains("SAFETY VIOLATION") {
                eprintln!("{line}");
            }
        })
        .unwrap_or_else(|e| panic!("site {seed}: {e}"));
        let row = r.row("NP3x2").expect("the strategy's row");
        violations += row.safety_violations;
        clearance = clearance.min(row.min_clearance_m);
        images += row.n_images_mean;
    }
    (violations, clearance, images)
}

fn sites(n: u64) -> Vec<u64> {
    // Away from the training site (101) and the demo's held-out sites.
    (0..n).map(|i| 1000 + 17 * i).collect()
}

#[test]
fn planned_flights_keep_the_safety_distance_to_the_truth() {
    let forest = train_forest(&config(0, UnknownSpace::Occupied)).unwrap();
    let (violations, clearance, images) = fly(&forest, &sites(3), UnknownSpace::Occupied);
    println!("3 sites: {violations} violations, {clearance:.2} m min clearance, {images} images");
    assert!(images > 0.0, "nothing was flown: the check would be empty");
    assert_eq!(violations, 0, "closest approach {clearance:.2} m");
}

/// `VPCTL_SITES` sites (default 50).
#[test]
#[ignore = "long: 50 random sites with both policies"]
fn fifty_sites_with_both_unknown_space_policies() {
    let n: u64 = std::env::var("VPCTL_SITES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(50);
    let forest = train_forest(&config(0, UnknownSpace::Occupied)).unwrap();
    // Both policies run before the assertion, so a violation with the
    // default still reports the risk `"free"` carries.
    let runs = [UnknownSpace::Occupied, UnknownSpace::Free].map(|unknown| {
        let (v, c, images) = fly(&forest, &sites(n), unknown);
        println!("unknown_space = {unknown:?}: {n} sites, {v} safety violations, closest approach {c:.2} m, {images} images");
        (v, c)
    });
    let (violations, clearance) = runs[0];
    assert_eq!(violations, 0, "closest approach {clearance:.2} m");
}
