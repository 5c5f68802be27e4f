//! Issue 39: the simulated vehicle flies the plan with standard GNSS (a
//! slowly varying bias per flight, white noise in the photos' tags, path
//! tracking), the model is georeferenced from the first flight's tags as
//! `colmap align` would, and every flown path (waypoints and the segments
//! between them, from where the vehicle was) is checked against the TRUE
//! mesh. With the planner's position margin on, no flown path comes inside
//! the safety distance.
//!
//! The long run (`VPCTL_SITES`, default 200 sites, margin on and off) is
//! `#[ignore]`d:
//! `VPCTL_SITES=200 cargo test --release --locked --workspace --test position_error -- --ignored --nocapture many_sites`

use vp_forest::Forest;
use vp_planner::{GnssClass, UnknownSpace};
use vp_sim::campaign::{run_campaign_with_forest, train_forest, CampaignConfig, MvsKind};

/// The quick preset shrunk further (virtual MVS, two NP iterations of two
/// triplets) on held-out site `seed`, with `gnss` and the margin on or off.
///
/// The planner plans on the TRUE surface (moved into the model's
/// georeferenced frame, `plan_on_true_surface`), so a flown path inside the
/// safety distance can only come from the position error: planned on the
/// mesh of what the six-image initial flight saw, with unknown space free,
/// waypoints 2 m above ground nobody had seen came within 0.9 m of it
/// whatever the margin (site 5031). Unknown space counts as free: with
/// standard GNSS the clearance is 17.3 m (4 + 0.5 + 12.8), and no position
/// of the quick site keeps that from the space the initial flight left
/// unobserved (the planner refuses: "no position in the flight volume
/// keeps ...").
fn config(seed: u64, gnss: GnssClass, margin: bool) -> CampaignConfig {
    let mut c = CampaignConfig::quick();
    c.held_out_seeds = vec![seed];
    c.strategies = vec!["NP2x2".into()];
    c.mvs = MvsKind::Virtual;
    c.planner.unknown_space = UnknownSpace::Free;
    c.flight_error.gnss = gnss;
    c.flight_error.position_margin = margin;
    c.flight_error.plan_on_true_surface = true;
    c.planner.safety.gnss = Some(gnss);
    c
}

/// What the flights over a set of sites measured.
#[derive(Debug, Default)]
struct Tally {
    /// Flown paths inside the safety distance of the true mesh.
    violations: usize,
    /// Sites with at least one violation.
    sites_violating: usize,
    /// Closest approach of any flown path to the truth, metres.
    closest: f64,
    /// Images the strategy planned, summed over sites.
    images: f64,
    /// Sites with a plan flown.
    planned: usize,
    /// Sites whose campaign stopped with an error (e.g. an initial flight
    /// whose error leaves no camera seeing the ROI), with the message.
    failed: Vec<(u64, String)>,
}

/// Flies `sites` and counts (a site whose campaign fails is counted and
/// named, not a panic: with the margin off, an initial flight's error can
/// leave nothing to plan from).
fn fly(forest: &Forest, sites: &[u64], gnss: GnssClass, margin: bool) -> Tally {
    let mut t = Tally {
        closest: f64::INFINITY,
        ..Tally::default()
    };
    for &seed in sites {
        let cfg = config(seed, gnss, margin);
        let r = match run_campaign_with_forest(&cfg, forest, &mut |line| {
            if line.contains("SAFETY VIOLATION") {
                eprintln!("site {seed}: {line}");
            }
        }) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("site {seed}: failed: {e}");
                t.failed.push((seed, e.to_string()));
                continue;
            }
        };
        let row = r.row("NP2x2").expect("the strategy's row");
        t.violations += row.safety_violations;
        t.sites_violating += usize::from(row.safety_violations > 0);
        t.closest = t.closest.min(row.min_clearance_m);
        t.images += row.n_images_mean;
        t.planned += usize::from(row.n_images_mean > 0.0);
    }
    t
}

fn sites(n: u64) -> Vec<u64> {
    // Away from the training site (101), the demo's and safety_truth's sites.
    (0..n).map(|i| 5000 + 31 * i).collect()
}

fn forest() -> Forest {
    train_forest(&config(0, GnssClass::Standard, true)).unwrap()
}

#[test]
fn standard_gnss_flights_keep_the_safety_distance_to_the_truth_with_the_margin() {
    let n = 10;
    let t = fly(&forest(), &sites(n), GnssClass::Standard, true);
    println!("{n} sites, standard GNSS, margin on: {t:?}");
    assert!(
        t.images > 0.0,
        "nothing was flown: the check would be empty"
    );
    assert!(t.failed.is_empty(), "{:?}", t.failed);
    assert_eq!(t.violations, 0, "closest approach {:.2} m", t.closest);
}

/// `VPCTL_SITES` sites (default 200), standard GNSS, the margin on and
/// off: the violations the margin removes.
#[test]
#[ignore = "long: 200 random sites, margin on and off"]
fn many_sites_with_and_without_the_position_margin() {
    let n: u64 = std::env::var("VPCTL_SITES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(200);
    let forest = forest();
    let runs = [true, false].map(|margin| {
        let t = fly(&forest, &sites(n), GnssClass::Standard, margin);
        println!(
            "standard GNSS, position margin {}: {n} sites, {} safety violations on {} sites, closest approach {:.2} m, {} images, {} sites with a plan, {} sites failed {:?}",
            if margin { "on" } else { "off" },
            t.violations,
            t.sites_violating,
            t.closest,
            t.images,
            t.planned,
            t.failed.len(),
            t.failed.iter().map(|f| f.0).collect::<Vec<_>>()
        );
        t
    });
    assert_eq!(
        runs[0].violations, 0,
        "closest approach {:.2} m",
        runs[0].closest
    );
}

/// The demo's and the paper's sites (their presets, the virtual MVS for
/// time) with RTK and standard GNSS: coverage and f of each strategy, and
/// the closest approach to the truth.
#[test]
#[ignore = "long: the demo and paper presets with both GNSS classes"]
fn demo_and_paper_sites_with_both_gnss_classes() {
    for (preset, base) in [
        ("demo", CampaignConfig::demo()),
        ("paper", CampaignConfig::paper()),
    ] {
        let mut base = base;
        base.mvs = MvsKind::Virtual;
        let forest = train_forest(&base).unwrap();
        for gnss in [GnssClass::Rtk, GnssClass::Standard] {
            let mut c = base.clone();
            c.flight_error.gnss = gnss;
            c.planner.safety.gnss = Some(gnss);
            let r = run_campaign_with_forest(&c, &forest, &mut |line| {
                if line.contains("SAFETY VIOLATION") || line.contains("aligned to") {
                    eprintln!("{line}");
                }
            })
            .unwrap_or_else(|e| panic!("{preset} {}: {e}", gnss.label()));
            for row in &r.rows {
                println!(
                    "{preset} {} {}: coverage {:.1} %, f {:.1} %, images {:.1}, closest {:.2} m, {} violations",
                    gnss.label(),
                    row.strategy,
                    row.coverage_mean,
                    row.f_mean,
                    row.n_images_mean,
                    row.min_clearance_m,
                    row.safety_violations
                );
            }
        }
    }
}
