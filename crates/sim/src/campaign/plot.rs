//! PNG plots of the report, drawn with the `image` crate (no text: the
//! captions and legends live in `table.md`, which keeps the build free of
//! font dependencies).

use std::path::Path;

use image::Rgb;
use vp_planner::output::{render_top_view, TopView};
use vp_scene::plan::Plan;
use vp_scene::raster::{save_rgb, RgbImage};

use super::curves::ConfidenceCurve;
use super::report::SiteArtifacts;
use crate::error::Result;

const W: u32 = 480;
const H: u32 = 320;
const MARGIN: u32 = 30;
/// Largest angle on the x axis, degrees.
const X_MAX: f64 = 45.0;

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && x < i64::from(img.width()) && y < i64::from(img.height()) {
        img.put_pixel(x as u32, y as u32, c);
    }
}

fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
    let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
    for i in 0..=n {
        let s = i as f64 / n as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * s, a.1 + (b.1 - a.1) * s);
        for (dx, dy) in [(0, 0), (1, 0), (0, 1)] {
            put(img, x as i64 + dx, y as i64 + dy, c);
        }
    }
}

/// One material's learned (blue) and true (red) confidence over the angle.
pub fn curve_plot(c: &ConfidenceCurve) -> RgbImage {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let (x0, y0) = (f64::from(MARGIN), f64::from(H - MARGIN));
    let (x1, y1) = (f64::from(W - MARGIN), f64::from(MARGIN));
    let grey = Rgb([190, 190, 190]);
    for k in 0..=9 {
        let x = x0 + (x1 - x0) * f64::from(k) * 5.0 / X_MAX;
        line(&mut img, (x, y0), (x, y0 + 5.0), grey);
    }
    for k in 0..=4 {
        let y = y0 + (y1 - y0) * f64::from(k) / 4.0;
        line(&mut img, (x0, y), (x1, y), grey);
    }
    line(&mut img, (x0, y0), (x1, y0), Rgb([0, 0, 0]));
    line(&mut img, (x0, y0), (x0, y1), Rgb([0, 0, 0]));
    let to = |a: f64, v: f64| {
        (
            x0 + (x1 - x0) * a / X_MAX,
            y0 + (y1 - y0) * v.clamp(0.0, 1.0),
        )
    };
    for (vals, colour) in [
        (&c.truth, Rgb([220, 40, 40])),
        (&c.learned, Rgb([40, 70, 220])),
    ] {
        for i in 1..vals.len() {
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

/// `plan_<strategy>.png` (every iteration's views over the true mesh) and
/// `fulfilment_<strategy>.png` (per evaluation face f, red 0 to green 1).
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
        let file = s.name.replace('+', "plus_");
        let empty = Plan::new(None);
        let mut all = Plan::new(None);
        for p in &s.plans {
            all.waypoints.extend(p.waypoints.iter().cloned());
        }
        if !s.plans.is_empty() {
            let view = TopView {
                mesh: &a.mesh,
                fulfilment: &[],
                roi_outline: &roi,
                plan: &all,
                size: 640,
            };
            save_rgb(
                &render_top_view(&view),
                &dir.join(format!("plan_{file}.png")),
            )?;
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
            fulfilment: &pts,
            roi_outline: &roi,
            plan: &empty,
            size: 640,
        };
        save_rgb(
            &render_top_view(&view),
            &dir.join(format!("fulfilment_{file}.png")),
        )?;
    }
    Ok(())
}
