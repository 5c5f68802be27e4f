//! The report folder of a campaign: `table.md`, `table.csv`, `report.json`,
//! `curves.csv`, `config.toml`, the plans and QGC missions, the PNG plots
//! ([`plot`]), `scene.glb` ([`scene`]) and `report.html` ([`html`]), all
//! written from the campaign's [`results`]. The writers read the results;
//! nothing here is read back by them.

use std::fmt::Write as _;
use std::path::Path;

use vp_mission::{export_qgc, Autopilot, MissionOptions, QgcOptions};
use vp_scene::outdir::OutDir;

use crate::error::{Result, SimError};

pub mod eval_html;
pub mod f_vs_np;
pub mod html;
pub mod outcomes;
pub mod page;
pub mod plot;
pub mod results;
pub mod scene;
mod svg;
pub mod two_matchers;

pub use results::{
    aggregate, CampaignReport, SiteArtifacts, SiteResult, StrategyArtifacts, TableRow,
};

fn io_err(path: &Path, e: std::io::Error) -> SimError {
    SimError::Scene(vp_scene::SceneError::Io {
        path: path.to_path_buf(),
        source: e,
    })
}

fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| io_err(path, e))
}

/// Writes the report folder `out`: `table.md`, `table.csv`,
/// `report.json`, `curves.csv`, `config.toml`, `plans/<strategy>/iter<i>.json`
/// and `.plan` (QGroundControl missions via vp-mission),
/// `plans/<strategy>/iter<i>-acquired/` (what the iteration planned from,
/// see [`crate::campaign::acquired`]), the PNG plots
/// (see [`plot`]), `scene.glb` (see [`scene`]) and
/// `report.html` (see [`html`]), through [`OutDir`]: built beside
/// the folder and swapped in, so a failure leaves no partial report, and
/// only the files of an earlier report are replaced (`out` was checked
/// before the campaign: see [`OutDir::check`]).
pub fn write_report(report: &CampaignReport, out: &OutDir) -> Result<()> {
    out.write(|dir| fill(report, dir))
}

/// The paragraph of `table.md` on the `iter<i>-acquired` folders, with a
/// command that plans one again (None without triplet strategies).
fn acquired_recipe(report: &CampaignReport) -> Option<String> {
    // The example: a strategy with prediction if there is one.
    let acquired_example = report.artifacts.as_ref().and_then(|a| {
        let with = |conf: bool| {
            a.strategies.iter().find(|s| {
                s.acquired
                    .first()
                    .is_some_and(|m| m.confidence.is_empty() != conf)
            })
        };
        with(true).or_else(|| with(false)).map(|s| {
            let predicted = !s.acquired[0].confidence.is_empty();
            let flag = if predicted {
                " --confidence-dir $A/confidence"
            } else {
                ""
            };
            (s.name.clone(), flag)
        })
    });
    acquired_example.map(|(name, conf_flag)| {
        format!(
            "\n`plans/<strategy>/iter<i>.json` and `.plan`: each iteration's plan (vpctl, \
             QGroundControl). `plans/<strategy>/iter<i>-acquired/`: what that iteration planned \
             from: `sparse/` (the COLMAP model of the images acquired so far, with \
             `frame.json`), `confidence/` (their predicted `.vpconf`, strategies with \
             prediction), `mesh.ply` (the planning mesh), `roi.json`. To plan an iteration \
             again by hand (comparable, not identical: the campaign's planner also had the \
             fused dense points as free-space observations):\n\n```sh\n\
             A=plans/{name}/iter1-acquired\n\
             vpctl plan --mesh $A/mesh.ply --colmap $A/sparse{conf_flag} --roi $A/roi.json \
             --config config.toml --out again.json\n```\n"
        )
    })
}

fn fill(report: &CampaignReport, dir: &Path) -> Result<()> {
    let mut md = String::from("# vpctl campaign report\n\n");
    let _ = writeln!(
        md,
        "Held-out sites (never trained on): {:?}. {}, percent.\n",
        report.config.held_out_seeds,
        report.table_caption()
    );
    md.push_str(&report.table_markdown());
    let _ = writeln!(md, "\n{}", report.forest_line());
    if let Some(p) = f_vs_np::paragraph(report) {
        md.push_str("\n## F against NP on this run\n\n");
        md.push_str(&p);
        md.push('\n');
    }
    if let Some(o) = outcomes::markdown(report) {
        md.push_str("\n## The outcome per triplet\n\n");
        md.push_str(&o);
    }
    md.push_str("\n## Learned confidence against the MVS's measured success\n\n```\n");
    md.push_str(&report.curves_summary());
    md.push_str("```\n");
    if let Some(t) = &report.training {
        md.push_str("\n## Label quality (labelgen against the renderer's truth)\n\n");
        md.push_str(&t.label_quality.markdown());
        md.push_str(
            "\nPer true triangulation angle (correct % / labelled % of surface; no angle: not \
             seen by all three views of the triplet; counts in `label_quality.csv`):\n\n",
        );
        md.push_str(&t.label_quality.angle_markdown());
        write(&dir.join("label_quality.csv"), &t.label_quality.csv())?;
    }
    md.push_str("\nPlots: `confidence_<material>.png` (learned: blue, measured on the flown triplets: red, on the random triplets no planner chose: green, x: angle 0-45 deg, y: 0-1), ");
    md.push_str("`plan_<strategy>.png` (top view of the plan), `fulfillment_<strategy>.png` (per-face f, red 0 to green 1), `depth_error_rock_<strategy>.png` (Fig. 6: share of rock pixels per depth-error bin; green: the |error| 68.3 % of them stay within, red: the median predicted 1 sigma).\n");
    md.push_str("\n`triplets.csv`: every flown triplet (strategy, site, iteration, triplet, planned angle, ROI pixels, with a depth, within the 24 cm rule, their shares, success). `depth_error_rock.csv`: Fig. 6's histograms per flight.\n");
    md.push_str("\n`report.html`: this report as one self-contained page with its plots. `scene.glb`: the site in 3D (mesh, initial flight and planned cameras as frusta, flight paths) for any glTF viewer.\n");
    if let Some(recipe) = acquired_recipe(report) {
        md.push_str(&recipe);
    }
    write(&dir.join("table.md"), &md)?;
    write(&dir.join("table.csv"), &report.table_csv())?;
    let json = serde_json::to_string_pretty(report)
        .map_err(|e| SimError::Campaign(format!("report to JSON: {e}")))?;
    write(&dir.join("report.json"), &json)?;
    write(&dir.join("config.toml"), &report.config.to_toml()?)?;
    let mut csv = String::from(
        "material,angle_deg,learned,measured,measured_pixels,measured_random,measured_random_pixels\n",
    );
    let share = |m: f64| {
        if m.is_finite() {
            format!("{m:.4}")
        } else {
            String::new()
        }
    };
    for c in &report.curves {
        for (b, a) in c.angle_deg.iter().enumerate() {
            let _ = writeln!(
                csv,
                "{},{a},{:.4},{},{},{},{}",
                c.material,
                c.learned[b],
                share(c.measured[b]),
                c.measured_pixels[b],
                share(c.measured_random[b]),
                c.measured_random_pixels[b]
            );
        }
    }
    write(&dir.join("curves.csv"), &csv)?;
    plot::write_curve_plots(&report.curves, dir)?;
    outcomes::write_files(report, dir)?;
    if let Some(a) = &report.artifacts {
        let plans = dir.join("plans");
        for s in &a.strategies {
            if s.plans.is_empty() {
                continue;
            }
            let sd = plans.join(&s.name);
            std::fs::create_dir_all(&sd).map_err(|e| io_err(&sd, e))?;
            for (i, p) in s.plans.iter().enumerate() {
                let base = sd.join(format!("iter{}", i + 1));
                p.save(&base.with_extension("json"), true)?;
                let qgc = export_qgc(
                    p,
                    &MissionOptions::for_autopilot(Autopilot::Px4),
                    &QgcOptions::default(),
                )?;
                write(&base.with_extension("plan"), &qgc)?;
            }
            for (i, a) in s.acquired.iter().enumerate() {
                a.write(&sd.join(format!("iter{}-acquired", i + 1)))?;
            }
        }
        plot::write_site_plots(a, dir)?;
    }
    scene::write_scene_glb(report, dir)?;
    // Last: the page embeds the PNG views written above.
    html::write_html(report, dir)
}
