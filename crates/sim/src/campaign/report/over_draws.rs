//! H3 and H4 over several forest draws of each matcher.
//!
//! One campaign's F figures carry the draw of its forest's training:
//! another forest trained on the same sites plans other triplets, and on
//! bare ground moved a site's f by up to 9 points (docs/campaign-findings.md,
//! "Why SGM's F5x4 moved"). With several draws per matcher (each a forest
//! flown on the same held-out sites), the hypotheses are read on the
//! draws' mean, and the bootstrap resamples the draws as well as the
//! sites. The rule was written down before it was first computed
//! (docs/campaign-findings.md, "H3 and H4 over forest draws"):
//!
//! - per site and matcher, the *draw-mean gap*: the mean over the
//!   matcher's draws of f(F) - f(NP); and the mean over its draws of F's
//!   mean planned angle;
//! - H3: SGM's draw-mean angle narrower than PatchMatch's on 7 of 8 sites;
//! - H4: SGM's draw-mean gap above 0 on 7 of 8 sites, and the mean over
//!   sites of SGM's draw-mean gap minus PatchMatch's with a 95 % bootstrap
//!   interval above 0. One forest flies every site, so sites and draws are
//!   crossed: each resample draws the sites with replacement, then, once
//!   for all of them, each matcher's draws with replacement.
//!
//! The two matchers' draws are trained apart: they are not paired.

use std::fmt::Write as _;
use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{figures, mean, mean_finite, needed, MatcherCampaign, Verdict};
use crate::error::{Result, SimError};

/// Bootstrap resamples, as the one-campaign interval's.
const RESAMPLES: usize = 10_000;

/// One draw of one matcher: the sites flown with one forest, and the
/// report folders they came from.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Draw {
    /// The merged batches (`forest` is the draw's fingerprint).
    pub campaign: MatcherCampaign,
    /// The report folders, as given.
    pub folders: Vec<PathBuf>,
}

/// One draw's row: its forest, folders and per-site gap f(F) - f(NP).
#[derive(Debug, Clone, PartialEq)]
pub struct DrawRow {
    /// Fingerprint, or "not recorded".
    pub forest: String,
    /// The report folders.
    pub folders: Vec<String>,
    /// Per site, in seed order.
    pub gaps: Vec<f64>,
}

/// The comparison over draws.
#[derive(Debug, Clone, PartialEq)]
pub struct DrawComparison {
    /// The F strategy and its NP twin.
    pub strategies: (String, String),
    /// The sites' seeds, in order.
    pub seeds: Vec<u64>,
    /// SGM's draws, then PatchMatch's.
    pub draws: [Vec<DrawRow>; 2],
    /// Per site: the draw-mean gap with SGM and with PatchMatch, and F's
    /// draw-mean planned angle with SGM and with PatchMatch (degrees).
    pub sites: Vec<[f64; 4]>,
    /// H3, then H4.
    pub verdicts: Vec<Verdict>,
}

/// Per draw of one matcher, its row and its F's mean planned angle per
/// site (NaN where F flew no triplet with one), checking that every draw
/// flies the sites `seeds`.
fn rows(
    draws: &[Draw],
    name: &str,
    seeds: &[u64],
    (f_name, np_name): (&str, &str),
) -> Result<(Vec<DrawRow>, Vec<Vec<f64>>)> {
    let mut out = Vec::with_capacity(draws.len());
    let mut angles = Vec::with_capacity(draws.len());
    for d in draws {
        let forest = d
            .campaign
            .forest
            .clone()
            .unwrap_or_else(|| "not recorded".into());
        let folders: Vec<String> = d.folders.iter().map(|p| p.display().to_string()).collect();
        let flown: Vec<u64> = d.campaign.sites.iter().map(|s| s.seed).collect();
        if flown != seeds {
            return Err(SimError::InvalidArgument(format!(
                "{name}'s draw with forest {forest} ({}) flew the sites {flown:?}, another draw \
                 {seeds:?}: every draw of both matchers must fly the same held-out sites",
                folders.join(", ")
            )));
        }
        let mut gaps = Vec::with_capacity(seeds.len());
        let mut angle = Vec::with_capacity(seeds.len());
        for s in &d.campaign.sites {
            gaps.push(figures(s, f_name)?.f - figures(s, np_name)?.f);
            angle.push(s.mean_planned_angle(f_name));
        }
        out.push(DrawRow {
            forest,
            folders,
            gaps,
        });
        angles.push(angle);
    }
    Ok((out, angles))
}

/// H3 and H4 over the draws `sgm` and `pm` (at least one each); the
/// bootstrap draws from `seed`.
pub fn compare(
    sgm: &[Draw],
    pm: &[Draw],
    strategies: (&str, &str),
    seed: u64,
) -> Result<DrawComparison> {
    let seeds: Vec<u64> = sgm
        .first()
        .or(pm.first())
        .map(|d| d.campaign.sites.iter().map(|s| s.seed).collect())
        .unwrap_or_default();
    if sgm.is_empty() || pm.is_empty() || seeds.is_empty() {
        return Err(SimError::InvalidArgument(
            "each matcher needs at least one report folder with held-out sites".into(),
        ));
    }
    let (sgm_rows, sgm_angles) = rows(sgm, "SGM", &seeds, strategies)?;
    let (pm_rows, pm_angles) = rows(pm, "PatchMatch", &seeds, strategies)?;
    let draw_mean =
        |rows: &[DrawRow], s: usize| mean(&rows.iter().map(|r| r.gaps[s]).collect::<Vec<_>>());
    let angle_mean = |a: &[Vec<f64>], s: usize| mean_finite(a.iter().map(|d| d[s]));
    let n = seeds.len();
    let sites: Vec<[f64; 4]> = (0..n)
        .map(|s| {
            [
                draw_mean(&sgm_rows, s),
                draw_mean(&pm_rows, s),
                angle_mean(&sgm_angles, s),
                angle_mean(&pm_angles, s),
            ]
        })
        .collect();
    let (f_name, np_name) = strategies;
    let counts = format!("{} SGM and {} PatchMatch draws", sgm.len(), pm.len());

    // NaN (no planned angle) is never narrower.
    let narrower = sites.iter().filter(|s| s[2] < s[3]).count();
    let h3 = Verdict {
        name: "H3 over draws".into(),
        holds: narrower >= needed(7, n),
        figures: format!(
            "{f_name}'s draw-mean planned angle is narrower with SGM than with PatchMatch on \
             {narrower} of {n} sites (needs {}); means {:.1} and {:.1} deg ({counts})",
            needed(7, n),
            mean_finite(sites.iter().map(|s| s[2])),
            mean_finite(sites.iter().map(|s| s[3])),
        ),
    };

    let ahead = sites.iter().filter(|s| s[0] > 0.0).count();
    let diff = mean(&sites.iter().map(|s| s[0] - s[1]).collect::<Vec<_>>());
    let (lo, hi) = crossed_interval(&sgm_rows, &pm_rows, seed);
    let h4 = Verdict {
        name: "H4 over draws".into(),
        holds: ahead >= needed(7, n) && lo > 0.0,
        figures: format!(
            "with SGM the draw-mean f({f_name}) - f({np_name}) > 0 on {ahead} of {n} sites \
             (needs {}), mean {:+.1} points; PatchMatch's mean {:+.1}; SGM's minus \
             PatchMatch's {diff:+.1} points (95 % bootstrap interval over sites and draws \
             {lo:+.1} .. {hi:+.1}; needs it above 0; {counts})",
            needed(7, n),
            mean(&sites.iter().map(|s| s[0]).collect::<Vec<_>>()),
            mean(&sites.iter().map(|s| s[1]).collect::<Vec<_>>()),
        ),
    };
    Ok(DrawComparison {
        strategies: (f_name.into(), np_name.into()),
        seeds,
        draws: [sgm_rows, pm_rows],
        sites,
        verdicts: vec![h3, h4],
    })
}

/// The 95 % percentile interval of the mean over sites of SGM's
/// draw-mean gap minus PatchMatch's, resampling sites and draws crossed:
/// each resample picks the sites with replacement, then each matcher's
/// draws with replacement, once for all its sites (in that order, from
/// `seed`).
fn crossed_interval(sgm: &[DrawRow], pm: &[DrawRow], seed: u64) -> (f64, f64) {
    let n = sgm[0].gaps.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pick = |k: usize, rng: &mut ChaCha8Rng| -> Vec<usize> {
        (0..k).map(|_| rng.random_range(0..k)).collect()
    };
    let mut stats: Vec<f64> = (0..RESAMPLES)
        .map(|_| {
            let sites = pick(n, &mut rng);
            let (ds, dp) = (pick(sgm.len(), &mut rng), pick(pm.len(), &mut rng));
            let gap = |rows: &[DrawRow], draws: &[usize], s: usize| {
                draws.iter().map(|&d| rows[d].gaps[s]).sum::<f64>() / draws.len() as f64
            };
            sites
                .iter()
                .map(|&s| gap(sgm, &ds, s) - gap(pm, &dp, s))
                .sum::<f64>()
                / n as f64
        })
        .collect();
    stats.sort_by(f64::total_cmp);
    let at = |q: f64| stats[((q * (RESAMPLES - 1) as f64).round() as usize).min(RESAMPLES - 1)];
    (at(0.025), at(0.975))
}

impl DrawComparison {
    /// Markdown: the draws, the per-site table, then H3 and H4.
    pub fn markdown(&self) -> String {
        let (fname, npname) = &self.strategies;
        let mut s = format!(
            "Forest draws compared ({fname} against {npname}; every draw flew the same {} held-out \
             sites):\n\n| matcher | draw | forest | report folders | {fname} ahead of {npname} | mean gap |\n\
             |---|---|---|---|---|---|\n",
            self.seeds.len()
        );
        for (matcher, rows) in ["SGM", "PatchMatch"].iter().zip(&self.draws) {
            for (i, r) in rows.iter().enumerate() {
                let ahead = r.gaps.iter().filter(|&&g| g > 0.0).count();
                let _ = writeln!(
                    s,
                    "| {matcher} | {} | {} | {} | {ahead} of {} | {:+.1} |",
                    i + 1,
                    r.forest,
                    r.folders.join(", "),
                    r.gaps.len(),
                    mean(&r.gaps)
                );
            }
        }
        let _ = write!(
            s,
            "\n| site | SGM draw-mean gap | PatchMatch draw-mean gap | difference | {fname} draw-mean \
             planned angle SGM / PatchMatch (deg) |\n|---|---|---|---|---|\n"
        );
        for (seed, [gs, gp, a_s, a_p]) in self.seeds.iter().zip(&self.sites) {
            let _ = writeln!(
                s,
                "| {seed} | {gs:+.1} | {gp:+.1} | {:+.1} | {a_s:.1} / {a_p:.1} |",
                gs - gp
            );
        }
        s.push('\n');
        for v in &self.verdicts {
            let _ = writeln!(s, "{}", v.markdown());
        }
        s
    }
}
