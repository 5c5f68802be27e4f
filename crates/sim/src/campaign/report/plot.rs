//! PNG plots of the report, drawn with the `image` crate; titles, axis
//! labels and legends in vp-scene's bitmap font ([`draw_text`]).

use std::path::Path;

use image::Rgb;
use vp_planner::output::{render_top_view, TopView};
use vp_scene::plan::{Flight, Plan};
use vp_scene::raster::{draw_text, save_rgb, text_width, RgbImage, GLYPH_PX as GLYPH};

use super::results::SiteArtifacts;
use crate::campaign::curves::ConfidenceCurve;
use crate::error::Result;

const W: u32 = 480;
const H: u32 = 320;
const MARGIN: u32 = 30;
/// Largest angle on the x axis, degrees.
const X_MAX: f64 = 45.0;

pub(crate) fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && x < i64::from(img.width()) && y < i64::from(img.height()) {
        img.put_pixel(x as u32, y as u32, c);
    }
}

pub(crate) fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
    let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
    for i in 0..=n {
        let s = i as f64 / n as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * s, a.1 + (b.1 - a.1) * s);
        for (dx, dy) in [(0, 0), (1, 0), (0, 1)] {
            put(img, x as i64 + dx, y as i64 + dy, c);
        }
    }
}

pub(crate) const BLACK: Rgb<u8> = Rgb([0, 0, 0]);
const TRUTH: Rgb<u8> = Rgb([220, 40, 40]);
const LEARNED: Rgb<u8> = Rgb([40, 70, 220]);
/// Measured on the random triplets no planner chose.
const RANDOM: Rgb<u8> = Rgb([30, 150, 60]);

pub(crate) fn text(img: &mut RgbImage, x: i64, y: i64, s: &str, c: Rgb<u8>) {
    draw_text(img, x, y, s, c);
}

/// One material's learned (blue) and measured confidence over the angle, on
/// the flown triplets (red) and on the random set (green),
/// with its title, axis labels and legend.
pub fn curve_plot(c: &ConfidenceCurve) -> RgbImage {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let (x0, y0) = (f64::from(MARGIN), f64::from(H - MARGIN));
    let (x1, y1) = (f64::from(W - MARGIN), f64::from(MARGIN));
    let grey = Rgb([190, 190, 190]);
    for k in 0..=9 {
        let x = x0 + (x1 - x0) * f64::from(k) * 5.0 / X_MAX;
        line(&mut img, (x, y0), (x, y0 + 5.0), grey);
        if k % 3 == 0 {
            let label = format!("{}", 5 * k);
            text(
                &mut img,
                x as i64 - text_width(&label) / 2,
                y0 as i64 + 8,
                &label,
                BLACK,
            );
        }
    }
    for k in 0..=4 {
        let y = y0 + (y1 - y0) * f64::from(k) / 4.0;
        line(&mut img, (x0, y), (x1, y), grey);
    }
    for (v, label) in [(0.0, "0"), (0.5, ".5"), (1.0, "1")] {
        let y = y0 + (y1 - y0) * v;
        text(
            &mut img,
            x0 as i64 - text_width(label) - 4,
            y as i64 - 4,
            label,
            BLACK,
        );
    }
    line(&mut img, (x0, y0), (x1, y0), BLACK);
    line(&mut img, (x0, y0), (x0, y1), BLACK);
    let title = format!("{}: MVS success vs angle", c.material);
    text(&mut img, x0 as i64, 8, &title, BLACK);
    let legend_x = x1 as i64 - text_width("learned");
    text(&mut img, legend_x, y1 as i64 + 6, "learned", LEARNED);
    text(&mut img, legend_x, y1 as i64 + 18, "flown", TRUTH);
    text(&mut img, legend_x, y1 as i64 + 30, "random", RANDOM);
    let axis = "angle (deg)";
    text(
        &mut img,
        x1 as i64 - text_width(axis),
        y0 as i64 + 18,
        axis,
        BLACK,
    );
    let to = |a: f64, v: f64| {
        (
            x0 + (x1 - x0) * a / X_MAX,
            y0 + (y1 - y0) * v.clamp(0.0, 1.0),
        )
    };
    for (vals, colour) in [
        (&c.measured_random, RANDOM),
        (&c.measured, TRUTH),
        (&c.learned, LEARNED),
    ] {
        for i in 1..vals.len() {
            // A bin without measured pixels breaks the line.
            if !(vals[i - 1].is_finite() && vals[i].is_finite()) {
                continue;
            }
            line(
                &mut img,
                to(c.angle_deg[i - 1], vals[i - 1]),
                to(c.angle_deg[i], vals[i]),
                colour,
            );
        }
    }
    img
}

/// `confidence_<material>.png` for every curve.
pub fn write_curve_plots(curves: &[ConfidenceCurve], dir: &Path) -> Result<()> {
    for c in curves {
        save_rgb(
            &curve_plot(c),
            &dir.join(format!("confidence_{}.png", c.material)),
        )?;
    }
    Ok(())
}

/// A strategy's name as it appears in file names (`G+F5x4` is
/// `Gplus_F5x4`: a `+` in a URL or shell word is a trap).
pub fn file_stem(strategy: &str) -> String {
    strategy.replace('+', "plus_")
}

/// A caption on a white band along the top of a top view.
fn caption(img: &mut RgbImage, s: &str) {
    for y in 0..GLYPH as u32 + 8 {
        for x in 0..img.width() {
            put(img, i64::from(x), i64::from(y), Rgb([255, 255, 255]));
        }
    }
    text(img, 6, 4, s, BLACK);
}

/// `plan_<strategy>.png` (every iteration's views over the true mesh) and
/// `fulfillment_<strategy>.png` (per evaluation face f, red 0 to green 1).
pub fn write_site_plots(a: &SiteArtifacts, dir: &Path) -> Result<()> {
    let roi = [
        [a.roi.min.x, a.roi.min.y],
        [a.roi.max.x, a.roi.min.y],
        [a.roi.max.x, a.roi.max.y],
        [a.roi.min.x, a.roi.max.y],
    ];
    // Thin out the faces: a top view shows a few thousand dots at most.
    let step = (a.centroids.len() / 6000).max(1);
    for s in &a.strategies {
        let file = file_stem(&s.name);
        let empty = Plan::new(None);
        // Every iteration's plan in one picture: each keeps its own
        // flights (from and to home), numbered on from the previous ones.
        let mut all = Plan::new(s.plans.first().and_then(|p| p.origin));
        all.home = s.plans.first().and_then(|p| p.home.clone());
        for p in &s.plans {
            let base = all.waypoints.len();
            all.waypoints.extend(p.waypoints.iter().cloned());
            if p.flights.is_empty() && !p.waypoints.is_empty() {
                all.flights.push(Flight {
                    waypoints: (base..all.waypoints.len()).collect(),
                    distance_m: 0.0,
                    duration_s: 0.0,
                    from_home: p.home.is_some(),
                });
            }
            all.flights.extend(p.flights.iter().map(|f| Flight {
                waypoints: f.waypoints.iter().map(|i| base + i).collect(),
                ..f.clone()
            }));
        }
        if !s.plans.is_empty() {
            let view = TopView {
                mesh: &a.mesh,
                fulfillment: &[],
                roi_outline: &roi,
                plan: &all,
                acquired: &[],
                size: 640,
            };
            let mut img = render_top_view(&view);
            caption(
                &mut img,
                &format!(
                    "{}: every iteration's flights, numbered in flight order",
                    s.name
                ),
            );
            save_rgb(&img, &dir.join(format!("plan_{file}.png")))?;
        }
        let pts: Vec<_> = a
            .centroids
            .iter()
            .zip(&s.face_f)
            .step_by(step)
            .map(|(p, f)| (*p, *f))
            .collect();
        let view = TopView {
            mesh: &a.mesh,
            fulfillment: &pts,
            roi_outline: &roi,
            plan: &empty,
            acquired: &[],
            size: 640,
        };
        let mut img = render_top_view(&view);
        caption(
            &mut img,
            &format!("{}: fulfillment f per face, red 0 .. green 1", s.name),
        );
        save_rgb(&img, &dir.join(format!("fulfillment_{file}.png")))?;
    }
    Ok(())
}
