//! Hypotheses H3-H6 of the two-matcher experiment (issue 35), read from
//! two campaign report folders of the same held-out sites: one flown with
//! SGM, one with PatchMatch, each with its own forest. The rules are the
//! issue's, fixed before the campaigns ran; counts "7 of 8" and "6 of 8"
//! scale with the number of sites (rounded up).
//!
//! - H3: with SGM, F plans narrower triangulation angles than with
//!   PatchMatch (the mean planned angle of F's flown triplets per site).
//! - H4 (primary): f(F) - f(NP) > 0 with SGM on 7 of 8 sites, and SGM's gap
//!   minus PatchMatch's, paired by site, has a 95 % bootstrap interval
//!   above 0 (the claim is that the gap is the matcher's).
//! - H5: with SGM, F's triplet success >= 90 % and NP's lower, on 6 of 8
//!   sites; with PatchMatch the mean triplet success of F and NP within 5
//!   points.
//! - H6, per matcher: F covers more than the Grid with fewer images and
//!   more than the oblique capture with as many, on 6 of 8 sites.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use serde_json::Value;

use super::results::CampaignReport;
use crate::campaign::angle_fall::bootstrap_mean;
use crate::error::{Result, SimError};

/// Table-1 figures of one strategy on one site (percent; images a count).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Figures {
    /// Coverage of the ROI.
    pub coverage: f64,
    /// The fulfillment f.
    pub f: f64,
    /// Triplet success (None: no triplets flown).
    pub success: Option<f64>,
    /// Distinct images.
    pub images: f64,
}

/// One held-out site of one campaign.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SiteFigures {
    /// The site's seed.
    pub seed: u64,
    /// Per strategy name.
    pub strategies: BTreeMap<String, Figures>,
    /// Per strategy name, the planned angle (degrees) of each flown triplet.
    pub planned_angles: BTreeMap<String, Vec<f64>>,
}

impl SiteFigures {
    /// The mean planned angle (degrees) of `strategy`'s flown triplets;
    /// NaN where it flew none with a planned angle: never "narrower".
    pub fn mean_planned_angle(&self, strategy: &str) -> f64 {
        self.planned_angles
            .get(strategy)
            .filter(|v| !v.is_empty())
            .map_or(f64::NAN, |v| mean(v))
    }
}

/// One campaign: its matcher (`mvs` of its config) and its sites.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MatcherCampaign {
    /// "sgm", "patchmatch", ...
    pub matcher: String,
    /// In the report's order.
    pub sites: Vec<SiteFigures>,
    /// The fingerprint of the forest its F strategies flew
    /// ([`vp_forest::Forest::fingerprint`]); `None` for a report written
    /// before reports recorded it.
    pub forest: Option<String>,
}

impl MatcherCampaign {
    /// The figures of a campaign run in this process.
    pub fn from_report(r: &CampaignReport) -> Self {
        let sites = r
            .sites
            .iter()
            .map(|site| {
                let mut s = SiteFigures {
                    seed: site.seed,
                    ..SiteFigures::default()
                };
                for (name, sc) in &site.scores {
                    let figures = Figures {
                        coverage: sc.coverage,
                        f: sc.f,
                        success: sc.triplet_success,
                        images: sc.n_images as f64,
                    };
                    s.strategies.insert(name.clone(), figures);
                }
                for t in &site.triplets {
                    if let Some(angle) = t.planned_angle_deg {
                        s.planned_angles
                            .entry(t.strategy.clone())
                            .or_default()
                            .push(angle);
                    }
                }
                s
            })
            .collect();
        MatcherCampaign {
            matcher: format!("{:?}", r.config.mvs).to_lowercase(),
            sites,
            forest: Some(r.forest_fingerprint.clone()),
        }
    }
}

fn bad(path: &Path, what: &str) -> SimError {
    SimError::InvalidArgument(format!(
        "{}: {what} (expected report.json of `vpctl sim run`)",
        path.display()
    ))
}

/// Reads `report.json` of a campaign report folder `dir`.
pub fn read_campaign(dir: &Path) -> Result<MatcherCampaign> {
    let path = dir.join("report.json");
    let text = std::fs::read_to_string(&path).map_err(|e| {
        SimError::InvalidArgument(format!(
            "{}: {e} (give the folder `vpctl sim run --out` wrote)",
            path.display()
        ))
    })?;
    let json: Value = serde_json::from_str(&text).map_err(|e| bad(&path, &e.to_string()))?;
    let matcher = json["config"]["mvs"]
        .as_str()
        .ok_or_else(|| bad(&path, "no config.mvs"))?
        .to_lowercase();
    let sites = json["sites"]
        .as_array()
        .ok_or_else(|| bad(&path, "no sites"))?;
    let mut out = MatcherCampaign {
        matcher,
        sites: Vec::new(),
        forest: json["forest_fingerprint"].as_str().map(str::to_string),
    };
    for site in sites {
        let seed = site["seed"]
            .as_u64()
            .ok_or_else(|| bad(&path, "a site without seed"))?;
        let mut s = SiteFigures {
            seed,
            ..SiteFigures::default()
        };
        for pair in site["scores"].as_array().into_iter().flatten() {
            let (Some(name), sc) = (pair[0].as_str(), &pair[1]) else {
                return Err(bad(&path, "a score without strategy name"));
            };
            let num = |k: &str| {
                sc[k]
                    .as_f64()
                    .ok_or_else(|| bad(&path, &format!("{name}: no {k}")))
            };
            let figures = Figures {
                coverage: num("coverage")?,
                f: num("f")?,
                success: sc["triplet_success"].as_f64(),
                images: num("n_images")?,
            };
            s.strategies.insert(name.to_string(), figures);
        }
        for t in site["triplets"].as_array().into_iter().flatten() {
            if let (Some(name), Some(angle)) =
                (t["strategy"].as_str(), t["planned_angle_deg"].as_f64())
            {
                s.planned_angles
                    .entry(name.to_string())
                    .or_default()
                    .push(angle);
            }
        }
        out.sites.push(s);
    }
    Ok(out)
}

/// One hypothesis: its verdict and the figures it rests on.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// "H3", ...
    pub name: String,
    /// Whether it holds.
    pub holds: bool,
    /// The figures, in words.
    pub figures: String,
}

/// The whole comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// The F strategy and its NP twin compared.
    pub strategies: (String, String),
    /// The sites' seeds, in order.
    pub seeds: Vec<u64>,
    /// Per site: SGM's and PatchMatch's f of F and of NP.
    pub f: Vec<[(f64, f64); 2]>,
    /// Per site: mean planned angle of F's triplets with SGM and PatchMatch.
    pub angle: Vec<(f64, f64)>,
    /// H3-H6 in order (H6 once per matcher).
    pub verdicts: Vec<Verdict>,
    /// The forests flown with SGM and with PatchMatch (fingerprints).
    pub forests: (Option<String>, Option<String>),
}

/// Sites needed of `n` for "k of 8", rounded up.
fn needed(k: usize, n: usize) -> usize {
    (k * n).div_ceil(8)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The mean of the finite values of `v` (NaN when there are none).
fn mean_finite(v: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = v.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        f64::NAN
    } else {
        mean(&v)
    }
}

fn figures<'a>(site: &'a SiteFigures, name: &str) -> Result<&'a Figures> {
    site.strategies.get(name).ok_or_else(|| {
        SimError::InvalidArgument(format!(
            "site {}: no strategy {name} in the report",
            site.seed
        ))
    })
}

/// H3-H6 from the SGM campaign `sgm` and the PatchMatch campaign `pm` on
/// the same sites; `f_name` and `np_name` the strategies compared (F5x4,
/// NP5x4); the bootstrap draws from `seed`.
pub fn compare(
    sgm: &MatcherCampaign,
    pm: &MatcherCampaign,
    (f_name, np_name): (&str, &str),
    seed: u64,
) -> Result<Comparison> {
    let seeds: Vec<u64> = sgm.sites.iter().map(|s| s.seed).collect();
    let pm_seeds: Vec<u64> = pm.sites.iter().map(|s| s.seed).collect();
    if seeds != pm_seeds || seeds.is_empty() {
        return Err(SimError::InvalidArgument(format!(
            "the two campaigns must fly the same held-out sites (SGM {seeds:?}, PatchMatch {pm_seeds:?})"
        )));
    }
    let n = seeds.len();
    let mut f = Vec::with_capacity(n);
    let mut angle = Vec::with_capacity(n);
    for (a, b) in sgm.sites.iter().zip(&pm.sites) {
        let pair = |s: &SiteFigures| -> Result<(f64, f64)> {
            Ok((figures(s, f_name)?.f, figures(s, np_name)?.f))
        };
        f.push([pair(a)?, pair(b)?]);
        angle.push((a.mean_planned_angle(f_name), b.mean_planned_angle(f_name)));
    }
    let mut verdicts = Vec::new();

    let narrower = angle.iter().filter(|(s, p)| s < p).count();
    verdicts.push(Verdict {
        name: "H3".into(),
        holds: narrower >= needed(7, n),
        figures: format!(
            "{f_name}'s mean planned angle is narrower with SGM than with PatchMatch on {narrower} of {n} sites \
             (needs {}); means {:.1} and {:.1} deg",
            needed(7, n),
            mean_finite(angle.iter().map(|a| a.0)),
            mean_finite(angle.iter().map(|a| a.1)),
        ),
    });

    let gap = |m: usize| -> Vec<f64> { f.iter().map(|s| s[m].0 - s[m].1).collect() };
    let (gap_sgm, gap_pm) = (gap(0), gap(1));
    let ahead = gap_sgm.iter().filter(|&&g| g > 0.0).count();
    let diff: Vec<f64> = gap_sgm.iter().zip(&gap_pm).map(|(a, b)| a - b).collect();
    let (d, (lo, hi)) = bootstrap_mean(&diff, seed);
    verdicts.push(Verdict {
        name: "H4".into(),
        holds: ahead >= needed(7, n) && lo > 0.0,
        figures: format!(
            "with SGM f({f_name}) - f({np_name}) > 0 on {ahead} of {n} sites (needs {}), mean {:+.1} points; \
             PatchMatch's gap mean {:+.1}; SGM's gap minus PatchMatch's {d:+.1} points (95 % bootstrap \
             interval over sites {lo:+.1} .. {hi:+.1}; needs it above 0)",
            needed(7, n),
            mean(&gap_sgm),
            mean(&gap_pm),
        ),
    });

    verdicts.push(h5(sgm, pm, (f_name, np_name))?);
    for c in [sgm, pm] {
        verdicts.push(h6(c, f_name)?);
    }
    Ok(Comparison {
        strategies: (f_name.into(), np_name.into()),
        seeds,
        f,
        angle,
        verdicts,
        forests: (sgm.forest.clone(), pm.forest.clone()),
    })
}

fn h5(
    sgm: &MatcherCampaign,
    pm: &MatcherCampaign,
    (f_name, np_name): (&str, &str),
) -> Result<Verdict> {
    let n = sgm.sites.len();
    let mut sgm_sites = 0;
    for s in &sgm.sites {
        let (fs, ns) = (figures(s, f_name)?.success, figures(s, np_name)?.success);
        if let (Some(fs), Some(ns)) = (fs, ns) {
            sgm_sites += usize::from(fs >= 90.0 && ns < fs);
        }
    }
    let mean_success = |c: &MatcherCampaign, name: &str| -> Result<f64> {
        let v: Vec<f64> = c
            .sites
            .iter()
            .map(|s| figures(s, name).map(|f| f.success.unwrap_or(0.0)))
            .collect::<Result<_>>()?;
        Ok(mean(&v))
    };
    let (pf, pn) = (mean_success(pm, f_name)?, mean_success(pm, np_name)?);
    let (sf, sn) = (mean_success(sgm, f_name)?, mean_success(sgm, np_name)?);
    Ok(Verdict {
        name: "H5".into(),
        holds: sgm_sites >= needed(6, n) && (pf - pn).abs() <= 5.0,
        figures: format!(
            "with SGM {f_name} >= 90 % triplet success and {np_name} lower on {sgm_sites} of {n} sites (needs {}; \
             means {sf:.1} and {sn:.1} %); with PatchMatch |F - NP| = {:.1} points ({pf:.1} and {pn:.1} %, needs <= 5)",
            needed(6, n),
            (pf - pn).abs(),
        ),
    })
}

fn h6(c: &MatcherCampaign, f_name: &str) -> Result<Verdict> {
    let n = c.sites.len();
    // Sites where F out-covers the Grid, where it also flies fewer images
    // than the Grid, where it out-covers the oblique capture (with at most
    // as many images), and where all three hold.
    let (mut grid_cov, mut grid_fewer, mut oblique_cov, mut all) = (0, 0, 0, 0);
    for s in &c.sites {
        let (f, grid) = (figures(s, f_name)?, figures(s, "Grid")?);
        let Some(obl) = s.strategies.get("Oblique") else {
            return Ok(Verdict {
                name: format!("H6 ({})", c.matcher),
                holds: false,
                figures: "no Oblique row (fly with [grid] oblique = true)".into(),
            });
        };
        let g = f.coverage > grid.coverage;
        let fewer = f.images < grid.images;
        let o = f.coverage > obl.coverage && f.images <= obl.images;
        grid_cov += usize::from(g);
        grid_fewer += usize::from(g && fewer);
        oblique_cov += usize::from(o);
        all += usize::from(g && fewer && o);
    }
    Ok(Verdict {
        name: format!("H6 ({})", c.matcher),
        holds: all >= needed(6, n),
        figures: format!(
            "{f_name} covers more than the Grid with fewer images and more than the oblique capture with \
             as many on {all} of {n} sites (needs {}): more than the Grid on {grid_cov} (with fewer \
             images on {grid_fewer}), more than the oblique capture on {oblique_cov}",
            needed(6, n)
        ),
    })
}

/// `vpctl sim compare`: reads each matcher's draws (a draw: the report
/// folders of one campaign, or of batches of held-out sites flown with one
/// saved forest: `sim train`, then `sim run --forest` per batch), checks
/// each folder holds the matcher its flag says, no site twice in a draw, one
/// forest per draw and no forest in two draws (where reports record their
/// forest). With one draw per matcher, compares `f_name` (an F strategy)
/// with its NP twin over the sites in seed order ([`Comparison::markdown`]);
/// with more, reads H3 and H4 over the draws ([`over_draws`]).
pub fn compare_dirs<P: AsRef<Path>>(
    (sgm, pm): (&[Vec<P>], &[Vec<P>]),
    f_name: &str,
    seed: u64,
) -> Result<String> {
    let np_name = f_name
        .strip_prefix('F')
        .map(|rest| format!("NP{rest}"))
        .ok_or_else(|| {
            SimError::InvalidArgument(format!(
                "--strategy {f_name}: not an F strategy (e.g. F5x4)"
            ))
        })?;
    let (sgm, pm) = (read_draws(sgm, "sgm")?, read_draws(pm, "patchmatch")?);
    if let ([s], [p]) = (&sgm[..], &pm[..]) {
        let c = compare(&s.campaign, &p.campaign, (f_name, &np_name), seed)?;
        return Ok(c.markdown());
    }
    Ok(over_draws::compare(&sgm, &pm, (f_name, &np_name), seed)?.markdown())
}

/// Each draw of `draws` (its report folders), all flown with `matcher`;
/// two draws that flew one forest are refused: it would count twice.
fn read_draws<P: AsRef<Path>>(draws: &[Vec<P>], matcher: &str) -> Result<Vec<Draw>> {
    let mut out: Vec<Draw> = Vec::with_capacity(draws.len());
    for dirs in draws {
        let draw = read_draw(dirs, matcher)?;
        let same = out
            .iter()
            .find(|d| draw.campaign.forest.is_some() && d.campaign.forest == draw.campaign.forest);
        if let (Some(first), Some(forest)) = (same, &draw.campaign.forest) {
            return Err(SimError::InvalidArgument(format!(
                "{} and {} flew the same forest {forest} and were given as two draws: give \
                 batches of one draw comma-separated after one flag",
                first.folders[0].display(),
                draw.folders[0].display()
            )));
        }
        out.push(draw);
    }
    Ok(out)
}

/// The sites of every report folder in `dirs`, all flown with `matcher`
/// and one forest, in seed order; a site in two folders is refused.
fn read_draw<P: AsRef<Path>>(dirs: &[P], matcher: &str) -> Result<Draw> {
    let mut all = Draw::default();
    all.campaign.matcher = matcher.into();
    // The folder each forest fingerprint was first read from.
    let mut forest_from: Option<(String, &Path)> = None;
    let mut from: BTreeMap<u64, &Path> = BTreeMap::new();
    for dir in dirs {
        let dir = dir.as_ref();
        let c = read_campaign(dir)?;
        if c.matcher != matcher {
            return Err(SimError::InvalidArgument(format!(
                "{}: flown with mvs = \"{}\", not \"{matcher}\"",
                dir.display(),
                c.matcher
            )));
        }
        if let Some(f) = &c.forest {
            match &forest_from {
                Some((first, first_dir)) if first != f => {
                    return Err(SimError::InvalidArgument(format!(
                        "{} flew the forest {first} and {} the forest {f}: batches of one \
                         draw must fly one forest (`sim run --forest`); give another \
                         forest's flights as another draw (the flag again)",
                        first_dir.display(),
                        dir.display()
                    )));
                }
                Some(_) => {}
                None => forest_from = Some((f.clone(), dir)),
            }
        }
        for site in c.sites {
            if let Some(first) = from.insert(site.seed, dir) {
                return Err(SimError::InvalidArgument(format!(
                    "held-out site {} is in {} and in {}: give each site's batch once",
                    site.seed,
                    first.display(),
                    dir.display()
                )));
            }
            all.campaign.sites.push(site);
        }
        all.folders.push(dir.to_path_buf());
    }
    all.campaign.sites.sort_by_key(|s| s.seed);
    all.campaign.forest = forest_from.map(|(f, _)| f);
    Ok(all)
}

impl Comparison {
    /// Markdown: the per-site table, then one line per hypothesis.
    pub fn markdown(&self) -> String {
        let (fname, npname) = &self.strategies;
        let mut s = format!(
            "| site | SGM f {fname} | SGM f {npname} | SGM gap | PatchMatch f {fname} | PatchMatch f {npname} | \
             PatchMatch gap | {fname} mean planned angle SGM / PatchMatch (deg) |\n|---|---|---|---|---|---|---|---|\n"
        );
        for ((seed, [a, b]), (sa, pa)) in self.seeds.iter().zip(&self.f).zip(&self.angle) {
            let _ = writeln!(
                s,
                "| {seed} | {:.1} | {:.1} | {:+.1} | {:.1} | {:.1} | {:+.1} | {sa:.1} / {pa:.1} |",
                a.0,
                a.1,
                a.0 - a.1,
                b.0,
                b.1,
                b.0 - b.1
            );
        }
        s.push('\n');
        let name = |f: &Option<String>| f.clone().unwrap_or_else(|| "not recorded".into());
        let _ = writeln!(
            s,
            "Forests flown ({fname}; fingerprints): SGM {}, PatchMatch {}. Another forest \
             trained on the same sites (another draw, or labels a few pixels apart) flies other \
             triplets: per-site figures carry the forest's training draw.\n",
            name(&self.forests.0),
            name(&self.forests.1)
        );
        for v in &self.verdicts {
            let _ = writeln!(s, "{}", v.markdown());
        }
        s
    }
}

impl Verdict {
    /// One markdown list item: the name, holds or not, the figures.
    pub fn markdown(&self) -> String {
        let holds = if self.holds { "holds" } else { "does not hold" };
        format!("- **{}: {holds}.** {}", self.name, self.figures)
    }
}

#[path = "over_draws.rs"]
pub mod over_draws;
use over_draws::Draw;

#[cfg(test)]
#[path = "two_matchers_tests.rs"]
mod tests;
