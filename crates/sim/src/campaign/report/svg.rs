//! Small inline SVG line plots for `report.html`: axes with ticks, one
//! polyline per series (a non-finite value breaks the line), point marks
//! so that a one-point series shows, and a legend. Text output with fixed
//! decimals, so the same data gives the same bytes.

use std::fmt::Write as _;

/// One line of a plot.
pub(super) struct Series {
    /// Legend text.
    pub label: String,
    /// CSS colour.
    pub colour: &'static str,
    /// Dashed instead of solid.
    pub dashed: bool,
    /// (x, y) in data units, in drawing order.
    pub points: Vec<(f64, f64)>,
}

/// A plot of a few series over fixed axis ranges.
pub(super) struct LinePlot<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// Label of the x axis.
    pub x_label: &'a str,
    /// Label of the y axis.
    pub y_label: &'a str,
    /// x range (min, max).
    pub x_range: (f64, f64),
    /// y range (min, max).
    pub y_range: (f64, f64),
    /// Tick positions on x.
    pub x_ticks: Vec<f64>,
    /// Tick positions on y.
    pub y_ticks: Vec<f64>,
    /// The lines.
    pub series: Vec<Series>,
}

const W: f64 = 440.0;
const H: f64 = 260.0;
const LEFT: f64 = 46.0;
const RIGHT: f64 = 120.0;
const TOP: f64 = 26.0;
const BOTTOM: f64 = 38.0;

/// Escapes text for HTML and SVG.
pub(super) fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            c => o.push(c),
        }
    }
    o
}

/// A tick value with at most two decimals and no trailing zeros (0.25, 0.5, 5).
fn tick_label(v: f64) -> String {
    let s = format!("{v:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

impl LinePlot<'_> {
    fn px(&self, x: f64, y: f64) -> (f64, f64) {
        let (x0, x1) = self.x_range;
        let (y0, y1) = self.y_range;
        let sx = if x1 > x0 { (x - x0) / (x1 - x0) } else { 0.5 };
        let sy = if y1 > y0 { (y - y0) / (y1 - y0) } else { 0.5 };
        (
            LEFT + sx * (W - LEFT - RIGHT),
            H - BOTTOM - sy.clamp(-0.05, 1.05) * (H - TOP - BOTTOM),
        )
    }

    /// The plot as an `<svg>` element with a `<title>` for screen readers.
    pub(super) fn render(&self) -> String {
        let mut s = String::new();
        let _ = write!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W} {H}" width="{W}" height="{H}" role="img"><title>{t}</title>"#,
            t = escape(self.title)
        );
        let _ = write!(
            s,
            r#"<text x="{LEFT}" y="16" class="title">{}</text>"#,
            escape(self.title)
        );
        let (bx0, by0) = self.px(self.x_range.0, self.y_range.0);
        let (bx1, by1) = self.px(self.x_range.1, self.y_range.1);
        for &t in &self.y_ticks {
            let (_, y) = self.px(self.x_range.0, t);
            let _ = write!(
                s,
                r##"<line x1="{bx0:.1}" y1="{y:.1}" x2="{bx1:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                bx0 - 4.0,
                y + 4.0,
                tick_label(t)
            );
        }
        for &t in &self.x_ticks {
            let (x, _) = self.px(t, self.y_range.0);
            let _ = write!(
                s,
                r##"<line x1="{x:.1}" y1="{by0:.1}" x2="{x:.1}" y2="{:.1}" stroke="#999"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                by0 + 4.0,
                by0 + 16.0,
                tick_label(t)
            );
        }
        let _ = write!(
            s,
            r##"<polyline points="{bx0:.1},{by1:.1} {bx0:.1},{by0:.1} {bx1:.1},{by0:.1}" fill="none" stroke="#333"/>"##
        );
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            f64::midpoint(bx0, bx1),
            H - 6.0,
            escape(self.x_label)
        );
        let _ = write!(
            s,
            r#"<text transform="translate(12 {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            f64::midpoint(by0, by1),
            escape(self.y_label)
        );
        for (i, series) in self.series.iter().enumerate() {
            self.draw_series(&mut s, series);
            let ly = TOP + 8.0 + 16.0 * i as f64;
            let lx = W - RIGHT + 10.0;
            let _ = write!(
                s,
                r#"<line x1="{lx:.1}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{c}" stroke-width="2"{d}/><text x="{:.1}" y="{:.1}">{}</text>"#,
                lx + 18.0,
                lx + 22.0,
                ly + 4.0,
                escape(&series.label),
                c = series.colour,
                d = if series.dashed {
                    r#" stroke-dasharray="5 3""#
                } else {
                    ""
                },
            );
        }
        s.push_str("</svg>");
        s
    }

    fn draw_series(&self, s: &mut String, series: &Series) {
        let dash = if series.dashed {
            r#" stroke-dasharray="5 3""#
        } else {
            ""
        };
        let mut run: Vec<(f64, f64)> = Vec::new();
        let flush = |s: &mut String, run: &mut Vec<(f64, f64)>| {
            if run.len() > 1 {
                let pts: Vec<String> = run.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
                let _ = write!(
                    s,
                    r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="2"{dash}/>"#,
                    pts.join(" "),
                    series.colour
                );
            }
            run.clear();
        };
        for &(x, y) in &series.points {
            if !(x.is_finite() && y.is_finite()) {
                flush(s, &mut run);
                continue;
            }
            let p = self.px(x, y);
            let _ = write!(
                s,
                r#"<circle cx="{:.1}" cy="{:.1}" r="2.5" fill="{}"/>"#,
                p.0, p.1, series.colour
            );
            run.push(p);
        }
        flush(s, &mut run);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_non_finite_value_breaks_the_line_and_text_is_escaped() {
        let plot = LinePlot {
            title: "a < b",
            x_label: "x",
            y_label: "y",
            x_range: (0.0, 3.0),
            y_range: (0.0, 1.0),
            x_ticks: vec![0.0, 1.5, 3.0],
            y_ticks: vec![0.0, 1.0],
            series: vec![Series {
                label: "G+F".into(),
                colour: "red",
                dashed: false,
                points: vec![(0.0, 0.1), (1.0, 0.2), (2.0, f64::NAN), (3.0, 0.5)],
            }],
        };
        let svg = plot.render();
        assert!(svg.contains("a &lt; b") && !svg.contains("a < b"));
        // Two points before the gap make a line; the one after is a mark only.
        assert_eq!(svg.matches(r#"stroke="red" stroke-width="2"/>"#).count(), 2); // line + legend
        assert_eq!(svg.matches("<circle").count(), 3);
        assert_eq!(svg, plot.render());
    }
}
