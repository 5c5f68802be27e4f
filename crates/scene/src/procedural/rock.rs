//! The site's one large smooth rock: a low, skewed elliptical dome rising
//! out of the terrain, like the glacier-polished rock-art surfaces of Val
//! Camonica.
//!
//! The rock is a height offset ("bump") over the meshed terrain. Its mesh is
//! a finer grid in the rock's own frame, cut to the cells where the bump
//! emerges; the cut edge lies at or just below the terrain, so rock and
//! ground intersect like a real outcrop instead of leaving a gap. Terrain
//! faces fully under the rock are removed by the site generator.

use nalgebra::{Point3, Vector2};
use rand::Rng;
use rayon::prelude::*;

use super::noise::GradientNoise;
use super::terrain::TerrainGrid;
use super::{filter_faces, part, part_rng, part_seed, shapes::grid};

/// The rock mesh is lowered by this much (metres) so its cut edge sits
/// below the terrain surface.
pub(crate) const SINK: f64 = 0.05;
/// Terrain vertices with a bump above `SINK + COVER_MARGIN` are hidden
/// under the rock; the margin absorbs the rock's small-scale relief
/// between grid vertices.
pub(crate) const COVER_MARGIN: f64 = 0.10;
/// Relative amplitude of the outline's wobble: the footprint stays within
/// 1 / (1 +- OUTLINE) of the nominal ellipse.
const OUTLINE: f64 = 0.05;

/// Analytic shape of the rock.
#[derive(Debug, Clone)]
pub struct Rock {
    /// Centre of the footprint (x, y), metres.
    pub center: Vector2<f64>,
    /// Yaw of the long axis from +x (east), radians, counter-clockwise.
    pub yaw: f64,
    /// Nominal semi-axes (long, short) of the footprint ellipse, metres.
    pub semi_axes: [f64; 2],
    /// Nominal height above the terrain at the centre, metres; the crest
    /// reaches up to about 1.45 times this (skew and shape noise).
    pub height: f64,
    outline: GradientNoise,
    shape: GradientNoise,
    detail: GradientNoise,
}

impl Rock {
    /// A rock of `length` x `width` x `height` metres near the site centre
    /// (within 2 m), long axis at `yaw` radians from +x.
    pub(crate) fn new(seed: u64, length: f64, width: f64, height: f64, yaw: f64) -> Self {
        let mut rng = part_rng(seed, part::ROCK, 0);
        let center = Vector2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0));
        Rock {
            center,
            yaw,
            semi_axes: [0.5 * length, 0.5 * width],
            height,
            outline: GradientNoise::new(part_seed(seed, part::ROCK, 1)),
            shape: GradientNoise::new(part_seed(seed, part::ROCK, 2)),
            detail: GradientNoise::new(part_seed(seed, part::ROCK, 3)),
        }
    }

    /// (x, y) in the rock frame: u along the long axis, v across.
    fn to_local(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.yaw.sin_cos();
        let (dx, dy) = (x - self.center.x, y - self.center.y);
        (c * dx + s * dy, -s * dx + c * dy)
    }

    fn to_world(&self, u: f64, v: f64) -> (f64, f64) {
        let (s, c) = self.yaw.sin_cos();
        (self.center.x + c * u - s * v, self.center.y + s * u + c * v)
    }

    /// Height of the rock surface above the terrain at (x, y); negative
    /// outside the footprint (where the shape continues under ground).
    pub fn bump(&self, x: f64, y: f64) -> f64 {
        let (u, v) = self.to_local(x, y);
        self.bump_local(u, v)
    }

    fn bump_local(&self, u: f64, v: f64) -> f64 {
        let [a, b] = self.semi_axes;
        let r2 = (u / a).powi(2) + (v / b).powi(2);
        if r2 > 4.0 {
            // Far outside: deep under ground, no need for noise.
            return -3.0 * self.height;
        }
        let r = r2.sqrt() * (1.0 + OUTLINE * self.outline.get(u / 5.0, v / 5.0));
        let base = 1.0 - r * r;
        // One end higher than the other, like an inclined slab.
        let skew = 1.0 + 0.25 * (u / a).clamp(-1.5, 1.5);
        let modulation = 1.0 + 0.15 * self.shape.get(u / 6.0 + 3.7, v / 6.0 - 1.3);
        let detail = 0.06 * self.detail.get(u / 1.5, v / 1.5) * smoothstep(base / 0.3);
        self.height * base * skew * modulation + detail
    }

    /// Elliptical distance from the rock centre with the semi-axes grown by
    /// `margin` metres: below 1 means within `margin` of the footprint.
    pub(crate) fn ellipse_r(&self, x: f64, y: f64, margin: f64) -> f64 {
        let (u, v) = self.to_local(x, y);
        ((u / (self.semi_axes[0] + margin)).powi(2) + (v / (self.semi_axes[1] + margin)).powi(2))
            .sqrt()
    }

    /// Point at elliptical distance 1 (semi-axes grown by `margin`) in the
    /// direction `angle` (rock frame, radians).
    pub(crate) fn ring_point(&self, angle: f64, margin: f64) -> (f64, f64) {
        self.to_world(
            (self.semi_axes[0] + margin) * angle.cos(),
            (self.semi_axes[1] + margin) * angle.sin(),
        )
    }

    /// Whether (x, y) lies within `margin` metres of the footprint's box in
    /// the rock frame (semi-axes grown by `margin`).
    pub(crate) fn within_box(&self, x: f64, y: f64, margin: f64) -> bool {
        let (u, v) = self.to_local(x, y);
        u.abs() <= self.semi_axes[0] + margin && v.abs() <= self.semi_axes[1] + margin
    }

    /// World-axis bounds (min and max corners) of [`Rock::within_box`].
    pub(crate) fn box_bounds(&self, margin: f64) -> ([f64; 2], [f64; 2]) {
        let (a, b) = (self.semi_axes[0] + margin, self.semi_axes[1] + margin);
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (u, v) in [(-a, -b), (a, -b), (a, b), (-a, b)] {
            let (x, y) = self.to_world(u, v);
            lo = [lo[0].min(x), lo[1].min(y)];
            hi = [hi[0].max(x), hi[1].max(y)];
        }
        (lo, hi)
    }

    /// Whether the terrain at (x, y) is hidden under the rock.
    pub(crate) fn covers(&self, x: f64, y: f64) -> bool {
        self.bump(x, y) > SINK + COVER_MARGIN
    }

    /// Half extents of the rock-frame grid domain for cell size `h`: the
    /// footprint's largest extent plus two cells.
    fn domain(&self, h: f64) -> (usize, usize, f64, f64) {
        let reach = 1.0 / (1.0 - OUTLINE);
        let (hu, hv) = (
            reach * self.semi_axes[0] + 2.0 * h,
            reach * self.semi_axes[1] + 2.0 * h,
        );
        let (nu, nv) = (
            (2.0 * hu / h).ceil() as usize,
            (2.0 * hv / h).ceil() as usize,
        );
        (nu, nv, 0.5 * nu as f64 * h, 0.5 * nv as f64 * h)
    }

    /// Rock-frame grid with bumps as z, and the cells' faces that emerge
    /// (some corner above `SINK`).
    fn local_grid(&self, h: f64) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let (nu, nv, hu, hv) = self.domain(h);
        let (vertices, faces) = grid((-hu, -hv), (h, h), nu, nv, |_, u, v| self.bump_local(u, v));
        // Keep both triangles of a cell together: decide on the whole quad.
        let row = nu + 1;
        let up = |k: usize| vertices[k].z > SINK;
        let keep: Vec<bool> = faces
            .chunks(2)
            .map(|pair| {
                let v00 = pair[0][0] as usize;
                up(v00) || up(v00 + 1) || up(v00 + row) || up(v00 + row + 1)
            })
            .collect();
        let kept: Vec<[u32; 3]> = faces
            .iter()
            .enumerate()
            .filter(|(f, _)| keep[f / 2])
            .map(|(_, f)| *f)
            .collect();
        (vertices, kept)
    }

    /// Cell size (metres) whose rock mesh comes close to `budget` faces.
    pub(crate) fn fit_cell(&self, budget: usize) -> f64 {
        let area = std::f64::consts::PI * self.semi_axes[0] * self.semi_axes[1];
        let mut h = (2.0 * area / budget.max(8) as f64).sqrt();
        for _ in 0..2 {
            let n = self.local_grid(h).1.len().max(1);
            h *= (n as f64 / budget.max(8) as f64).sqrt();
        }
        h
    }

    /// The rock mesh on top of the meshed terrain with cell size `h`.
    pub(crate) fn mesh(&self, ground: &TerrainGrid, h: f64) -> (Vec<Point3<f64>>, Vec<[u32; 3]>) {
        let (local, faces) = self.local_grid(h);
        let (local, faces) = filter_faces(&local, &faces, |_| true);
        let vertices = local
            .par_iter()
            .map(|p| {
                let (x, y) = self.to_world(p.x, p.y);
                Point3::new(x, y, ground.height(x, y) + p.z - SINK)
            })
            .collect();
        (vertices, faces)
    }
}

/// C1 step from 0 (t <= 0) to 1 (t >= 1).
fn smoothstep(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::super::terrain::Terrain;
    use super::*;

    #[test]
    fn rock_emerges_in_its_footprint_only() {
        let rock = Rock::new(3, 17.0, 13.0, 2.5, 0.4);
        let c = rock.center;
        assert!(rock.bump(c.x, c.y) > 2.0 && rock.bump(c.x, c.y) < 3.7);
        for k in 0..64 {
            let a = k as f64 / 64.0 * std::f64::consts::TAU;
            let (x, y) = rock.ring_point(a, 1.0);
            assert!(
                rock.bump(x, y) < 0.0,
                "bump outside the footprint at angle {a}"
            );
            let (x, y) = rock.ring_point(a, -1.5);
            assert!(
                rock.bump(x, y) > 0.0,
                "no bump inside the footprint at angle {a}"
            );
        }
    }

    #[test]
    fn rock_mesh_meets_budget_and_edge_is_buried() {
        let rock = Rock::new(4, 17.0, 13.0, 2.5, 0.0);
        let terrain = Terrain::new(4);
        let grid = TerrainGrid::new(&terrain, 30.0, 60, 60);
        let h = rock.fit_cell(20_000);
        let (v, f) = rock.mesh(&grid, h);
        let ratio = f.len() as f64 / 20_000.0;
        assert!((ratio - 1.0).abs() < 0.03, "{} faces", f.len());
        // Boundary vertices (on an edge used once) are at or below the ground.
        let mut uses = std::collections::HashMap::new();
        for face in &f {
            for k in 0..3 {
                let (a, b) = (face[k], face[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let mut boundary = 0;
        for ((a, b), n) in uses {
            if n == 1 {
                for p in [v[a as usize], v[b as usize]] {
                    assert!(p.z <= grid.height(p.x, p.y) + 1e-9);
                    boundary += 1;
                }
            }
        }
        assert!(boundary > 100);
    }
}
