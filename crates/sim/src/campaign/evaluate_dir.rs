//! `vpctl sim evaluate`'s front door: the leave-one-site-out evaluation
//! ([`super::evaluate`]) run from a config file and written to a folder with
//! its report ([`super::report::eval_html`]). Apart from the evaluation so
//! that the report reads the evaluation's results and nothing in the
//! evaluation reads the report.

use std::fmt::Write as _;
use std::path::Path;

use vp_scene::outdir::OutDir;
use vp_scene::SceneError;

use super::angle_fall;
use super::cross_eval::{self, MatcherFolds};
use super::evaluate::{evaluate_labelled, label_sites, ForestEvaluation};
use super::reliability;
use crate::config::CampaignConfig;
use crate::error::{Result, SimError};

/// `vpctl sim evaluate`: evaluates the campaign of the config file `config`
/// ([`evaluate_forest`]) and writes `out/forest_eval.csv`,
/// `out/angle_success.csv`, `out/reliability.csv` with one
/// `reliability_<matcher>_<forest>.png` per forest size, `out/label_quality.csv`,
/// `out/summary.txt` and `out/report.html` (the output folder rules of
/// [`OutDir`]; nothing is written when the evaluation fails).
///
/// With `versus` (a second config, the other matcher on the same training
/// sites), that config is evaluated too, its files written to
/// `out/versus/`, and each matcher's fold forests score the other's labels
/// ([`cross_eval`], hypothesis H2 of issue 35): `out/cross.csv` and H2's
/// lines in the summary. The returned summary covers both.
pub fn evaluate_to_dir(
    config: &Path,
    versus: Option<&Path>,
    sizes: &[(usize, usize)],
    (out, force): (&Path, bool),
    progress: &mut dyn FnMut(&str),
) -> Result<String> {
    let cfg = CampaignConfig::load(config)?;
    let other = versus.map(CampaignConfig::load).transpose()?;
    if let (Some(path), Some(other)) = (versus, &other) {
        cross_eval::check_same_folds(&cfg, other).map_err(named(path))?;
    }
    let mut inputs = vec![config];
    inputs.extend(versus);
    let dir = OutDir::check(out, "sim evaluate", &inputs, force)?;
    let labelled = label_sites(&cfg, progress).map_err(named(config))?;
    let (eval, forests) =
        evaluate_labelled(&cfg, &labelled, sizes, progress).map_err(named(config))?;
    let mut summary = eval.summary();
    let mut second = None;
    if let (Some(path), Some(other)) = (versus, &other) {
        let labelled_b = label_sites(other, progress).map_err(named(path))?;
        let (eval_b, forests_b) =
            evaluate_labelled(other, &labelled_b, sizes, progress).map_err(named(path))?;
        let folds = |cfg, eval, labelled, forests| MatcherFolds {
            cfg,
            eval,
            labelled,
            forests,
        };
        let rows = cross_eval::cross_evaluate(
            &folds(&cfg, &eval, &labelled, &forests),
            &folds(other, &eval_b, &labelled_b, &forests_b),
        )
        .map_err(named(path))?;
        let _ = write!(
            summary,
            "\nversus {}:\n{}",
            path.display(),
            eval_b.summary()
        );
        summary.push_str(&cross_eval::summary(&rows, &eval.matcher, &eval_b.matcher));
        second = Some((eval_b, rows));
    }
    dir.write(|stage| -> Result<()> {
        write_evaluation(&eval, &cfg, stage)?;
        if let (Some((eval_b, rows)), Some(other)) = (&second, &other) {
            let sub = stage.join("versus");
            std::fs::create_dir_all(&sub).map_err(|e| SceneError::io(&sub, e))?;
            write_evaluation(eval_b, other, &sub)?;
            let p = stage.join("cross.csv");
            std::fs::write(&p, cross_eval::csv(rows)).map_err(|e| SceneError::io(&p, e))?;
        }
        let p = stage.join("summary.txt");
        std::fs::write(&p, &summary).map_err(|e| SceneError::io(&p, e))?;
        Ok(())
    })?;
    Ok(summary)
}

/// A config's own errors prefixed with its file name.
fn named(path: &Path) -> impl Fn(SimError) -> SimError + '_ {
    move |e| match e {
        SimError::InvalidArgument(m) => {
            SimError::InvalidArgument(format!("{}: {m}", path.display()))
        }
        e => e,
    }
}

/// One evaluation's files into `dir` (all but the summary).
fn write_evaluation(eval: &ForestEvaluation, cfg: &CampaignConfig, dir: &Path) -> Result<()> {
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
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| SceneError::io(&p, e))?;
    }
    super::report::eval_html::write(eval, dir)
}
