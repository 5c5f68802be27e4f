//! Closed-loop campaigns in the simulated world: the paper's experiment end
//! to end, and its Table 1.
//!
//! - [`train_forest`]: the offline training campaign (procedural training
//!   sites, random triplets over the angle range reconstructed by vp-mvs at
//!   each pyramid level, vp-labelgen labels on SfM's noisy poses, vp-forest
//!   training on the rendered pixels).
//! - [`run_campaign`] ([`train_campaign_forest`], then
//!   [`run_campaign_with_forest`]): on each held-out site
//!   (never a training site), the initial flight, the Grid baseline (vp-mvs
//!   on every Grid image against its best neighbours, as the paper's Grid)
//!   and every triplet strategy (`F5x4`, `F1x20`, `NP5x4`, ...: plan with
//!   vp-planner on the planning mesh SfM has so far, fly, reconstruct the
//!   triplet with vp-mvs, update, repeat), each evaluated on its own images
//!   against the true mesh, and Grid combined with each.
//! - [`curves`]: the forest's learned confidence against vp-mvs's measured
//!   success per material and angle; [`label_quality`]: labelgen's labels
//!   against the renderer's truth.
//! - [`write_report`]: the report directory, with [`html`]'s `report.html`
//!   and the site's `scene.glb` ([`scene`]).
//!
//! Nothing on the default path is planted: the virtual MVS (`mvs =
//! "virtual"`) is a fast stand-in for unit tests only. Everything is
//! seeded: the same configuration gives the same table.
//! `docs/campaign-findings.md` keeps what the experiment found.

pub mod acquired;
pub mod angle_fall;
pub mod crash;
pub mod cross_eval;
pub mod curves;
mod depth_maps;
pub mod eval;
pub mod evaluate;
mod evaluate_dir;
mod gate;
pub mod images;
pub mod label_quality;
pub mod reconstruct;
pub mod reliability;
pub mod renders;
pub mod report;
mod run;
pub mod seen;
mod site;
mod strategy_run;
pub mod training;
pub mod triplet_outcomes;

// The configuration lives at the crate root (`crate::config`, shared with
// `vpctl sim fly`); its old paths under `campaign` stay valid.
pub use crate::config;
pub use crate::config::{
    CampaignConfig, EvalConfig, GridBaseline, InitFlight, MatchingGate, MvsKind, SfmConfig,
    Strategy, TrainingConfig, PRESETS,
};
pub use curves::ConfidenceCurve;
pub use eval::Scores;
pub use evaluate::{evaluate_forest, ForestEvaluation};
pub use evaluate_dir::evaluate_to_dir;
pub use label_quality::LabelQuality;
pub use report::{f_vs_np, html, plot, scene};
pub use report::{write_report, CampaignReport, SiteResult, TableRow};
pub use run::{run_campaign, run_campaign_with_forest, train_campaign_forest};
pub use training::{train_forest, train_forest_with_stats, TrainingStats};
