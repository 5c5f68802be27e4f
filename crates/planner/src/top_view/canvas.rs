//! Pixel drawing for the top view: lines, dots, filled triangles, arrow
//! heads, and the shading of mesh faces by the f(t) of nearby samples.

use image::{Rgb, RgbImage};
use nalgebra::Point3;
use vp_scene::Mesh;

/// The map part of the top view: world x/y to pixels, north up.
pub(super) struct Canvas {
    pub img: RgbImage,
    /// World x at pixel column `margin`.
    pub x0: f64,
    /// World y at pixel row `margin`.
    pub y1: f64,
    /// Pixels per metre.
    pub scale: f64,
    /// Empty pixels around the map, so that marks at its edge stay whole.
    pub margin: f64,
}

impl Canvas {
    pub(super) fn px(&self, x: f64, y: f64) -> (f64, f64) {
        (
            (x - self.x0) * self.scale + self.margin,
            (self.y1 - y) * self.scale + self.margin,
        )
    }

    pub(super) fn put(&mut self, x: i64, y: i64, c: Rgb<u8>) {
        if x >= 0 && y >= 0 && x < i64::from(self.img.width()) && y < i64::from(self.img.height()) {
            self.img.put_pixel(x as u32, y as u32, c);
        }
    }

    pub(super) fn line(&mut self, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
        self.dashed(a, b, c, 0);
    }

    /// A line; with `dash > 0` pixels, drawn `dash` on, `dash` off.
    pub(super) fn dashed(&mut self, a: (f64, f64), b: (f64, f64), c: Rgb<u8>, dash: usize) {
        let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
        for i in 0..=n {
            if dash > 0 && (i / dash) % 2 == 1 {
                continue;
            }
            let s = i as f64 / n as f64;
            self.put(
                (a.0 + (b.0 - a.0) * s).round() as i64,
                (a.1 + (b.1 - a.1) * s).round() as i64,
                c,
            );
        }
    }

    /// A line `width` pixels wide (parallel copies), for the flight path.
    pub(super) fn thick(&mut self, a: (f64, f64), b: (f64, f64), c: Rgb<u8>, width: i64) {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len = dx.hypot(dy).max(1e-9);
        let (nx, ny) = (-dy / len, dx / len);
        for k in 0..width {
            let o = k as f64 - (width - 1) as f64 / 2.0;
            self.line(
                (a.0 + nx * o, a.1 + ny * o),
                (b.0 + nx * o, b.1 + ny * o),
                c,
            );
        }
    }

    pub(super) fn dot(&mut self, p: (f64, f64), r: i64, c: Rgb<u8>) {
        for dy in -r..=r {
            for dx in -r..=r {
                if dx * dx + dy * dy <= r * r {
                    self.put(p.0 as i64 + dx, p.1 as i64 + dy, c);
                }
            }
        }
    }

    /// A filled arrow head with its tip at `tip`, pointing along `heading`
    /// (radians, image axes: x right, y down), `size` pixels long.
    pub(super) fn arrow_head(&mut self, tip: (f64, f64), heading: f64, size: f64, c: Rgb<u8>) {
        let back = |side: f64| {
            let a = heading + std::f64::consts::PI + side * 0.45;
            (tip.0 + size * a.cos(), tip.1 + size * a.sin())
        };
        self.triangle([tip, back(1.0), back(-1.0)], c);
    }

    pub(super) fn triangle(&mut self, t: [(f64, f64); 3], c: Rgb<u8>) {
        let (xmin, xmax) = (
            t.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
            t.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max),
        );
        let (ymin, ymax) = (
            t.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
            t.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max),
        );
        let edge = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
            (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
        };
        let area = edge(t[0], t[1], t[2]);
        if area == 0.0 {
            return;
        }
        for y in (ymin.floor() as i64)..=(ymax.ceil() as i64) {
            for x in (xmin.floor() as i64)..=(xmax.ceil() as i64) {
                let p = (x as f64 + 0.5, y as f64 + 0.5);
                let w = [
                    edge(t[1], t[2], p),
                    edge(t[2], t[0], p),
                    edge(t[0], t[1], p),
                ];
                if w.iter().all(|v| v * area >= 0.0) {
                    self.put(x, y, c);
                }
            }
        }
    }
}

/// Per mesh face, the f(t) of the nearest sampled triangle (3D distance
/// between centroids) within 1.5 sample spacings, else `None` (not
/// sampled: outside the ROI, or too far from any sample). The spacing is
/// that of the samples spread evenly over their x/y bounding box (padded).
///
/// # Performance
/// Samples are bucketed in an x/y grid of that radius; each face looks at
/// its 3 x 3 cells only.
pub(super) fn face_fulfillment(mesh: &Mesh, samples: &[(Point3<f64>, f64)]) -> Vec<Option<f64>> {
    if samples.is_empty() {
        return vec![None; mesh.n_faces()];
    }
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for (p, _) in samples {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    }
    // Padded by one spacing of the longer side, so that samples along a
    // line still get a spacing.
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    let pad = w.max(h) / (samples.len() as f64).sqrt();
    let area = ((w + pad) * (h + pad)).max(1e-12);
    let radius = (1.5 * (area / samples.len() as f64).sqrt()).max(1e-6);
    let cell = |x: f64, y: f64| {
        (
            ((x - lo[0]) / radius).floor() as i64,
            ((y - lo[1]) / radius).floor() as i64,
        )
    };
    let mut grid: std::collections::HashMap<(i64, i64), Vec<usize>> =
        std::collections::HashMap::new();
    for (i, (p, _)) in samples.iter().enumerate() {
        grid.entry(cell(p.x, p.y)).or_default().push(i);
    }
    (0..mesh.n_faces())
        .map(|f| {
            let c = mesh.face_centroid(f);
            let (cx, cy) = cell(c.x, c.y);
            let mut best: Option<(f64, f64)> = None;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for &i in grid.get(&(cx + dx, cy + dy)).map_or(&[][..], Vec::as_slice) {
                        let d = (samples[i].0 - c).norm();
                        if d <= radius && best.is_none_or(|(bd, _)| d < bd) {
                            best = Some((d, samples[i].1));
                        }
                    }
                }
            }
            best.map(|(_, v)| v)
        })
        .collect()
}

/// Red (0) through yellow to green (1): the f(t) key.
pub(super) fn ramp(f: f64) -> Rgb<u8> {
    let f = f.clamp(0.0, 1.0);
    let r = (255.0 * (2.0 - 2.0 * f).min(1.0)) as u8;
    let g = (255.0 * (2.0 * f).min(1.0)) as u8;
    Rgb([r, g, 40])
}

/// Light blue (lowest waypoint) through white to yellow (highest): the
/// altitude key of the flight path, apart from the f(t) key's red and green.
pub(super) fn altitude_ramp(t: f64) -> Rgb<u8> {
    let t = t.clamp(0.0, 1.0);
    let mix = |a: [f64; 3], b: [f64; 3], s: f64| {
        Rgb([0, 1, 2].map(|i| (a[i] + (b[i] - a[i]) * s).round() as u8))
    };
    let (low, mid, high) = (
        [80.0, 170.0, 255.0],
        [255.0, 255.0, 255.0],
        [255.0, 200.0, 0.0],
    );
    if t < 0.5 {
        mix(low, mid, 2.0 * t)
    } else {
        mix(mid, high, 2.0 * t - 2.0 * 0.5)
    }
}

/// Fills a rectangle, clipped to the image.
pub(super) fn fill(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, c: Rgb<u8>) {
    for yy in y.max(0)..(y + h).min(i64::from(img.height())) {
        for xx in x.max(0)..(x + w).min(i64::from(img.width())) {
            img.put_pixel(xx as u32, yy as u32, c);
        }
    }
}
