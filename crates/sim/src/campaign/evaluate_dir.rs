//! `vpctl sim evaluate`'s front door: the leave-one-site-out evaluation
//! ([`super::evaluate`]) run from a config file and written to a folder with
//! its report ([`super::report::eval_html`]). Apart from the evaluation so
//! that the report reads the evaluation's results and nothing in the
//! evaluation reads the report.

use std::path::Path;

use vp_scene::outdir::OutDir;
use vp_scene::SceneError;

use super::angle_fall;
use super::evaluate::{evaluate_forest, ForestEvaluation};
use super::reliability;
use crate::config::CampaignConfig;
use crate::error::{Result, SimError};

/// `vpctl sim evaluate`: evaluates the campaign of the config file `config`
/// ([`evaluate_forest`]) and writes `out/forest_eval.csv`,
/// `out/angle_success.csv`, `out/reliability.csv` with one
/// `reliability_<matcher>_<forest>.png` per forest size, `out/label_quality.csv`,
/// `out/summary.txt` and `out/report.html` (the output folder rules of
/// [`OutDir`]; nothing is written when the evaluation fails).
pub fn evaluate_to_dir(
    config: &Path,
    sizes: &[(usize, usize)],
    out: &Path,
    force: bool,
    progress: &mut dyn FnMut(&str),
) -> Result<ForestEvaluation> {
    let cfg = CampaignConfig::load(config)?;
    let dir = OutDir::check(out, "sim evaluate", &[config], force)?;
    let eval = evaluate_forest(&cfg, sizes, progress).map_err(|e| match e {
        SimError::InvalidArgument(m) => {
            SimError::InvalidArgument(format!("{}: {m}", config.display()))
        }
        e => e,
    })?;
    dir.write(|stage| -> Result<()> {
        let bins = &cfg.training.forest.bins;
        for (name, text) in [
            ("forest_eval.csv", eval.csv()),
            (
                "angle_success.csv",
                angle_fall::csv(&eval.matcher, &eval.success, bins),
            ),
            (
                "reliability.csv",
                reliability::csv(&eval.matcher, &eval.reliability),
            ),
            ("label_quality.csv", eval.stats.label_quality.csv()),
            ("summary.txt", eval.summary()),
        ] {
            let p = stage.join(name);
            std::fs::write(&p, text).map_err(|e| SceneError::io(&p, e))?;
        }
        super::report::eval_html::write(&eval, stage)
    })?;
    Ok(eval)
}
