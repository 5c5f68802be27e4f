//! The campaign's results: the Table-1 rows (mean and standard deviation
//! over held-out sites), per-site scores, confidence curves, and their
//! formatting as text (Markdown, CSV); the writers of the report folder
//! (`super`) read them.

use std::fmt::Write as _;

use serde::Serialize;
use vp_scene::plan::Plan;
use vp_scene::{Aabb, Mesh};

use crate::campaign::acquired::AcquiredModel;
use crate::campaign::curves::ConfidenceCurve;
use crate::campaign::eval::Scores;
use crate::campaign::training::TrainingStats;
use crate::campaign::triplet_outcomes::{DepthErrorHistogram, TripletOutcome};
use crate::config::CampaignConfig;

/// One row of the table: a strategy's figures over the held-out sites.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TableRow {
    /// Strategy (`Init`, `Grid`, `F5x4`, `G+F5x4`, ...).
    pub strategy: String,
    /// Coverage of the ROI, percent: mean and standard deviation.
    pub coverage_mean: f64,
    /// See `coverage_mean`.
    pub coverage_std: f64,
    /// Mean f_res, percent.
    pub f_res_mean: f64,
    /// See `f_res_mean`.
    pub f_res_std: f64,
    /// Mean f_unc, percent.
    pub f_unc_mean: f64,
    /// See `f_unc_mean`.
    pub f_unc_std: f64,
    /// Mean f, percent.
    pub f_mean: f64,
    /// See `f_mean`.
    pub f_std: f64,
    /// Triplets with any 3D output, percent.
    pub triplet_success_mean: f64,
    /// See `triplet_success_mean`.
    pub triplet_success_std: f64,
    /// Images used.
    pub n_images_mean: f64,
    /// See `n_images_mean`.
    pub n_images_std: f64,
    /// Coverage of the rock alone, percent.
    pub rock_coverage_mean: f64,
    /// See `rock_coverage_mean`.
    pub rock_coverage_std: f64,
    /// Smallest distance of any flown path to the true surface over the
    /// sites, metres (infinite: nothing flown).
    pub min_clearance_m: f64,
    /// Safety violations against the truth, summed over the sites.
    pub safety_violations: usize,
}

/// Scores of every strategy on one held-out site.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SiteResult {
    /// The site's seed.
    pub seed: u64,
    /// (strategy, scores) in table order.
    pub scores: Vec<(String, Scores)>,
    /// Every flown triplet of every triplet strategy, strategies in table
    /// order, each in flight order.
    pub triplets: Vec<TripletOutcome>,
    /// Per flight (Init, Grid, Oblique with `grid.oblique`, then each
    /// triplet strategy; table order), the depth errors of its
    /// reconstructions' rock pixels (the paper's Fig. 6).
    pub rock_errors: Vec<(String, DepthErrorHistogram)>,
}

/// What the plots of one strategy need (first held-out site only).
#[derive(Debug, Clone)]
pub struct StrategyArtifacts {
    /// Strategy name.
    pub name: String,
    /// f per evaluation face (0..1).
    pub face_f: Vec<f64>,
    /// Plans, one per iteration (empty for combinations).
    pub plans: Vec<Plan>,
    /// What each iteration planned from, beside `plans` (triplet strategies
    /// only; empty for Init, Grid and combinations).
    pub acquired: Vec<AcquiredModel>,
}

/// The first held-out site's data for plots and missions.
#[derive(Debug, Clone)]
pub struct SiteArtifacts {
    /// Site seed.
    pub seed: u64,
    /// True mesh.
    pub mesh: Mesh,
    /// Region of interest.
    pub roi: Aabb,
    /// Evaluation face centroids.
    pub centroids: Vec<nalgebra::Point3<f64>>,
    /// Per strategy.
    pub strategies: Vec<StrategyArtifacts>,
}

/// Everything a campaign produced.
#[derive(Debug, Clone, Serialize)]
pub struct CampaignReport {
    /// The table (mean and standard deviation over held-out sites).
    pub rows: Vec<TableRow>,
    /// Per-site scores.
    pub sites: Vec<SiteResult>,
    /// Learned vs true confidence per material, with rank correlations.
    pub curves: Vec<ConfidenceCurve>,
    /// Per angle bin (deg), the rank correlation across materials of learned
    /// against true confidence.
    pub material_ranking: Vec<(f64, f64)>,
    /// The same against the random triplets no planner chose.
    pub material_ranking_random: Vec<(f64, f64)>,
    /// What training did (None when the forest was loaded).
    pub training: Option<TrainingStats>,
    /// The flown forest's fingerprint ([`vp_forest::Forest::fingerprint`],
    /// 16 hex digits): two reports flew the same forest exactly when they
    /// show the same one.
    pub forest_fingerprint: String,
    /// The configuration that produced it.
    pub config: CampaignConfig,
    /// Plot and mission data of the first held-out site.
    #[serde(skip)]
    pub artifacts: Option<SiteArtifacts>,
}

/// Mean and sample standard deviation (0 for one value).
fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let m = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return (m, 0.0);
    }
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, var.sqrt())
}

/// The table rows from per-site scores (row order of the first site).
pub fn aggregate(sites: &[SiteResult]) -> Vec<TableRow> {
    let Some(first) = sites.first() else {
        return Vec::new();
    };
    first
        .scores
        .iter()
        .map(|(name, _)| {
            let all: Vec<&Scores> = sites
                .iter()
                .filter_map(|s| s.scores.iter().find(|(n, _)| n == name).map(|(_, sc)| sc))
                .collect();
            let ms =
                |k: fn(&Scores) -> f64| mean_std(&all.iter().map(|s| k(s)).collect::<Vec<_>>());
            let (coverage_mean, coverage_std) = ms(|s| s.coverage);
            let (f_res_mean, f_res_std) = ms(|s| s.f_res);
            let (f_unc_mean, f_unc_std) = ms(|s| s.f_unc);
            let (f_mean, f_std) = ms(|s| s.f);
            let (triplet_success_mean, triplet_success_std) =
                ms(|s| s.triplet_success.unwrap_or(f64::NAN));
            let (n_images_mean, n_images_std) = ms(|s| s.n_images as f64);
            let (rock_coverage_mean, rock_coverage_std) = ms(|s| s.rock_coverage);
            let min_clearance_m = all
                .iter()
                .map(|s| s.min_clearance_m)
                .fold(f64::INFINITY, f64::min);
            TableRow {
                min_clearance_m,
                safety_violations: all.iter().map(|s| s.safety_violations).sum(),
                strategy: name.clone(),
                coverage_mean,
                coverage_std,
                f_res_mean,
                f_res_std,
                f_unc_mean,
                f_unc_std,
                f_mean,
                f_std,
                triplet_success_mean,
                triplet_success_std,
                n_images_mean,
                n_images_std,
                rock_coverage_mean,
                rock_coverage_std,
            }
        })
        .collect()
}

impl CampaignReport {
    /// The row of `strategy`, if any.
    pub fn row(&self, strategy: &str) -> Option<&TableRow> {
        self.rows.iter().find(|r| r.strategy == strategy)
    }

    /// The table's header and its rows as display text (percent, mean ±
    /// std over held-out sites; the mean alone when there is one site,
    /// whose std says nothing; "-" where there is no value; the clearance
    /// is the minimum and the violations the sum over sites). The one
    /// formatting of the table, for Markdown and HTML.
    pub fn table_cells(&self) -> (Vec<&'static str>, Vec<Vec<String>>) {
        let one_site = self.config.held_out_seeds.len() == 1;
        let clearance = |m: f64| {
            if m.is_finite() {
                format!("{m:.1}")
            } else {
                "-".to_string()
            }
        };
        let pm = |m: f64, s: f64| {
            if m.is_nan() {
                "-".to_string()
            } else if one_site {
                format!("{m:.1}")
            } else {
                format!("{m:.1} ± {s:.1}")
            }
        };
        let header = vec![
            "strategy",
            "cov %",
            "f_res %",
            "f_unc %",
            "f %",
            "triplet success %",
            "images",
            "rock cov %",
            "min clearance to the truth (m)",
            "safety violations",
        ];
        let rows = self
            .rows
            .iter()
            .map(|r| {
                vec![
                    r.strategy.clone(),
                    pm(r.coverage_mean, r.coverage_std),
                    pm(r.f_res_mean, r.f_res_std),
                    pm(r.f_unc_mean, r.f_unc_std),
                    pm(r.f_mean, r.f_std),
                    pm(r.triplet_success_mean, r.triplet_success_std),
                    pm(r.n_images_mean, r.n_images_std),
                    pm(r.rock_coverage_mean, r.rock_coverage_std),
                    clearance(r.min_clearance_m),
                    r.safety_violations.to_string(),
                ]
            })
            .collect();
        (header, rows)
    }

    /// The table as Markdown ([`CampaignReport::table_cells`]).
    pub fn table_markdown(&self) -> String {
        let (header, rows) = self.table_cells();
        let mut t = String::new();
        let _ = writeln!(t, "| {} |", header.join(" | "));
        let _ = writeln!(t, "|{}", "---|".repeat(header.len()));
        for r in rows {
            let _ = writeln!(t, "| {} |", r.join(" | "));
        }
        t
    }

    /// What the table's cells are: "Mean ± standard deviation over them" or,
    /// for one site, "One site: no standard deviation".
    pub fn table_caption(&self) -> &'static str {
        if self.config.held_out_seeds.len() == 1 {
            "One site: values of that site, no standard deviation"
        } else {
            "Mean ± standard deviation over them"
        }
    }

    /// Which forest the F strategies flew with, and what its fingerprint
    /// is for.
    pub fn forest_line(&self) -> String {
        format!(
            "The F strategies flew the forest with fingerprint {} (the checksum its `.vpforest` \
             file ends with, as `--save-forest` writes it): reports with the same fingerprint flew \
             the same forest. A forest trained again on other labels, even a few pixels' \
             difference, is another model and plans other triplets.",
            self.forest_fingerprint
        )
    }

    /// The table as CSV (one column per mean and per standard deviation).
    pub fn table_csv(&self) -> String {
        let mut t = String::from(
            "strategy,coverage_mean,coverage_std,f_res_mean,f_res_std,f_unc_mean,f_unc_std,f_mean,f_std,triplet_success_mean,triplet_success_std,n_images_mean,n_images_std,rock_coverage_mean,rock_coverage_std,min_clearance_m,safety_violations\n",
        );
        let v = |x: f64| {
            if x.is_nan() {
                String::new()
            } else {
                format!("{x:.4}")
            }
        };
        for r in &self.rows {
            let _ = writeln!(
                t,
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
                r.strategy,
                v(r.coverage_mean),
                v(r.coverage_std),
                v(r.f_res_mean),
                v(r.f_res_std),
                v(r.f_unc_mean),
                v(r.f_unc_std),
                v(r.f_mean),
                v(r.f_std),
                v(r.triplet_success_mean),
                v(r.triplet_success_std),
                v(r.n_images_mean),
                v(r.n_images_std),
                v(r.rock_coverage_mean),
                v(r.rock_coverage_std),
                if r.min_clearance_m.is_finite() {
                    v(r.min_clearance_m)
                } else {
                    String::new()
                },
                r.safety_violations,
            );
        }
        t
    }

    /// Per material: the Spearman rank correlation of learned against true
    /// confidence over the angle bins; per bin, the rank correlation across
    /// materials; as text lines.
    pub fn curves_summary(&self) -> String {
        let mut t = String::new();
        for (set, ranking) in [
            ("flown triplets", &self.material_ranking),
            ("random triplets", &self.material_ranking_random),
        ] {
            let ranking: Vec<String> = ranking
                .iter()
                .map(|(a, r)| format!("{a:.1} deg {r:+.2}"))
                .collect();
            let _ = writeln!(
                t,
                "ranking of materials, learned vs measured on the {set}, per bin: {}",
                ranking.join(", ")
            );
        }
        for c in &self.curves {
            let _ = writeln!(
                t,
                "{:<7} spearman {:+.2} flown ({} pixels), {:+.2} random set ({} pixels), over {} bins ({} samples): learned {} -> {}, measured flown {} -> {}, random {} -> {} from {:.1} to {:.1} deg",
                c.material,
                c.spearman,
                c.measured_pixels.iter().sum::<u64>(),
                c.spearman_random,
                c.measured_random_pixels.iter().sum::<u64>(),
                c.angle_deg.len(),
                c.samples,
                fmt2(c.learned.first()),
                fmt2(c.learned.last()),
                fmt2(c.measured.first()),
                fmt2(c.measured.last()),
                fmt2(c.measured_random.first()),
                fmt2(c.measured_random.last()),
                c.angle_deg.first().copied().unwrap_or(0.0),
                c.angle_deg.last().copied().unwrap_or(0.0),
            );
        }
        t
    }
}

fn fmt2(v: Option<&f64>) -> String {
    v.map_or_else(|| "-".into(), |x| format!("{x:.2}"))
}
