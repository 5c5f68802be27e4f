//! The outcome per triplet in the report (issue 34, item 4), pooled over
//! the held-out sites per triplet strategy: the planned-angle histogram (F
//! beside NP: did prediction change the plan?), the distribution of each
//! triplet's share of ROI pixels within the 24 cm rule and the success at
//! several thresholds (Table 1's success rate saturates), and the paper's
//! Fig. 6, the depth error on the rock against its 1 sigma bound. Files:
//! `triplets.csv`, `depth_error_rock.csv`, `depth_error_rock_<strategy>.png`.

use std::fmt::Write as _;
use std::path::Path;

use image::Rgb;
use vp_scene::raster::{save_rgb, text_width, RgbImage};

use super::page::{cell_table, figure_row, Figure};
use super::plot::{file_stem, line, put, text, BLACK};
use super::results::CampaignReport;
use super::svg::escape;
use crate::campaign::triplet_outcomes::{
    angle_histogram, five_numbers, success_share, DepthErrorHistogram, TripletOutcome,
    ANGLE_BIN_DEG, ERROR_RANGE_M, N_ERROR_BINS, SUCCESS_THRESHOLDS,
};
use crate::error::Result;

/// One flight's (a baseline's or a triplet strategy's) flown triplets and
/// rock depth errors over the sites.
pub struct StrategyOutcomes<'a> {
    /// Strategy name.
    pub name: String,
    /// Whether it is a triplet strategy (planned triplets; not a baseline).
    pub planned: bool,
    /// Its flown triplets, site by site in flight order.
    pub triplets: Vec<&'a TripletOutcome>,
    /// Its rock pixels' depth errors, merged over the sites.
    pub rock: DepthErrorHistogram,
}

/// The flights of `report` with rock depth errors (baselines, then the
/// triplet strategies) in table order, pooled over sites.
pub fn by_strategy(report: &CampaignReport) -> Vec<StrategyOutcomes<'_>> {
    let mut out: Vec<StrategyOutcomes<'_>> = Vec::new();
    for site in &report.sites {
        for (name, h) in &site.rock_errors {
            let i = out.iter().position(|s| &s.name == name).unwrap_or_else(|| {
                out.push(StrategyOutcomes {
                    name: name.clone(),
                    planned: report.config.strategies.contains(name),
                    triplets: Vec::new(),
                    rock: DepthErrorHistogram::default(),
                });
                out.len() - 1
            });
            out[i].rock.merge(h);
            out[i]
                .triplets
                .extend(site.triplets.iter().filter(|t| &t.strategy == name));
        }
    }
    out
}

/// The triplet strategies of `all`.
fn planned<'a, 'b>(all: &'b [StrategyOutcomes<'a>]) -> Vec<&'b StrategyOutcomes<'a>> {
    all.iter().filter(|s| s.planned).collect()
}

/// The angle histogram spans at least the planner's usual 0-45 deg.
const ANGLE_SPAN_DEG: f64 = 45.0;

/// Bins of the angle histogram: 0-45 deg, or up to the largest planned angle.
fn angle_bins(all: &[StrategyOutcomes<'_>]) -> usize {
    let max = all
        .iter()
        .flat_map(|s| s.triplets.iter().filter_map(|t| t.planned_angle_deg))
        .filter(|a| a.is_finite())
        .fold(0.0f64, f64::max);
    ((max / ANGLE_BIN_DEG).floor() as usize + 1).max((ANGLE_SPAN_DEG / ANGLE_BIN_DEG) as usize)
}

/// A share as percent text ("-" for NaN: nothing to share).
fn pct(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else {
        format!("{:.1}", 100.0 * x)
    }
}

/// The planned-angle histogram: strategy, triplets per 5 deg bin, triplets
/// without a planned angle, triplets flown.
pub fn angle_cells(all: &[StrategyOutcomes<'_>]) -> (Vec<String>, Vec<Vec<String>>) {
    let n = angle_bins(all);
    let mut header = vec!["strategy".to_string()];
    header.extend((0..n).map(|b| {
        let lo = b as f64 * ANGLE_BIN_DEG;
        format!("{lo:.0}-{:.0}", lo + ANGLE_BIN_DEG)
    }));
    header.extend(["no angle".to_string(), "triplets".to_string()]);
    let rows = planned(all)
        .into_iter()
        .map(|s| {
            let h = angle_histogram(s.triplets.iter().filter_map(|t| t.planned_angle_deg), n);
            let mut r = vec![s.name.clone()];
            r.extend(h.iter().map(u64::to_string));
            let none = s.triplets.iter().filter(|t| t.planned_angle_deg.is_none());
            r.push(none.count().to_string());
            r.push(s.triplets.len().to_string());
            r
        })
        .collect();
    (header, rows)
}

/// Per pair of strategies of the same shape with and without prediction
/// (`F5x4`, `NP5x4`): how many triplets the angle histograms differ by
/// (half the summed absolute difference of their bin counts).
pub fn f_vs_np_angles(all: &[StrategyOutcomes<'_>]) -> Vec<String> {
    let n = angle_bins(all);
    let hist = |s: &StrategyOutcomes<'_>| {
        angle_histogram(s.triplets.iter().filter_map(|t| t.planned_angle_deg), n)
    };
    let mut lines = Vec::new();
    let all = planned(all);
    for f in &all {
        let Some(shape) = f.name.strip_prefix('F') else {
            continue;
        };
        let Some(np) = all.iter().find(|s| s.name == format!("NP{shape}")) else {
            continue;
        };
        let (a, b) = (hist(f), hist(np));
        let diff: u64 = a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).sum();
        lines.push(if diff == 0 {
            format!(
                "{} and {}: the same planned-angle histogram; prediction did not change the angles planned.",
                f.name, np.name
            )
        } else {
            format!(
                "{} and {}: the planned-angle histograms differ by {} triplets ({} flew {}, {} flew {}).",
                f.name,
                np.name,
                diff.div_ceil(2),
                f.name,
                f.triplets.len(),
                np.name,
                np.triplets.len()
            )
        });
    }
    lines
}

/// Per strategy: triplets, the five-number summary of their share of ROI
/// pixels within the 24 cm rule, and success at [`SUCCESS_THRESHOLDS`],
/// all in percent.
pub fn share_cells(all: &[StrategyOutcomes<'_>]) -> (Vec<String>, Vec<Vec<String>>) {
    let mut header: Vec<String> = [
        "strategy", "triplets", "min", "25 %", "median", "75 %", "max",
    ]
    .map(String::from)
    .to_vec();
    header.extend(SUCCESS_THRESHOLDS.iter().map(|&t| {
        if t <= 0.0 {
            "success > 0 px".to_string()
        } else {
            format!("success ≥ {:.0} %", 100.0 * t)
        }
    }));
    let rows = planned(all)
        .into_iter()
        .map(|s| {
            let shares: Vec<f64> = s.triplets.iter().map(|t| t.within_share()).collect();
            let mut r = vec![s.name.clone(), s.triplets.len().to_string()];
            match five_numbers(&shares) {
                Some(q) => r.extend(q.iter().map(|&x| pct(x))),
                None => r.extend(std::iter::repeat_n("-".to_string(), 5)),
            }
            let ts = s.triplets.iter().copied();
            r.extend(
                SUCCESS_THRESHOLDS
                    .iter()
                    .map(|&t| pct(success_share(ts.clone(), t))),
            );
            r
        })
        .collect();
    (header, rows)
}

/// Fig. 6 in figures: rock pixels with a depth, the paper's bound (the
/// |error| 68.3 % of them stay within), the pixels with a predicted 1
/// sigma, its median, the share within it, and the share within ±0.5 m.
pub fn rock_cells(all: &[StrategyOutcomes<'_>]) -> (Vec<String>, Vec<Vec<String>>) {
    let header = [
        "strategy",
        "rock px with depth",
        "68.3 % within (mm)",
        "with predicted sigma",
        "median predicted 1 sigma (mm)",
        "within predicted 1 sigma %",
        "within ±0.5 m %",
    ]
    .map(String::from)
    .to_vec();
    let rows = all
        .iter()
        .map(|s| {
            let h = &s.rock;
            let mm = |m: Option<f64>| match m {
                None => "-".to_string(),
                Some(m) if m.is_infinite() => "> 2000".to_string(),
                Some(m) => format!("{:.1}", 1000.0 * m),
            };
            let inside = h.counts[1..=N_ERROR_BINS].iter().sum::<u64>();
            let inside = if h.pixels == 0 {
                f64::NAN
            } else {
                inside as f64 / h.pixels as f64
            };
            vec![
                s.name.clone(),
                h.pixels.to_string(),
                mm(h.measured_bound_m()),
                h.with_sigma.to_string(),
                mm(h.median_sigma_m()),
                pct(h.within_sigma_share()),
                pct(inside),
            ]
        })
        .collect();
    (header, rows)
}

fn markdown_table(md: &mut String, (header, rows): (Vec<String>, Vec<Vec<String>>)) {
    let _ = writeln!(md, "| {} |", header.join(" | "));
    let _ = writeln!(md, "|{}", "---|".repeat(header.len()));
    for r in rows {
        let _ = writeln!(md, "| {} |", r.join(" | "));
    }
}

const ANGLE_NOTE: &str = "Planned triangulation angle (the angle bin centre each flown triplet was planned for), triplets per 5 deg bin over the held-out sites:";
const SHARE_NOTE: &str = "Each flown triplet's share of its ROI pixels within the 24 cm rule (percent; min, quartiles, max over the triplets), and the share of triplets (percent) with more than 0 pixels, or at least 1, 10 or 25 % of them, within it. Every triplet in `triplets.csv`.";
const ROCK_NOTE: &str = "The paper's Fig. 6: the signed depth error (reconstructed minus true depth along the true camera's axis) of the rock pixels in the ROI that have a depth, per flight (the Grid's and the initial flight's reference images, each strategy's flown triplets), with the paper's 1 sigma bound (the |error| 68.3 % of the pixels stay within) and the first-order 1 sigma predicted per pixel (1 px image noise through the cameras that see the point: all three of a triplet, a Grid reference and its sources that see it; a pixel no other camera sees has none). Histograms in 2 cm bins over ±0.5 m in `depth_error_rock.csv` and `depth_error_rock_<strategy>.png`.";

/// The report's section in Markdown (None without triplet strategies).
pub fn markdown(report: &CampaignReport) -> Option<String> {
    let all = by_strategy(report);
    if planned(&all).is_empty() {
        return None;
    }
    let mut md = format!("{ANGLE_NOTE}\n\n");
    markdown_table(&mut md, angle_cells(&all));
    for l in f_vs_np_angles(&all) {
        let _ = write!(md, "\n{l}\n");
    }
    let _ = write!(md, "\n{SHARE_NOTE}\n\n");
    markdown_table(&mut md, share_cells(&all));
    let _ = write!(md, "\n{ROCK_NOTE}\n\n");
    markdown_table(&mut md, rock_cells(&all));
    Some(md)
}

/// The report's section in HTML with the Fig. 6 plots `figures` (empty
/// without triplet strategies).
pub fn html(report: &CampaignReport, figures: &[Figure]) -> String {
    let all = by_strategy(report);
    if planned(&all).is_empty() {
        return String::new();
    }
    let mut h = String::from("<h2>The outcome per triplet</h2>\n");
    table(&mut h, "triplet-angles", ANGLE_NOTE, angle_cells(&all));
    for l in f_vs_np_angles(&all) {
        let _ = writeln!(h, "<p>{}</p>", escape(&l));
    }
    table(&mut h, "triplet-shares", SHARE_NOTE, share_cells(&all));
    table(&mut h, "depth-error-rock", ROCK_NOTE, rock_cells(&all));
    figure_row(&mut h, figures);
    h
}

/// A note and its table, in HTML.
fn table(h: &mut String, id: &str, note: &str, (header, rows): (Vec<String>, Vec<Vec<String>>)) {
    let _ = writeln!(h, "<p>{}</p>", escape(note));
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    cell_table(h, id, None, &header, rows.iter().map(Vec::as_slice));
}

/// A number as CSV text (empty for NaN, `inf` / `-inf` for infinities).
fn csv_num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.4}")
    } else if x.is_nan() {
        String::new()
    } else if x > 0.0 {
        "inf".into()
    } else {
        "-inf".into()
    }
}

/// `triplets.csv`: one row per flown triplet, strategies in table order,
/// then sites, then flight order.
pub fn triplets_csv(all: &[StrategyOutcomes<'_>]) -> String {
    let mut t = String::from(
        "strategy,site,iteration,triplet,planned_angle_deg,roi_pixels,depth_pixels,within_pixels,depth_share,within_share,success\n",
    );
    for s in all {
        for o in &s.triplets {
            let _ = writeln!(
                t,
                "{},{},{},{},{},{},{},{},{:.4},{:.4},{}",
                o.strategy,
                o.site,
                o.iteration,
                o.triplet,
                o.planned_angle_deg
                    .map_or(String::new(), |a| format!("{a:.2}")),
                o.stats.pixels,
                o.stats.output,
                o.stats.measured,
                o.depth_share(),
                o.within_share(),
                o.success
            );
        }
    }
    t
}

/// `depth_error_rock.csv`: per flight, one row per error bin (the first
/// and last open-ended), with the flight's 1 sigma figures.
pub fn depth_error_csv(all: &[StrategyOutcomes<'_>]) -> String {
    let mut t = String::from(
        "strategy,bin,error_lo_m,error_hi_m,pixels,share,strategy_pixels,bound_683_m,with_sigma,within_sigma,median_sigma_m\n",
    );
    for s in all {
        let h = &s.rock;
        for (b, &c) in h.counts.iter().enumerate() {
            let (lo, hi) = DepthErrorHistogram::bin_range(b);
            let share = if h.pixels == 0 {
                f64::NAN
            } else {
                c as f64 / h.pixels as f64
            };
            let _ = writeln!(
                t,
                "{},{b},{},{},{c},{},{},{},{},{},{}",
                s.name,
                csv_num(lo),
                csv_num(hi),
                csv_num(share),
                h.pixels,
                h.measured_bound_m().map_or(String::new(), csv_num),
                h.with_sigma,
                h.within_sigma,
                h.median_sigma_m().map_or(String::new(), csv_num),
            );
        }
    }
    t
}

const W: u32 = 480;
const H: u32 = 320;
const MARGIN: u32 = 44;
const BAR: Rgb<u8> = Rgb([90, 110, 170]);
const OVERFLOW: Rgb<u8> = Rgb([150, 150, 150]);
const SIGMA: Rgb<u8> = Rgb([220, 40, 40]);
const BOUND: Rgb<u8> = Rgb([20, 140, 60]);

/// Fig. 6 of one strategy: the share of rock pixels per 2 cm error bin
/// over ±0.5 m (grey bars at the ends: beyond), the paper's bound (68.3 %
/// of the errors within) as green and the median predicted 1 sigma as red
/// lines either side of 0.
pub fn depth_error_plot(name: &str, h: &DepthErrorHistogram) -> RgbImage {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let (x0, y0) = (f64::from(MARGIN), f64::from(H - MARGIN));
    let (x1, y1) = (f64::from(W - MARGIN), f64::from(MARGIN));
    let slots = h.counts.len() as f64;
    let slot = (x1 - x0) / slots;
    let peak = h.counts.iter().copied().max().unwrap_or(0).max(1) as f64;
    let total = h.pixels.max(1) as f64;
    for (b, &c) in h.counts.iter().enumerate() {
        let colour = if b == 0 || b + 1 == h.counts.len() {
            OVERFLOW
        } else {
            BAR
        };
        let top = y0 + (y1 - y0) * c as f64 / peak;
        let (l, r) = (x0 + slot * b as f64 + 1.0, x0 + slot * (b + 1) as f64 - 1.0);
        for x in l as i64..=r as i64 {
            for y in top as i64..=y0 as i64 {
                put(&mut img, x, y, colour);
            }
        }
    }
    // x of an error inside the range: the inner slots span ±ERROR_RANGE_M.
    let at =
        |e: f64| x0 + slot * (1.0 + (e + ERROR_RANGE_M) / (2.0 * ERROR_RANGE_M) * (slots - 2.0));
    for (bound, colour) in [(h.measured_bound_m(), BOUND), (h.median_sigma_m(), SIGMA)] {
        if let Some(s) = bound.filter(|s| *s < ERROR_RANGE_M) {
            for e in [-s, s] {
                line(&mut img, (at(e), y0), (at(e), y1), colour);
            }
        }
    }
    line(&mut img, (x0, y0), (x1, y0), BLACK);
    line(&mut img, (x0, y0), (x0, y1), BLACK);
    for e in [-0.5, -0.25, 0.0, 0.25, 0.5] {
        let x = at(e);
        line(&mut img, (x, y0), (x, y0 + 4.0), BLACK);
        let label = format!("{e}");
        text(
            &mut img,
            x as i64 - text_width(&label) / 2,
            y0 as i64 + 8,
            &label,
            BLACK,
        );
    }
    // The y axis: the share of the pixels in the tallest bin.
    let peak_label = format!("{:.0} %", 100.0 * peak / total);
    let label_x = x0 as i64 - text_width(&peak_label) - 4;
    text(&mut img, label_x, y1 as i64 - 4, &peak_label, BLACK);
    text(
        &mut img,
        x0 as i64 - text_width("0") - 4,
        y0 as i64 - 4,
        "0",
        BLACK,
    );
    let title = format!("{name}: rock depth error, {} px", h.pixels);
    text(&mut img, x0 as i64, 4, &title, BLACK);
    let axis = "error (m)";
    text(
        &mut img,
        x1 as i64 - text_width(axis),
        y0 as i64 + 20,
        axis,
        BLACK,
    );
    // A bound beyond the axis is named, not drawn.
    let off = |b: Option<f64>| {
        if b.is_some_and(|b| b >= ERROR_RANGE_M) {
            " > 0.5 m"
        } else {
            ""
        }
    };
    let legends = [
        (
            format!("68.3 % within{}", off(h.measured_bound_m())),
            BOUND,
            16,
        ),
        (
            format!("median predicted 1 sigma{}", off(h.median_sigma_m())),
            SIGMA,
            28,
        ),
    ];
    for (legend, colour, y) in legends {
        text(
            &mut img,
            x1 as i64 - text_width(&legend),
            y,
            &legend,
            colour,
        );
    }
    img
}

/// Writes `triplets.csv`, `depth_error_rock.csv` and the Fig. 6 PNGs into
/// `dir` (nothing without triplet strategies).
pub fn write_files(report: &CampaignReport, dir: &Path) -> Result<()> {
    let all = by_strategy(report);
    if planned(&all).is_empty() {
        return Ok(());
    }
    let write = |name: &str, text: &str| {
        vp_scene::fsio::write_file_atomic(&dir.join(name), text.as_bytes())
    };
    write("triplets.csv", &triplets_csv(&all))?;
    write("depth_error_rock.csv", &depth_error_csv(&all))?;
    for s in &all {
        let file = format!("depth_error_rock_{}.png", file_stem(&s.name));
        save_rgb(&depth_error_plot(&s.name, &s.rock), &dir.join(&file))?;
    }
    Ok(())
}

#[cfg(test)]
#[path = "outcomes_tests.rs"]
mod tests;
