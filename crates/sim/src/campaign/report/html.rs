//! `report.html`: the campaign report as one self-contained page to open
//! in a browser — Table 1, the planner's per-iteration curves and the
//! learned-vs-measured confidence curves as inline SVG, and the plan and
//! fulfillment views as PNG data URIs. Inline CSS, no script, no network:
//! the page can be mailed or archived as one file. No timestamp: the same
//! report gives the same bytes.

use std::fmt::Write as _;
use std::path::Path;

use super::f_vs_np;
use super::page::{cell_table, figure_row, Figure, STYLE};
use super::results::CampaignReport;
use super::svg::{escape, LinePlot, Series};
use crate::error::Result;

/// Colours of the strategies' lines, in table order.
const PALETTE: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

/// The report page. `figures`: plan views to embed; `fig6`: the depth
/// error plots of the rock per triplet strategy (see [`write_html`]).
pub fn report_html(report: &CampaignReport, figures: &[Figure], fig6: &[Figure]) -> String {
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">");
    // An empty icon: the browser asks for no /favicon.ico.
    h.push_str("<link rel=\"icon\" href=\"data:,\">");
    let _ = write!(
        h,
        "<title>vpctl campaign report</title><style>{STYLE}</style></head><body>\n<h1>vpctl campaign report</h1>\n"
    );
    let _ = writeln!(
        h,
        "<p>Held-out sites (never trained on): {}. {}, percent.</p>",
        escape(&format!("{:?}", report.config.held_out_seeds)),
        escape(report.table_caption())
    );
    table(&mut h, report);
    let _ = writeln!(h, "<p id=\"forest\">{}</p>", escape(&report.forest_line()));
    glossary(&mut h);
    if let Some(p) = f_vs_np::paragraph(report) {
        let _ = writeln!(
            h,
            "<h2>F against NP on this run</h2>\n<p id=\"f-vs-np\">{}</p>",
            escape(&p)
        );
    }
    planning_curves(&mut h, report);
    confidence_curves(&mut h, report);
    h.push_str(&super::outcomes::html(report, fig6));
    if !figures.is_empty() {
        let seed = report.artifacts.as_ref().map_or(0, |a| a.seed);
        let _ = writeln!(h, "<h2>Plan views (site {seed})</h2>");
        figure_row(&mut h, figures);
    }
    if let Some(t) = &report.training {
        h.push_str("<h2>Label quality (labelgen against the renderer's truth)</h2>\n");
        let (header, rows) = t.label_quality.cells();
        cell_table(
            &mut h,
            "label-quality",
            None,
            &header,
            rows.iter().map(<[String; 5]>::as_slice),
        );
        let (header, rows) = t.label_quality.angle_cells();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        cell_table(
            &mut h,
            "label-quality-angle",
            Some(
                "Per true triangulation angle: correct % / labelled % of surface (no angle: \
                 not seen by all three views); counts in label_quality.csv",
            ),
            &header,
            rows.iter().map(Vec::as_slice),
        );
    }
    h.push_str(
        "<h2>Files beside this page</h2>\n<p><code>table.csv</code>, <code>report.json</code>, \
         <code>config.toml</code>, <code>curves.csv</code>, <code>triplets.csv</code> (every flown \
         triplet's planned angle and outcome), <code>depth_error_rock.csv</code> (Fig. 6's \
         histograms), <code>plans/&lt;strategy&gt;/iter&lt;i&gt;.json</code> \
         and <code>.plan</code> (QGroundControl), the PNG plots, and <code>scene.glb</code>: the site's \
         mesh with every plan's cameras as frusta and its flight path, for any glTF viewer.</p>\n</body></html>\n",
    );
    h
}

fn table(h: &mut String, report: &CampaignReport) {
    let (header, rows) = report.table_cells();
    cell_table(
        h,
        "table1",
        Some("Table 1"),
        &header,
        rows.iter().map(Vec::as_slice),
    );
}

/// The table's columns in the paper's terms (Mostegel et al. 2016, M1;
/// docs/design.md): what a reader needs before the numbers mean anything.
const GLOSSARY: [(&str, &str); 4] = [
    (
        "cov",
        "coverage: the share of the ROI's faces on the true mesh measured by at least c = 3 \
         cameras of reconstructions that worked, a camera measuring a face when its MVS depth \
         there lies within 24 cm of the face.",
    ),
    (
        "f_res",
        "resolution fulfillment, min(1, r / r_d): the pixels per square metre of the coarsest camera \
         of the best triplet seeing the face, against the desired ground sampling distance \
         (r_d = 1 / gsd_d²); mean over the ROI's faces, 0 where uncovered.",
    ),
    (
        "f_unc",
        "uncertainty fulfillment, min(1, a_d / √u): u the largest eigenvalue of the covariance of the \
         face's centre triangulated by that triplet from 1 px image noise, against the desired \
         accuracy a_d; mean over the ROI's faces, 0 where uncovered.",
    ),
    (
        "f",
        "quality fulfillment, (½ f_res + ½ f_unc) · f_cov per face, mean over the ROI's faces: \
         100 % means every face is covered at the desired resolution and accuracy. While planning, \
         the paper also multiplies by f_conf, the predicted MVS confidence; here the MVS has run, \
         so only faces it actually reconstructed count.",
    ),
];

fn glossary(h: &mut String) {
    h.push_str("<dl id=\"glossary\">\n");
    for (term, def) in GLOSSARY {
        let _ = writeln!(h, "<dt><code>{term}</code></dt><dd>{}</dd>", escape(def));
    }
    h.push_str("</dl>\n");
}

/// Per strategy, the planner's own estimate after each planned triplet
/// (mean f(t) and coverage of its sampled triangles on the planning mesh),
/// iterations one after the other: a jump between iterations is the new
/// planning mesh and sample.
fn planning_curves(h: &mut String, report: &CampaignReport) {
    let Some(a) = &report.artifacts else {
        return;
    };
    let mut f_series = Vec::new();
    let mut cov_series = Vec::new();
    let mut steps = 0usize;
    for (i, s) in a.strategies.iter().enumerate() {
        let (mut f, mut cov) = (Vec::new(), Vec::new());
        let mut x = 0usize;
        for plan in &s.plans {
            let its = &plan.statistics.iterations;
            if let Some(first) = its.first() {
                f.push((x as f64, first.f_before));
                cov.push((x as f64, f64::NAN));
            }
            for it in its {
                x += 1;
                f.push((x as f64, it.f_after));
                cov.push((x as f64, it.coverage));
            }
        }
        if f.is_empty() {
            continue;
        }
        steps = steps.max(x);
        let colour = PALETTE[i % PALETTE.len()];
        f_series.push(Series {
            label: s.name.clone(),
            colour,
            dashed: false,
            points: f,
        });
        cov_series.push(Series {
            label: s.name.clone(),
            colour,
            dashed: false,
            points: cov,
        });
    }
    if f_series.is_empty() {
        return;
    }
    h.push_str(
        "<h2>Planning iterations</h2>\n<p>The planner's own estimate on its sampled triangles of \
         the planning mesh, after each planned triplet (site ",
    );
    let _ = write!(
        h,
        "{}; a jump between iterations is the new mesh and sample).</p>\n<div class=\"plots\">",
        a.seed
    );
    let ticks: Vec<f64> = (0..=steps).map(|k| k as f64).collect();
    for (title, y_label, series) in [
        ("Planned mean f(t)", "mean f(t)", f_series),
        ("Planned coverage", "share covered", cov_series),
    ] {
        let plot = LinePlot {
            title,
            x_label: "planned triplets",
            y_label,
            x_range: (0.0, steps.max(1) as f64),
            y_range: (0.0, 1.0),
            x_ticks: ticks.clone(),
            y_ticks: vec![0.0, 0.25, 0.5, 0.75, 1.0],
            series,
        };
        h.push_str(&plot.render());
    }
    h.push_str("</div>\n");
}

/// Per material, the forest's learned confidence (solid) against vp-mvs's
/// measured success (dashed) over the triangulation angle: on the flown
/// triplets (red) and on the fixed random triplets no planner chose (green).
fn confidence_curves(h: &mut String, report: &CampaignReport) {
    if report.curves.is_empty() {
        return;
    }
    h.push_str(
        "<h2>Learned confidence against the MVS's measured success</h2>\n<div class=\"plots\">",
    );
    for c in &report.curves {
        let pts = |v: &[f64]| c.angle_deg.iter().copied().zip(v.iter().copied()).collect();
        let title = format!(
            "{} (spearman {:+.2} flown, {:+.2} random)",
            c.material, c.spearman, c.spearman_random
        );
        let plot = LinePlot {
            title: &title,
            x_label: "triangulation angle (deg)",
            y_label: "success",
            x_range: (0.0, 45.0),
            y_range: (0.0, 1.0),
            x_ticks: (0..=9).map(|k| f64::from(k) * 5.0).collect(),
            y_ticks: vec![0.0, 0.5, 1.0],
            series: vec![
                Series {
                    label: "learned".into(),
                    colour: "#2846dc",
                    dashed: false,
                    points: pts(&c.learned),
                },
                Series {
                    label: "measured, flown".into(),
                    colour: "#dc2828",
                    dashed: true,
                    points: pts(&c.measured),
                },
                Series {
                    label: "measured, random set".into(),
                    colour: "#1e963c",
                    dashed: true,
                    points: pts(&c.measured_random),
                },
            ],
        };
        h.push_str(&plot.render());
    }
    let _ = writeln!(h, "</div>\n<pre>{}</pre>", escape(&report.curves_summary()));
}

/// Writes `report.html` into the report directory `dir`, embedding the plan
/// and fulfillment PNGs already written there (by [`super::plot`]).
pub fn write_html(report: &CampaignReport, dir: &Path) -> Result<()> {
    let mut figures = Vec::new();
    if let Some(a) = &report.artifacts {
        for s in &a.strategies {
            let stem = super::plot::file_stem(&s.name);
            for (file, what) in [
                (format!("plan_{stem}.png"), "plan (top view)"),
                (format!("fulfillment_{stem}.png"), "fulfillment f per face"),
            ] {
                let p = dir.join(&file);
                if p.is_file() {
                    figures.push(Figure {
                        caption: format!("{}: {what} ({file})", s.name),
                        png: vp_scene::fsio::read_file(&p)?,
                    });
                }
            }
        }
    }
    let mut fig6 = Vec::new();
    for s in super::outcomes::by_strategy(report) {
        let file = format!("depth_error_rock_{}.png", super::plot::file_stem(&s.name));
        let p = dir.join(&file);
        if p.is_file() {
            fig6.push(Figure {
                caption: format!("{}: depth error on the rock ({file})", s.name),
                png: vp_scene::fsio::read_file(&p)?,
            });
        }
    }
    let path = dir.join("report.html");
    let page = report_html(report, &figures, &fig6);
    vp_scene::fsio::write_file_atomic(&path, page.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::report::TableRow;
    use crate::campaign::{CampaignConfig, ConfidenceCurve};

    fn report() -> CampaignReport {
        let row = |name: &str| TableRow {
            strategy: name.into(),
            coverage_mean: 51.0,
            coverage_std: 0.0,
            f_res_mean: 40.0,
            f_res_std: 0.0,
            f_unc_mean: 30.0,
            f_unc_std: 0.0,
            f_mean: 20.0,
            f_std: 0.0,
            triplet_success_mean: f64::NAN,
            triplet_success_std: f64::NAN,
            n_images_mean: 19.0,
            n_images_std: 0.0,
            rock_coverage_mean: 60.0,
            rock_coverage_std: 0.0,
            min_clearance_m: f64::INFINITY,
            safety_violations: 0,
        };
        CampaignReport {
            rows: vec![row("Init"), row("G+F<1>")],
            sites: Vec::new(),
            curves: vec![ConfidenceCurve {
                material: "rock".into(),
                angle_deg: vec![2.5, 7.5],
                learned: vec![0.5, 0.7],
                measured: vec![f64::NAN, 0.6],
                measured_pixels: vec![0, 10],
                measured_random: vec![0.4, f64::NAN],
                measured_random_pixels: vec![5, 0],
                samples: 3,
                spearman: 1.0,
                spearman_random: 0.0,
            }],
            material_ranking: Vec::new(),
            material_ranking_random: Vec::new(),
            training: None,
            forest_fingerprint: "0123456789abcdef".into(),
            config: CampaignConfig::quick(),
            artifacts: None,
        }
    }

    #[test]
    fn the_page_holds_the_table_and_plots_and_loads_nothing() {
        let r = report();
        let figure = Figure {
            caption: "plan".into(),
            png: vec![0x89, b'P', b'N', b'G'],
        };
        let html = report_html(&r, std::slice::from_ref(&figure), &[]);
        assert!(html.contains("<td>Init</td><td>51.0</td>"), "{html}");
        assert!(html.contains("<td>G+F&lt;1&gt;</td>"), "names are escaped");
        assert!(
            html.contains("<svg") && html.contains("rock (spearman +1.00 flown, +0.00 random)")
        );
        assert!(html.contains("src=\"data:image/png;base64,iVBORw==\""));
        // Which forest flew: its fingerprint, as the file's checksum.
        assert!(html.contains(
            "<p id=\"forest\">The F strategies flew the forest with fingerprint 0123456789abcdef"
        ));
        // Self-contained: nothing to fetch (the SVG namespace is a name, not a load).
        let no_ns = html.replace("xmlns=\"http://www.w3.org/2000/svg\"", "");
        assert!(!no_ns.contains("http") && !no_ns.contains("<script"));
        assert_eq!(
            html,
            report_html(&r, &[figure], &[]),
            "same report, same bytes"
        );
    }

    #[test]
    fn the_page_explains_its_columns_and_its_own_f_against_np_and_tabulates_label_quality() {
        let mut r = report();
        let mut f = r.rows[0].clone();
        f.strategy = "F1x2".into();
        f.f_mean = 37.8;
        f.triplet_success_mean = 60.0;
        let mut np = f.clone();
        np.strategy = "NP1x2".into();
        np.f_mean = 43.4;
        np.triplet_success_mean = 50.0;
        r.rows.extend([f, np]);
        let mut training = crate::campaign::TrainingStats::default();
        training.label_quality.materials = vec![(
            "rock".into(),
            crate::campaign::label_quality::MaterialCounts {
                surface: 100,
                labelled: 40,
                correct: 38,
                positive: 30,
                correct_positive: 29,
            },
        )];
        r.training = Some(training);
        let html = report_html(&r, &[], &[]);
        for term in [
            "<dt><code>cov</code></dt>",
            "<dt><code>f_res</code></dt>",
            "<dt><code>f_unc</code></dt>",
            "<dt><code>f</code></dt>",
        ] {
            assert!(html.contains(term), "{term} missing from the glossary");
        }
        // The paragraph is made from this run's numbers and points to the findings.
        assert!(
            html.contains("F1x2 reached f 37.8 % against NP1x2&#39;s 43.4 %"),
            "{html}"
        );
        assert!(
            html.contains("NP ahead by 5.6 points on one site"),
            "{html}"
        );
        assert!(html.contains("docs/campaign-findings.md"), "{html}");
        // Label quality is a table, not preformatted Markdown.
        assert!(html.contains("<table id=\"label-quality\">"), "{html}");
        assert!(
            html.contains(
                "<tr><td>rock</td><td>95.0</td><td>96.7</td><td>40.0</td><td>40</td></tr>"
            ),
            "{html}"
        );
        assert!(!html.contains("| material |"), "{html}");
    }
}
