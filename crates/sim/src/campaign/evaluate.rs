//! Leave-one-site-out evaluation of the confidence forest, as the paper
//! reports it (accuracy against labels made without ground truth, mean and
//! standard deviation over folds) and what the simulator adds: accuracy
//! against the renderer's truth and the Brier score next to an angle-only
//! baseline.
//!
//! Every training site of the config is flown and labelled once, exactly as
//! the training campaign does ([`super::training`]). Fold i trains a forest
//! with the training campaign's parameters and seed on every other site and
//! scores each labelled pixel of site i at its own triangulation angle
//! ([`vp_forest::Forest::score_labels`], as the planner reads confidence).
//! The angle-only baseline predicts, for a pixel in angle bin b, the share
//! of positive labels in bin b over the training sites of the fold: it knows
//! the angle and nothing of the image. Brier skill = 1 - Brier / Brier of
//! that baseline: above 0 the forest's appearance features add something
//! the angle alone does not.
//!
//! Several forest sizes can be compared on the same labels and folds: the
//! measurement by which the default size is chosen (labelling is the
//! expensive part and is done once).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use vp_forest::TrainingSet;
use vp_scene::raster::Label;
use vp_scene::Material;

use super::angle_fall::{angle_fall, AngleFall, SiteSuccess};
use super::curves::CurveAccumulator;
use super::reconstruct::truly_positive;
use super::reliability::Reliability;
use super::training::{label_site, LabelledView, TrainingStats};
use crate::config::CampaignConfig;
use crate::error::{Result, SimError};
use vp_scene::hash::mix64;

/// The paper's leave-one-out accuracies (Sec. 5.1): PMVS and SURE, mean and
/// standard deviation over folds, percent.
pub const PAPER_ACCURACY: [(&str, f64, f64); 2] = [("PMVS", 81.1, 4.2), ("SURE", 65.3, 6.1)];

/// One row of `forest_eval.csv`: a fold's labelled pixels of one material
/// in one angle bin.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct EvalRow {
    /// The campaign's matcher.
    pub matcher: String,
    /// The forest's size, trees x depth.
    pub forest: String,
    /// The held-out site's seed.
    pub fold: u64,
    /// Material under the pixels.
    pub material: String,
    /// Angle bin (index into the forest's bins) of the pixels' own angle.
    pub angle_bin: usize,
    /// Labelled pixels.
    pub pixels: u64,
    /// Share whose prediction (confidence >= 0.5) matches labelgen's label.
    pub accuracy_labels: f64,
    /// Share whose prediction matches the renderer's truth.
    pub accuracy_truth: f64,
    /// Share of the cell's more frequent label: what always predicting it scores.
    pub majority_rate: f64,
    /// Mean squared difference of confidence and label.
    pub brier: f64,
    /// The same for the angle-only baseline.
    pub brier_angle_only: f64,
}

/// The whole evaluation: rows and per-fold totals.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ForestEvaluation {
    /// The campaign's matcher (`mvs` of the config, lowercase).
    pub matcher: String,
    /// One row per (fold, material, angle bin) with pixels.
    pub rows: Vec<EvalRow>,
    /// Per forest size and fold (held-out site seed): totals over its rows.
    pub folds: Vec<(String, u64, Tally)>,
    /// Labelling statistics of all sites.
    pub stats: TrainingStats,
    /// The matcher's measured success per site, material and angle bin.
    pub success: Vec<SiteSuccess>,
    /// Its fall from 5-15 to 35-45 deg on ground and rock (stop rule G1).
    pub fall: Option<AngleFall>,
    /// Per forest size, the reliability diagram over every fold's pixels.
    pub reliability: Vec<Reliability>,
}

/// The narrow and wide angle ranges of the stop rule G1, degrees, and its
/// materials (the paper's SURE curve falls there on its rock and ground).
const G1_NARROW: (f32, f32) = (5.0, 15.0);
const G1_WIDE: (f32, f32) = (35.0, 45.0);
const G1_MATERIALS: [Material; 2] = [Material::Ground, Material::Rock];

/// Running sums over labelled pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Tally {
    /// Pixels.
    pub n: u64,
    /// Predictions matching the label.
    pub right_labels: u64,
    /// Predictions matching the truth.
    pub right_truth: u64,
    /// Positive labels.
    pub positive: u64,
    /// Sum of squared errors of the forest.
    pub brier: f64,
    /// Sum of squared errors of the angle-only baseline.
    pub brier_angle_only: f64,
}

impl Tally {
    pub(super) fn add(&mut self, o: &Tally) {
        self.n += o.n;
        self.right_labels += o.right_labels;
        self.right_truth += o.right_truth;
        self.positive += o.positive;
        self.brier += o.brier;
        self.brier_angle_only += o.brier_angle_only;
    }

    fn share(&self, k: u64) -> f64 {
        k as f64 / self.n.max(1) as f64
    }

    /// Accuracy against the labels.
    pub fn accuracy_labels(&self) -> f64 {
        self.share(self.right_labels)
    }

    /// Accuracy against the truth.
    pub fn accuracy_truth(&self) -> f64 {
        self.share(self.right_truth)
    }

    /// 1 - Brier / Brier of the angle-only baseline.
    pub fn brier_skill(&self) -> f64 {
        1.0 - self.brier / self.brier_angle_only.max(1e-12)
    }
}

/// Every training site of a config flown and labelled once, in
/// `[training] site_seeds` order: the data of every fold.
pub struct LabelledSites {
    /// Per site, its labelled views in the training campaign's order.
    pub sites: Vec<Vec<LabelledView>>,
    /// Labelling statistics of all sites.
    pub stats: TrainingStats,
    /// The matcher's measured success per site, material and angle bin.
    pub success: Vec<SiteSuccess>,
}

/// Flies and labels every training site of `cfg` ([`label_site`], as the
/// training campaign does); `progress` hears one line per step.
pub fn label_sites(cfg: &CampaignConfig, progress: &mut dyn FnMut(&str)) -> Result<LabelledSites> {
    cfg.validate()?;
    let t = &cfg.training;
    if t.site_seeds.len() < 2 {
        return Err(SimError::InvalidArgument(format!(
            "leave-one-site-out evaluation needs at least 2 training sites; [training] \
             site_seeds has {} (the paper's evaluation used 8 or more)",
            t.site_seeds.len()
        )));
    }
    let mut stats = TrainingStats::default();
    let mut sites = Vec::with_capacity(t.site_seeds.len());
    let mut success = Vec::new();
    for &seed in &t.site_seeds {
        let mut curves = CurveAccumulator::new(t.forest.bins.clone());
        sites.push(label_site(cfg, seed, &mut stats, &mut curves, progress)?);
        success.extend(curves.measured_rows(seed));
    }
    Ok(LabelledSites {
        sites,
        stats,
        success,
    })
}

/// One fold's forest and the angle-only baseline of its training sites.
pub struct FoldForest {
    /// Trained on every site but the fold's.
    pub forest: vp_forest::Forest,
    /// The baseline's prediction per angle bin.
    pub angle_only: Vec<f64>,
}

/// Runs the leave-one-site-out evaluation of `cfg`'s training campaign;
/// `progress` hears one line per site and per fold.
///
/// `sizes` lists forest sizes (trees, depth) to evaluate on the same labels
/// and folds; empty: the config's own.
pub fn evaluate_forest(
    cfg: &CampaignConfig,
    sizes: &[(usize, usize)],
    progress: &mut dyn FnMut(&str),
) -> Result<ForestEvaluation> {
    let labelled = label_sites(cfg, progress)?;
    Ok(evaluate_labelled(cfg, &labelled, sizes, progress)?.0)
}

/// [`evaluate_forest`] on sites labelled before; also returns the fold
/// forests of the first size evaluated (for [`super::cross_eval`]).
pub fn evaluate_labelled(
    cfg: &CampaignConfig,
    labelled: &LabelledSites,
    sizes: &[(usize, usize)],
    progress: &mut dyn FnMut(&str),
) -> Result<(ForestEvaluation, Vec<FoldForest>)> {
    let t = &cfg.training;
    let sites = &labelled.sites;
    let bins = &t.forest.bins;
    let fall = angle_fall(
        &labelled.success,
        bins,
        &G1_MATERIALS,
        G1_NARROW,
        G1_WIDE,
        mix64(cfg.seed ^ 0x0067_3166_616c),
    );
    let k_sigma = t.labels.k_sigma as f32;
    let matcher = format!("{:?}", cfg.mvs).to_lowercase();
    let mut out = ForestEvaluation {
        matcher: matcher.clone(),
        stats: labelled.stats.clone(),
        success: labelled.success.clone(),
        fall,
        ..ForestEvaluation::default()
    };
    let mut first_size_forests = Vec::new();
    let own = [(t.forest.n_trees, t.forest.max_depth)];
    for &(n_trees, max_depth) in if sizes.is_empty() { &own[..] } else { sizes } {
        let params = vp_forest::TrainParams {
            n_trees,
            max_depth,
            ..t.forest.clone()
        };
        params.validate()?;
        let size = format!("{n_trees}x{max_depth}");
        let mut diagram = Reliability::new(&size, bins);
        for (i, &fold) in t.site_seeds.iter().enumerate() {
            let train: Vec<&LabelledView> = sites
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .flat_map(|(_, s)| s.iter())
                .collect();
            // The training campaign's cap, seeds and parameters.
            let mut set = TrainingSet::with_cap_per_label_image(
                t.max_per_label_image,
                mix64(cfg.seed ^ 0x0063_6170),
            );
            for v in &train {
                set.add_image(&v.image, std::slice::from_ref(&v.label))?;
            }
            let forest = vp_forest::train(&set, &params, mix64(cfg.seed ^ 0x666f_7265_7374))?;
            let base = angle_only(&train, bins);
            let cells = score_site(&forest, &sites[i], &base, k_sigma, &mut diagram)?;
            if out.reliability.is_empty() {
                first_size_forests.push(FoldForest {
                    forest,
                    angle_only: base,
                });
            }
            let mut total = Tally::default();
            for (&(m, bin), c) in &cells {
                total.add(c);
                let n = c.n as f64;
                out.rows.push(EvalRow {
                    matcher: matcher.clone(),
                    forest: size.clone(),
                    fold,
                    material: Material::ALL[m].name().to_string(),
                    angle_bin: bin,
                    pixels: c.n,
                    accuracy_labels: c.accuracy_labels(),
                    accuracy_truth: c.accuracy_truth(),
                    majority_rate: c.share(c.positive.max(c.n - c.positive)),
                    brier: c.brier / n,
                    brier_angle_only: c.brier_angle_only / n,
                });
            }
            progress(&format!(
                "forest {size}, fold {}/{} (site {fold} held out): {} labelled pixels, accuracy {:.1} % against \
                 the labels, {:.1} % against the truth, Brier skill {:+.3}",
                i + 1,
                t.site_seeds.len(),
                total.n,
                100.0 * total.accuracy_labels(),
                100.0 * total.accuracy_truth(),
                total.brier_skill()
            ));
            out.folds.push((size.clone(), fold, total));
        }
        out.reliability.push(diagram);
    }
    Ok((out, first_size_forests))
}

/// Scores the labelled pixels of one held-out site's `views` with `forest`
/// and the angle-only baseline `base`: running sums per (material, angle bin),
/// and every pixel into the reliability `diagram`.
pub(super) fn score_site(
    forest: &vp_forest::Forest,
    views: &[LabelledView],
    base: &[f64],
    k_sigma: f32,
    diagram: &mut Reliability,
) -> Result<BTreeMap<(usize, usize), Tally>> {
    let bins = forest.bins();
    let mut cells: BTreeMap<(usize, usize), Tally> = BTreeMap::new();
    for v in views {
        let scored = forest.score_labels(&v.image, &v.label)?;
        let w = v.label.width() as usize;
        for ((x, y, label, angle), s) in v.label.labelled().zip(scored) {
            let px = y as usize * w + x as usize;
            let (Some(truth), Some(bin)) = (v.truth.get(px), bins.bin_of(angle)) else {
                continue;
            };
            let Some(material) = truth.material else {
                continue;
            };
            let positive = label == Label::Positive;
            let truly = truly_positive(truth, v.depth[px], k_sigma);
            let predicted = s.confidence >= 0.5;
            let y = f64::from(u8::from(positive));
            let c = cells.entry((material as usize, bin)).or_default();
            c.n += 1;
            c.right_labels += u64::from(predicted == positive);
            c.right_truth += u64::from(predicted == truly);
            c.positive += u64::from(positive);
            c.brier += (f64::from(s.confidence) - y).powi(2);
            c.brier_angle_only += (base[bin] - y).powi(2);
            diagram.add(bin, s.confidence, positive, truly);
        }
    }
    Ok(cells)
}

/// Share of positive labels per angle bin over `views`: the angle-only
/// baseline's prediction (0.5 in a bin without labels).
fn angle_only(views: &[&LabelledView], bins: &vp_scene::raster::AngleBins) -> Vec<f64> {
    let mut pos = vec![0u64; bins.len()];
    let mut all = vec![0u64; bins.len()];
    for v in views {
        for (_, _, label, angle) in v.label.labelled() {
            if let Some(b) = bins.bin_of(angle) {
                all[b] += 1;
                pos[b] += u64::from(label == Label::Positive);
            }
        }
    }
    pos.iter()
        .zip(&all)
        .map(|(&p, &a)| if a == 0 { 0.5 } else { p as f64 / a as f64 })
        .collect()
}

impl ForestEvaluation {
    /// `forest_eval.csv`: a header and one line per row.
    pub fn csv(&self) -> String {
        let mut s = String::from(
            "matcher,forest,fold,material,angle_bin,pixels,accuracy_labels,accuracy_truth,\
             majority_rate,brier,brier_angle_only\n",
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.5},{:.5}",
                r.matcher,
                r.forest,
                r.fold,
                r.material,
                r.angle_bin,
                r.pixels,
                r.accuracy_labels,
                r.accuracy_truth,
                r.majority_rate,
                r.brier,
                r.brier_angle_only
            );
        }
        s
    }

    /// The forest sizes evaluated, in order.
    fn sizes(&self) -> Vec<&str> {
        let mut v: Vec<&str> = Vec::new();
        for (size, _, _) in &self.folds {
            if !v.contains(&size.as_str()) {
                v.push(size);
            }
        }
        v
    }

    /// The printed summary, per forest size: accuracy over folds (mean and
    /// sample standard deviation) next to the paper's, and the Brier skill
    /// over the angle-only baseline.
    pub fn summary(&self) -> String {
        let paper: Vec<String> = PAPER_ACCURACY
            .iter()
            .map(|(m, a, s)| format!("{m} {a} ± {s}"))
            .collect();
        let mut out = String::new();
        for size in self.sizes() {
            let folds: Vec<&Tally> = self
                .folds
                .iter()
                .filter(|(s, _, _)| s == size)
                .map(|(_, _, t)| t)
                .collect();
            let mut all = Tally::default();
            for t in &folds {
                all.add(t);
            }
            let over = |f: fn(&Tally) -> f64| {
                let v: Vec<f64> = folds.iter().map(|t| f(t)).collect();
                let n = v.len() as f64;
                let mean = v.iter().sum::<f64>() / n.max(1.0);
                let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
                (mean, var.sqrt())
            };
            let (la, ls) = over(Tally::accuracy_labels);
            let (ta, ts) = over(Tally::accuracy_truth);
            let (sa, ss) = over(Tally::brier_skill);
            let skilled = folds.iter().filter(|t| t.brier_skill() > 0.0).count();
            let _ = writeln!(
                out,
                "forest {size}, leave-one-site-out over {} folds, {} labelled pixels:\n  \
                 accuracy against the labels: {:.1} ± {:.1} % (the paper, against its labels: \
                 {} %)\n  accuracy against the truth: {:.1} ± {:.1} %\n  Brier skill over the \
                 angle-only baseline: {:+.3} pooled, {sa:+.3} ± {ss:.3} over folds (> 0: the \
                 image adds to the angle), above 0 in {skilled} of {} folds\n  majority label \
                 share: {:.1} %",
                folds.len(),
                all.n,
                100.0 * la,
                100.0 * ls,
                paper.join(", "),
                100.0 * ta,
                100.0 * ts,
                all.brier_skill(),
                folds.len(),
                100.0 * all.share(all.positive.max(all.n - all.positive)),
            );
            if let Some(r) = self.reliability.iter().find(|r| r.forest == size) {
                let _ = writeln!(
                    out,
                    "  calibration error (ECE, 10 confidence bins, against the labels): {:.3} \
                     ({})",
                    r.ece(),
                    r.file_name(&self.matcher)
                );
            }
        }
        if let Some(f) = &self.fall {
            out.push_str(&f.summary());
        }
        out
    }
}
