//! The PNG top view an operator reads before a flight, after QGroundControl's
//! mission view: the take-off point as an "H", the waypoints numbered in
//! flight order, the path with arrows in the direction of flight and
//! coloured by altitude (with its key), and below the map a panel whose
//! title and footer say what kind of picture this is (a plan over its
//! f(t), a plan, a grid plan, a fulfillment map).
//!
//! [`top_view`] returns the picture with the list of what it drew
//! ([`Mark`]), so that tests check the marks rather than pixels.

mod canvas;
mod panel;
#[cfg(test)]
mod tests;

use std::io::Write;
use std::path::Path;

use image::{Rgb, RgbImage};
use nalgebra::Point3;
use vp_scene::geodesy::LocalFrame;
use vp_scene::plan::{Plan, Role};
use vp_scene::raster::{draw_text, text_width};
use vp_scene::{fsio, Camera, Mesh};

use crate::error::{PlannerError, Result};
use crate::output::{role_colour, ACQUIRED_COLOUR};
use canvas::{altitude_ramp, face_fulfillment, fill, ramp, Canvas};

/// What the top view shows.
pub struct TopView<'a> {
    /// The scene mesh.
    pub mesh: &'a Mesh,
    /// Sampled triangles' centroids with their f(t), drawn over the mesh.
    pub fulfillment: &'a [(Point3<f64>, f64)],
    /// ROI outline corners (x, y), closed implicitly.
    pub roi_outline: &'a [[f64; 2]],
    /// The plan; its home (with its origin) is drawn as the take-off point,
    /// its flights as separate paths from and to home.
    pub plan: &'a Plan,
    /// The acquired cameras (the COLMAP model planned from), drawn as
    /// blue squares under the plan.
    pub acquired: &'a [Camera],
    /// Longest image side, pixels.
    pub size: u32,
}

/// What a top view is a picture of; it decides its title and footer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViewKind {
    /// Waypoints over the f(t) they were planned from (`vpctl plan --png`).
    PlanOverFulfillment,
    /// Waypoints of a plan with triplet or bridging views, the mesh shaded
    /// by height (no f(t) given).
    Plan,
    /// Only grid and initial views: no f(t) exists for such a plan.
    GridPlan,
    /// f(t) per face, no waypoints (the campaign's fulfillment maps).
    FulfillmentMap,
    /// No waypoints and no f(t): the mesh by height.
    Mesh,
}

impl ViewKind {
    /// The kind of picture `view` makes.
    pub fn of(view: &TopView) -> ViewKind {
        let wps = &view.plan.waypoints;
        match (wps.is_empty(), view.fulfillment.is_empty()) {
            (true, true) => ViewKind::Mesh,
            (true, false) => ViewKind::FulfillmentMap,
            (false, false) => ViewKind::PlanOverFulfillment,
            (false, true) => {
                if wps
                    .iter()
                    .all(|w| matches!(w.role, Role::Grid | Role::Initial))
                {
                    ViewKind::GridPlan
                } else {
                    ViewKind::Plan
                }
            }
        }
    }
}

/// One thing drawn on the top view, in drawing order.
#[derive(Debug, Clone, PartialEq)]
pub enum Mark {
    /// The take-off point, an "H" in a green disc, at pixel `at`.
    Home {
        /// Pixel position (x right, y down).
        at: (f64, f64),
    },
    /// A dashed leg between home and the first (`to_home` false) or last
    /// waypoint of flight `flight` (0-based).
    HomeLeg {
        /// Index into the plan's flights.
        flight: usize,
        /// Whether the leg returns home.
        to_home: bool,
    },
    /// An arrow head on the leg from waypoint `from` to `from + 1`
    /// (numbers as written on the map), pointing the way the vehicle flies.
    Arrow {
        /// The number of the leg's first waypoint.
        from: usize,
    },
    /// A waypoint: its number in flight order (1 for `waypoints[0]`), its
    /// pixel position, its altitude (above home when the plan has one, else
    /// its z) and whether its number is written (numbers that would overlap
    /// an earlier one are left out; the first and last are always written).
    Waypoint {
        /// 1-based position in flight order.
        number: usize,
        /// Pixel position (x right, y down).
        at: (f64, f64),
        /// Metres above home, or z without a home.
        altitude_m: f64,
        /// Whether the number is drawn next to the dot.
        labelled: bool,
    },
    /// A line of the panel below the map (title, legend, keys, footer).
    Text(String),
}

/// A rendered top view and what it drew.
pub struct TopViewPicture {
    /// The picture (map and panel).
    pub image: RgbImage,
    /// Everything drawn, in order.
    pub marks: Vec<Mark>,
    /// What the picture shows.
    pub kind: ViewKind,
}

/// The take-off point's disc.
const HOME_COLOUR: Rgb<u8> = Rgb([30, 160, 70]);
const TEXT_COLOUR: Rgb<u8> = Rgb([235, 235, 235]);
const BACKGROUND: Rgb<u8> = Rgb([20, 20, 30]);
/// Pixels around the map for marks and numbers at its edge.
const MARGIN_PX: f64 = 14.0;

/// The waypoints' flights as runs of indices: the plan's flights, or one
/// flight of every waypoint in plans written before flights were recorded.
fn flight_runs(plan: &Plan) -> Vec<(Vec<usize>, bool)> {
    if plan.flights.is_empty() {
        if plan.waypoints.is_empty() {
            return Vec::new();
        }
        return vec![((0..plan.waypoints.len()).collect(), true)];
    }
    plan.flights
        .iter()
        .map(|f| (f.waypoints.clone(), f.from_home))
        .collect()
}

/// Renders the top view and lists what it drew: mesh faces from below to
/// above, each coloured by the f(t) of the nearest sampled triangle (red 0
/// to green 1, brighter higher up) or, where nothing was sampled, grey by
/// height; the ROI outline in blue; the acquired cameras as blue squares;
/// per flight, dashed legs from and to home and the path coloured by
/// altitude with an arrow on each leg; the planned cameras as dots
/// (triplet members orange, bridges cyan, grid and initial views magenta)
/// with heading ticks and their numbers; the home "H"; below the map the
/// panel (see [`ViewKind`]).
pub fn top_view(view: &TopView) -> TopViewPicture {
    let kind = ViewKind::of(view);
    let plan = view.plan;
    let home = match (plan.origin, &plan.home) {
        (Some(o), Some(h)) => LocalFrame::new(o).ok().map(|f| f.to_enu(h.position)),
        _ => None,
    };
    let b = view.mesh.bounds();
    let acquired: Vec<[f64; 3]> = view.acquired.iter().map(|c| c.center().into()).collect();
    let (mut lo, mut hi) = ([b.min.x, b.min.y], [b.max.x, b.max.y]);
    for p in plan
        .waypoints
        .iter()
        .map(|w| &w.position)
        .chain(&acquired)
        .chain(&home)
    {
        lo = [lo[0].min(p[0]), lo[1].min(p[1])];
        hi = [hi[0].max(p[0]), hi[1].max(p[1])];
    }
    let side = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-6);
    let scale = f64::from(view.size.max(16)) / side;
    let (w, h) = (
        (((hi[0] - lo[0]) * scale + 2.0 * MARGIN_PX).ceil() as u32).max(16),
        (((hi[1] - lo[1]) * scale + 2.0 * MARGIN_PX).ceil() as u32).max(16),
    );
    let mut cv = Canvas {
        img: RgbImage::from_pixel(w, h, BACKGROUND),
        x0: lo[0],
        y1: hi[1],
        scale,
        margin: MARGIN_PX,
    };
    draw_faces(&mut cv, view);
    let n = view.roi_outline.len();
    for i in 0..n {
        let (a, c) = (view.roi_outline[i], view.roi_outline[(i + 1) % n]);
        let (pa, pc) = (cv.px(a[0], a[1]), cv.px(c[0], c[1]));
        cv.line(pa, pc, panel::ROI_COLOUR);
    }
    let r = (0.004 * f64::from(w.max(h))).ceil().max(1.0) as i64;
    // Squares, no heading: acquired images are mostly nadir, where a
    // heading says nothing.
    for p in &acquired {
        let p = cv.px(p[0], p[1]);
        for dy in -r..=r {
            for dx in -r..=r {
                cv.put(p.0 as i64 + dx, p.1 as i64 + dy, ACQUIRED_COLOUR);
            }
        }
    }
    let mut marks = Vec::new();
    let wps = &plan.waypoints;
    let base = home.map_or(0.0, |h| h[2]);
    let alts: Vec<f64> = wps.iter().map(|w| w.position[2] - base).collect();
    let (amin, amax) = alts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| {
            (a.min(z), b.max(z))
        });
    let home_px = home.map(|p| cv.px(p[0], p[1]));
    draw_flights(&mut cv, plan, home_px, &alts, &mut marks);
    for v in wps {
        let colour = role_colour(v.role);
        let p = cv.px(v.position[0], v.position[1]);
        let yaw = v.yaw_deg.to_radians();
        let tick = 4.0 * r as f64;
        cv.line(p, (p.0 + tick * yaw.cos(), p.1 - tick * yaw.sin()), colour);
        cv.dot(p, r + 1, colour);
    }
    draw_numbers(&mut cv, plan, home_px, (&alts, r), &mut marks);
    let keys = panel::Keys {
        kind,
        width_m: f64::from(w) / scale,
        altitude: (!wps.is_empty()).then_some((amin, amax, home.is_some())),
        flights: flight_runs(plan).len(),
    };
    let (image, lines) = panel::with_panel(&cv.img, view, &keys);
    marks.extend(lines.into_iter().map(Mark::Text));
    TopViewPicture { image, marks, kind }
}

/// Per flight: dashed legs from and to home, the path coloured by altitude
/// (`alts`, one per waypoint) and an arrow on each leg long enough for one.
fn draw_flights(
    cv: &mut Canvas,
    plan: &Plan,
    home_px: Option<(f64, f64)>,
    alts: &[f64],
    marks: &mut Vec<Mark>,
) {
    let wps = &plan.waypoints;
    let (amin, amax) = alts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| {
            (a.min(z), b.max(z))
        });
    let alt_t = |z: f64| {
        if amax > amin {
            (z - amin) / (amax - amin)
        } else {
            0.5
        }
    };
    let xy = |cv: &Canvas, i: usize| cv.px(wps[i].position[0], wps[i].position[1]);
    for (fi, (run, from_home)) in flight_runs(plan).iter().enumerate() {
        let (Some(&first), Some(&last)) = (run.first(), run.last()) else {
            continue;
        };
        if let (Some(hp), true) = (home_px, *from_home) {
            for (end, to_home) in [(first, false), (last, true)] {
                let p = xy(&*cv, end);
                cv.dashed(hp, p, HOME_COLOUR, 5);
                marks.push(Mark::HomeLeg {
                    flight: fi,
                    to_home,
                });
            }
        }
        for pair in run.windows(2) {
            let (i, j) = (pair[0], pair[1]);
            let (a, c) = (xy(&*cv, i), xy(&*cv, j));
            let colour = altitude_ramp(alt_t(0.5 * (alts[i] + alts[j])));
            cv.thick(a, c, colour, 2);
            let len = (c.0 - a.0).hypot(c.1 - a.1);
            let size = 7.0;
            if len > 3.0 * size {
                let heading = (c.1 - a.1).atan2(c.0 - a.0);
                let mid = (
                    0.5 * (a.0 + c.0) + 0.5 * size * heading.cos(),
                    0.5 * (a.1 + c.1) + 0.5 * size * heading.sin(),
                );
                cv.arrow_head(mid, heading, size, colour);
                marks.push(Mark::Arrow { from: i + 1 });
            }
        }
    }
}

/// The home "H" and the waypoints' numbers, each on a dark box; a number
/// that would overlap an earlier one (or the H) is left out, except the
/// first and the last. `r` is the waypoint dots' radius.
fn draw_numbers(
    cv: &mut Canvas,
    plan: &Plan,
    home_px: Option<(f64, f64)>,
    (alts, r): (&[f64], i64),
    marks: &mut Vec<Mark>,
) {
    let wps = &plan.waypoints;
    let mut taken: Vec<[f64; 4]> = Vec::new();
    if let Some(hp) = home_px {
        cv.dot(hp, 8, Rgb([255, 255, 255]));
        cv.dot(hp, 7, HOME_COLOUR);
        draw_text(
            &mut cv.img,
            hp.0 as i64 - 3,
            hp.1 as i64 - 4,
            "H",
            Rgb([255, 255, 255]),
        );
        taken.push([hp.0 - 8.0, hp.1 - 8.0, hp.0 + 8.0, hp.1 + 8.0]);
        marks.push(Mark::Home { at: hp });
    }
    for (i, v) in wps.iter().enumerate() {
        let at = cv.px(v.position[0], v.position[1]);
        let label = (i + 1).to_string();
        let (x, y) = (at.0 + r as f64 + 2.0, at.1 - r as f64 - 11.0);
        let bx = [
            x - 1.0,
            y - 1.0,
            x + text_width(&label) as f64 + 1.0,
            y + 9.0,
        ];
        let overlaps = taken
            .iter()
            .any(|t| bx[0] < t[2] && t[0] < bx[2] && bx[1] < t[3] && t[1] < bx[3]);
        let labelled = i == 0 || i + 1 == wps.len() || !overlaps;
        if labelled {
            fill(
                &mut cv.img,
                bx[0] as i64,
                bx[1] as i64,
                (bx[2] - bx[0]) as i64,
                10,
                Rgb([0, 0, 0]),
            );
            draw_text(&mut cv.img, x as i64, y as i64, &label, TEXT_COLOUR);
            taken.push(bx);
        }
        marks.push(Mark::Waypoint {
            number: i + 1,
            at,
            altitude_m: alts[i],
            labelled,
        });
    }
}
/// The mesh faces from below to above, by f(t) where sampled, else grey by height.
fn draw_faces(cv: &mut Canvas, view: &TopView) {
    let b = view.mesh.bounds();
    let mut order: Vec<usize> = (0..view.mesh.n_faces()).collect();
    let cz: Vec<f64> = (0..view.mesh.n_faces())
        .map(|f| view.mesh.face_centroid(f).z)
        .collect();
    order.sort_by(|&a, &b| cz[a].total_cmp(&cz[b]));
    let dz = (b.max.z - b.min.z).max(1e-9);
    let shaded = face_fulfillment(view.mesh, view.fulfillment);
    for f in order {
        let t = view.mesh.triangle(f).map(|p| cv.px(p.x, p.y));
        let height = (cz[f] - b.min.z) / dz;
        let g = (60.0 + 170.0 * height) as u8;
        let colour = match shaded[f] {
            // f(t) colour, darker low and brighter high so relief still shows.
            Some(v) => {
                let k = 0.6 + 0.4 * height;
                Rgb(ramp(v).0.map(|c| (f64::from(c) * k) as u8))
            }
            None => Rgb([g, g, g]),
        };
        cv.triangle(t, colour);
    }
}

/// The picture of [`top_view`] alone.
pub fn render_top_view(view: &TopView) -> RgbImage {
    top_view(view).image
}

/// Writes the top view as PNG, atomically; refuses to overwrite unless `force`.
pub fn write_top_view_png(path: &Path, view: &TopView, force: bool) -> Result<()> {
    fsio::check_overwrite(path, force)?;
    let img = render_top_view(view);
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)
        .map_err(|e| PlannerError::Output {
            path: path.to_path_buf(),
            message: format!("PNG encoding failed: {e}"),
        })?;
    fsio::write_atomic(path, |w| w.write_all(buf.get_ref()))?;
    Ok(())
}
