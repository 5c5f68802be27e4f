//! The pieces every HTML page of a campaign shares (`report.html`, its
//! per-triplet outcomes, the forest evaluation's page): the inline style, a
//! row of embedded PNG figures and a plain table. Kept apart from the pages
//! so that a page can use another page's section without importing it back.

use std::fmt::Write as _;

use base64::Engine as _;

use super::svg::escape;

pub(super) const STYLE: &str = "body{font-family:system-ui,sans-serif;margin:24px;color:#222;max-width:1400px}\
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em}\
table{border-collapse:collapse;font-size:14px}caption{text-align:left;padding:4px 0;color:#555}\
th,td{border:1px solid #bbb;padding:4px 8px;text-align:right}th{background:#eef}\
td:first-child,th:first-child{text-align:left;font-weight:600}tbody tr:nth-child(even){background:#f7f7f7}\
.plots{display:flex;flex-wrap:wrap;gap:12px}svg{border:1px solid #ddd;background:#fff;font-size:11px}\
svg .title{font-size:13px;font-weight:600}figure{margin:0}figcaption{font-size:13px;color:#555}\
img{max-width:100%;border:1px solid #ddd}pre{background:#f5f5f5;padding:8px;overflow-x:auto}\
dl{font-size:14px;max-width:900px}dt{float:left;clear:left;width:4em;font-weight:600}dd{margin:0 0 4px 4.5em}";

/// A PNG written beside the report, embedded as a data URI, with its caption.
pub struct Figure {
    /// What it shows.
    pub caption: String,
    /// The PNG file's bytes.
    pub png: Vec<u8>,
}

/// `figures` side by side, each a PNG data URI with its caption.
pub(super) fn figure_row(h: &mut String, figures: &[Figure]) {
    if figures.is_empty() {
        return;
    }
    h.push_str("<div class=\"plots\">\n");
    let b64 = base64::engine::general_purpose::STANDARD;
    for f in figures {
        let _ = writeln!(
            h,
            "<figure><img alt=\"{c}\" src=\"data:image/png;base64,{}\"><figcaption>{c}</figcaption></figure>",
            b64.encode(&f.png),
            c = escape(&f.caption)
        );
    }
    h.push_str("</div>\n");
}

/// An HTML table with a header row; the first column names the row.
pub(super) fn cell_table<'a>(
    h: &mut String,
    id: &str,
    caption: Option<&str>,
    header: &[&str],
    rows: impl Iterator<Item = &'a [String]>,
) {
    let _ = write!(h, "<table id=\"{id}\">");
    if let Some(c) = caption {
        let _ = write!(h, "<caption>{}</caption>", escape(c));
    }
    h.push_str("<thead><tr>");
    for c in header {
        let _ = write!(h, "<th>{}</th>", escape(c));
    }
    h.push_str("</tr></thead><tbody>\n");
    for r in rows {
        h.push_str("<tr>");
        for c in r {
            let _ = write!(h, "<td>{}</td>", escape(c));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</tbody></table>\n");
}
