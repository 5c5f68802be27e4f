//! What the run's own F-against-NP result says, in words made from its
//! numbers: one line for the terminal, one paragraph for `report.html` and
//! `table.md`. F plans with the forest's predicted MVS confidence; NP
//! plans with confidence 1 everywhere (the paper's variant without
//! prediction). The paper's claim is that F reaches a higher f; whether a
//! run shows it depends on the sites, the forest and the spread between
//! sites, so the words follow the numbers and point to the full findings.

use std::fmt::Write as _;

use super::results::{CampaignReport, TableRow};

/// Where the campaigns that test the paper's claim are written up.
pub const FINDINGS: &str = "docs/campaign-findings.md in the vpctl repository";

/// One F strategy and its NP twin (same iterations and triplets).
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// The F row's name, e.g. `F1x2`.
    pub f_name: String,
    /// The NP row's name, e.g. `NP1x2`.
    pub np_name: String,
    /// Mean f, percent, of F and of NP.
    pub f: (f64, f64),
    /// Standard deviations over the sites of F's and NP's f.
    pub f_std: (f64, f64),
    /// Triplet success, percent, of F and of NP.
    pub success: (f64, f64),
    /// Held-out sites the means are over.
    pub sites: usize,
}

/// Every F row with its NP twin, in table order (`G+F...` rows, which add a
/// grid, have no NP twin and are left out).
pub fn comparisons(report: &CampaignReport) -> Vec<Comparison> {
    let rows: &[TableRow] = &report.rows;
    rows.iter()
        .filter_map(|f| {
            let rest = f.strategy.strip_prefix('F')?;
            let np = rows.iter().find(|r| r.strategy == format!("NP{rest}"))?;
            Some(Comparison {
                f_name: f.strategy.clone(),
                np_name: np.strategy.clone(),
                f: (f.f_mean, np.f_mean),
                f_std: (f.f_std, np.f_std),
                success: (f.triplet_success_mean, np.triplet_success_mean),
                sites: report.config.held_out_seeds.len(),
            })
        })
        .filter(|c| c.f.0.is_finite() && c.f.1.is_finite())
        .collect()
}

impl Comparison {
    /// F's f minus NP's, percentage points.
    pub fn difference(&self) -> f64 {
        self.f.0 - self.f.1
    }

    /// The standard error of the difference of the means over the sites
    /// (`None` for one site: no spread to judge by).
    pub fn standard_error(&self) -> Option<f64> {
        (self.sites > 1)
            .then(|| ((self.f_std.0.powi(2) + self.f_std.1.powi(2)) / self.sites as f64).sqrt())
    }

    /// What the difference says on this run.
    pub fn reading(&self) -> String {
        let d = self.difference();
        let who = if d >= 0.0 { "F ahead" } else { "NP ahead" };
        match self.standard_error() {
            None => format!(
                "{who} by {:.1} points on one site: one site has no spread to judge by, \
                 so this alone neither confirms nor refutes the paper",
                d.abs()
            ),
            Some(se) if d.abs() <= 2.0 * se => format!(
                "a difference of {d:+.1} points, within twice its standard error over {} sites \
                 ({se:.1}): no difference shown",
                self.sites
            ),
            Some(se) => format!(
                "{who} by {:.1} points, more than twice its standard error over {} sites ({se:.1})",
                d.abs(),
                self.sites
            ),
        }
    }

    /// What triplet success adds: whether the prediction picked triplets
    /// the MVS could match.
    pub fn success_reading(&self) -> &'static str {
        let (d, better) = (self.difference(), self.success.0 > self.success.1);
        match (d >= 0.0, better) {
            (true, true) => "so the prediction picked triplets the MVS could match, as the paper intends",
            (true, false) => "so F's higher f came from where its triplets looked, not from more of them succeeding",
            (false, true) => {
                "so the prediction steered the planner to triplets that succeed more often but cover less"
            }
            (false, false) => "so the prediction did not pick triplets the MVS could match better on this run",
        }
    }

    /// The printed line.
    pub fn line(&self) -> String {
        format!(
            "F vs NP: {} f {:.1} % vs {} {:.1} %: {}. Full findings: {FINDINGS}.",
            self.f_name,
            self.f.0,
            self.np_name,
            self.f.1,
            self.reading()
        )
    }
}

/// The report's paragraph: what F and NP are, each comparison with its
/// reading and triplet success, and where the full findings are. `None`
/// when the run had no F/NP pair.
pub fn paragraph(report: &CampaignReport) -> Option<String> {
    let cs = comparisons(report);
    if cs.is_empty() {
        return None;
    }
    let mut p = String::from(
        "F plans with the forest's predicted MVS confidence, NP with confidence 1 everywhere \
         (the paper's variant without prediction); the paper reports F reaching the higher f. \
         On this run: ",
    );
    let parts: Vec<String> = cs
        .iter()
        .map(|c| {
            format!(
                "{} reached f {:.1} % against {}'s {:.1} % ({}); {:.1} % of {}'s flown triplets \
                 produced 3D output against {:.1} % of {}'s, {}",
                c.f_name,
                c.f.0,
                c.np_name,
                c.f.1,
                c.reading(),
                c.success.0,
                c.f_name,
                c.success.1,
                c.np_name,
                c.success_reading()
            )
        })
        .collect();
    p.push_str(&parts.join("; "));
    let _ = write!(
        p,
        ". The campaigns over more sites, and why F and NP differ there, are in {FINDINGS}."
    );
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(f: (f64, f64), std: (f64, f64), sites: usize) -> Comparison {
        Comparison {
            f_name: "F1x2".into(),
            np_name: "NP1x2".into(),
            f,
            f_std: std,
            success: (50.0, 40.0),
            sites,
        }
    }

    #[test]
    fn the_reading_follows_the_numbers_and_the_spread() {
        let one = c((37.8, 43.4), (0.0, 0.0), 1);
        assert!(
            one.reading()
                .starts_with("NP ahead by 5.6 points on one site"),
            "{}",
            one.reading()
        );
        assert!(
            one.line().contains("F1x2 f 37.8 % vs NP1x2 43.4 %") && one.line().contains(FINDINGS)
        );
        // Five sites, spread 6 each: standard error 3.8, a 5.6 difference is within 2 of them.
        let noisy = c((37.8, 43.4), (6.0, 6.0), 5);
        assert!(
            noisy.reading().contains("no difference shown"),
            "{}",
            noisy.reading()
        );
        let clear = c((50.0, 40.0), (1.0, 1.0), 5);
        assert!(
            clear
                .reading()
                .starts_with("F ahead by 10.0 points, more than twice"),
            "{}",
            clear.reading()
        );
        assert!(clear.success_reading().contains("as the paper intends"));
    }
}
