//! The panel below the top view's map: a title and a footer that say what
//! kind of picture it is, the legend of the marks and the colour keys.

use std::fmt::Write as _;

use image::{Rgb, RgbImage};
use vp_scene::plan::Role;
use vp_scene::raster::{draw_text, text_width};

use super::canvas::{altitude_ramp, fill, ramp};
use super::{TopView, ViewKind, BACKGROUND, HOME_COLOUR, TEXT_COLOUR};
use crate::output::{ACQUIRED_COLOUR, BRIDGE_COLOUR, GRID_COLOUR, TRIPLET_COLOUR};

/// The ROI outline.
pub(super) const ROI_COLOUR: Rgb<u8> = Rgb([60, 120, 255]);
/// Height of one panel line, pixels.
const LINE_PX: u32 = 14;

/// What the panel needs besides the view.
pub(super) struct Keys {
    pub kind: ViewKind,
    /// The map's width, metres.
    pub width_m: f64,
    /// Lowest and highest waypoint altitude, and whether they are above home.
    pub altitude: Option<(f64, f64, bool)>,
    pub flights: usize,
}

/// The title line for `kind`.
fn title(view: &TopView, keys: &Keys) -> String {
    let wps = &view.plan.waypoints;
    let count = |f: &dyn Fn(Role) -> bool| wps.iter().filter(|v| f(v.role)).count();
    let mut t = match keys.kind {
        ViewKind::FulfillmentMap => {
            format!(
                "fulfillment map: f(t) of {} sampled triangles",
                view.fulfillment.len()
            )
        }
        ViewKind::Mesh => "the mesh, shaded by height".to_string(),
        ViewKind::GridPlan => format!(
            "grid plan: {} waypoints in {} flight{}",
            wps.len(),
            keys.flights,
            if keys.flights == 1 { "" } else { "s" }
        ),
        ViewKind::Plan | ViewKind::PlanOverFulfillment => format!(
            "vpctl plan: {} waypoints ({} triplet, {} bridge, {} grid) in {} flight{}",
            wps.len(),
            count(&|r| r == Role::TripletMember),
            count(&|r| r == Role::Bridge),
            count(&|r| matches!(r, Role::Grid | Role::Initial)),
            keys.flights,
            if keys.flights == 1 { "" } else { "s" }
        ),
    };
    if !view.acquired.is_empty() {
        let _ = write!(t, " from {} acquired", view.acquired.len());
    }
    if view.plan.cut_short {
        t.push_str(", cut short");
    }
    t
}

/// The footer line for `kind`: scale and what the face colours mean.
fn footer(keys: &Keys, has_home: bool) -> String {
    let faces = match keys.kind {
        ViewKind::PlanOverFulfillment | ViewKind::FulfillmentMap => {
            "faces: f(t) of the nearest sample, grey: not sampled"
        }
        ViewKind::Plan => "faces grey by height (f(t) not drawn in this view)",
        ViewKind::GridPlan => "a grid plan has no f(t): faces grey by height",
        ViewKind::Mesh => "faces grey by height",
    };
    let mut s = format!("north up, {:.0} m across; {faces}", keys.width_m);
    let plan_kind = matches!(
        keys.kind,
        ViewKind::Plan | ViewKind::PlanOverFulfillment | ViewKind::GridPlan
    );
    if plan_kind && !has_home {
        s.push_str("; no home in the plan");
    }
    s
}

/// The map with the panel below it, and the panel's lines as text.
pub(super) fn with_panel(map: &RgbImage, view: &TopView, keys: &Keys) -> (RgbImage, Vec<String>) {
    let has_home = view.plan.home.is_some() && view.plan.origin.is_some();
    let plan_kind = keys.altitude.is_some();
    let shows_f = matches!(
        keys.kind,
        ViewKind::PlanOverFulfillment | ViewKind::FulfillmentMap
    );
    let legend = legend(view, plan_kind, has_home);
    let altitude = keys.altitude.map(|(lo, hi, above_home)| {
        let what = if above_home {
            "path altitude above home"
        } else {
            "path height z (no home)"
        };
        (format!("{what} {lo:.0} m"), format!("{hi:.0} m"))
    });
    let title = title(view, keys);
    let footer = footer(keys, has_home);
    let mut lines = vec![title.clone()];
    if !legend.is_empty() {
        lines.push(
            legend
                .iter()
                .map(|(_, l)| *l)
                .collect::<Vec<_>>()
                .join(", "),
        );
    }
    lines.push(
        if shows_f {
            "f(t) 0 .. 1, mesh: low .. high"
        } else {
            "mesh: low .. high"
        }
        .to_string(),
    );
    if let Some((a, b)) = &altitude {
        lines.push(format!("{a} .. {b}"));
    }
    lines.push(footer.clone());

    let panel = 6 + lines.len() as u32 * LINE_PX;
    let legend_w: i64 = legend.iter().map(|(_, l)| 23 + text_width(l)).sum();
    let w = [
        i64::from(map.width()),
        text_width(&title) + 12,
        text_width(&footer) + 12,
        legend_w + 12,
        420,
    ]
    .into_iter()
    .max()
    .unwrap_or(420) as u32;
    let mut img = RgbImage::from_pixel(w, map.height() + panel, BACKGROUND);
    image::imageops::overlay(&mut img, map, 0, 0);
    let y0 = i64::from(map.height()) + 4;
    let mut k = 0;
    let mut row = || {
        let y = y0 + k * i64::from(LINE_PX);
        k += 1;
        y
    };
    draw_text(&mut img, 6, row(), &title, TEXT_COLOUR);
    if !legend.is_empty() {
        let y = row();
        let mut x = 6;
        for (c, label) in &legend {
            fill(&mut img, x, y, 8, 8, *c);
            draw_text(&mut img, x + 11, y, label, TEXT_COLOUR);
            x += 11 + text_width(label) + 12;
        }
    }
    let y = row();
    let mut x = 6;
    if shows_f {
        x = key(&mut img, x, y, "f(t) 0", "1", &|t| ramp(t)) + 16;
    }
    let grey = |t: f64| {
        let g = (60.0 + 170.0 * t) as u8;
        Rgb([g, g, g])
    };
    key(&mut img, x, y, "mesh: low", "high", &grey);
    if let Some((a, b)) = &altitude {
        key(&mut img, 6, row(), a, b, &|t| altitude_ramp(t));
    }
    draw_text(&mut img, 6, row(), &footer, TEXT_COLOUR);
    (img, lines)
}

/// The marks' legend: swatch colour and label.
fn legend(view: &TopView, plan_kind: bool, has_home: bool) -> Vec<(Rgb<u8>, &'static str)> {
    let mut legend: Vec<(Rgb<u8>, &'static str)> = Vec::new();
    if plan_kind {
        if has_home {
            legend.push((HOME_COLOUR, "H home"));
        }
        legend.extend([
            (TEXT_COLOUR, "1 2 3 flight order"),
            (TRIPLET_COLOUR, "triplet"),
            (BRIDGE_COLOUR, "bridge"),
            (GRID_COLOUR, "grid"),
        ]);
    }
    if !view.acquired.is_empty() {
        legend.push((ACQUIRED_COLOUR, "acquired"));
    }
    if !view.roi_outline.is_empty() {
        legend.push((ROI_COLOUR, "ROI"));
    }
    legend
}

/// A colour key `low [ramp] high` at (x, y); returns its right end.
fn key(
    img: &mut RgbImage,
    x: i64,
    y: i64,
    low: &str,
    high: &str,
    colour: &dyn Fn(f64) -> Rgb<u8>,
) -> i64 {
    draw_text(img, x, y, low, TEXT_COLOUR);
    let bar_x = x + text_width(low) + 4;
    for i in 0..80 {
        fill(img, bar_x + i, y, 1, 8, colour(i as f64 / 79.0));
    }
    draw_text(img, bar_x + 84, y, high, TEXT_COLOUR);
    bar_x + 84 + text_width(high)
}
