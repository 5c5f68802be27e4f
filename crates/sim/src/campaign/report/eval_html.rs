//! `report.html` of `vpctl sim evaluate`: the leave-one-site-out summary,
//! one reliability diagram per forest size (also written beside it as
//! `reliability_<matcher>_<forest>.png`) and the label quality per material
//! and per angle bin, on one self-contained page (PNG data URIs, inline
//! CSS, no timestamp: the same evaluation gives the same bytes).

use std::fmt::Write as _;
use std::path::Path;

use base64::Engine as _;
use vp_scene::raster::encode_png;
use vp_scene::SceneError;

use super::page::{cell_table, STYLE};
use super::svg::escape;
use crate::campaign::evaluate::ForestEvaluation;
use crate::campaign::reliability;
use crate::error::Result;

/// Writes the reliability PNGs and `report.html` of `eval` into `dir`.
pub fn write(eval: &ForestEvaluation, dir: &Path) -> Result<()> {
    let mut h = String::from("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">");
    h.push_str("<link rel=\"icon\" href=\"data:,\">");
    let _ = write!(
        h,
        "<title>vpctl forest evaluation</title><style>{STYLE}</style></head><body>\n\
         <h1>What the forest learned: leave-one-site-out ({})</h1>\n<pre>{}</pre>\n",
        escape(&eval.matcher),
        escape(&eval.summary())
    );
    h.push_str(
        "<h2>Reliability</h2>\n<p>Every held-out labelled pixel, binned by the forest's \
         predicted confidence (10 bins): mean confidence (x) against the share labelled \
         positive (y), over all angles (black) and per group of angle bins (colours); grey \
         bars: pixels per bin. A calibrated forest lies on the grey diagonal. The points, \
         with the share truly positive by the renderer's truth, are in \
         <code>reliability.csv</code>.</p>\n<div class=\"plots\">",
    );
    let b64 = base64::engine::general_purpose::STANDARD;
    for r in &eval.reliability {
        let name = r.file_name(&eval.matcher);
        let path = dir.join(&name);
        let png = encode_png(&reliability::plot(&eval.matcher, r), &path)?;
        std::fs::write(&path, &png).map_err(|e| SceneError::io(&path, e))?;
        let _ = writeln!(
            h,
            "<figure><img alt=\"{c}\" src=\"data:image/png;base64,{}\"><figcaption>{c}</figcaption></figure>",
            b64.encode(&png),
            c = escape(&name)
        );
    }
    h.push_str("</div>\n");
    let q = &eval.stats.label_quality;
    h.push_str(
        "<h2>Label quality (labelgen against the renderer's truth)</h2>\n<p>Over every \
         site's training triplets. A label is correct when it agrees with the truth (truly \
         positive: the matcher's depth within the uncertainty bound of the true depth).</p>\n",
    );
    let (header, rows) = q.cells();
    cell_table(
        &mut h,
        "label-quality",
        None,
        &header,
        rows.iter().map(<[String; 5]>::as_slice),
    );
    let (header, rows) = q.angle_cells();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    cell_table(
        &mut h,
        "label-quality-angle",
        Some(
            "Per true triangulation angle: correct % / labelled % of surface \
             (no angle: not seen by all three views); counts in label_quality.csv",
        ),
        &header,
        rows.iter().map(Vec::as_slice),
    );
    h.push_str(
        "<h2>Files beside this page</h2>\n<p><code>forest_eval.csv</code>, \
         <code>angle_success.csv</code>, <code>reliability.csv</code>, \
         <code>label_quality.csv</code>, <code>summary.txt</code> and the reliability PNGs.</p>\n\
         </body></html>\n",
    );
    let p = dir.join("report.html");
    std::fs::write(&p, h).map_err(|e| SceneError::io(&p, e))?;
    Ok(())
}
