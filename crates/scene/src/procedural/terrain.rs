//! Terrain: a gentle plane slope plus fBm relief, meshed as a regular grid.
//!
//! The analytic height ([`Terrain::height`]) shapes the grid; everything that
//! stands on the ground (rock rim, trunks, grass, posts) is placed on the
//! *meshed* surface ([`TerrainGrid::height`]), so nothing floats above or
//! hides below a coarse grid's facets.

use nalgebra::Point3;
use rand::Rng;
use rayon::prelude::*;

use super::noise::Fbm;
use super::{filter_faces, part, part_rng, part_seed, shapes::grid};

/// Wavelength of the first relief octave, metres: gentle undulation.
const RELIEF_WAVELENGTH: f64 = 24.0;
/// Amplitude of the first relief octave, metres.
const RELIEF_AMPLITUDE: f64 = 0.7;
/// Relief octaves: down to 1.5 m wavelength, bumps a pilot would see.
const RELIEF_OCTAVES: u32 = 5;

/// Analytic ground height of a site: `slope . (x, y) + relief(x, y)`,
/// shifted so that the height at the origin is 0.
#[derive(Debug, Clone)]
pub struct Terrain {
    /// Mean gradient (dz/dx, dz/dy) of the site: a gentle hillside.
    pub slope: [f64; 2],
    /// Relief added to the slope.
    pub relief: Fbm,
    offset: f64,
}

impl Terrain {
    /// The terrain of a site seed: slope 3-10 % in a random direction.
    pub fn new(seed: u64) -> Self {
        let mut rng = part_rng(seed, part::TERRAIN, 0);
        let grade = rng.random_range(0.03..0.10);
        let dir = rng.random_range(0.0..std::f64::consts::TAU);
        let relief = Fbm::new(
            part_seed(seed, part::TERRAIN, 1),
            RELIEF_WAVELENGTH,
            RELIEF_AMPLITUDE,
            RELIEF_OCTAVES,
        );
        let offset = relief.get(0.0, 0.0);
        Terrain {
            slope: [grade * dir.cos(), grade * dir.sin()],
            relief,
            offset,
        }
    }

    /// Height at (x, y), metres.
    pub fn height(&self, x: f64, y: f64) -> f64 {
        self.slope[0] * x + self.slope[1] * y + self.relief.get(x, y) - self.offset
    }

    /// Bounds (min, max) of the height over the square |x|, |y| <= `half`:
    /// the slope's extremes at the corners widened by the relief's bound.
    pub fn height_bounds(&self, half: f64) -> (f64, f64) {
        let plane = half * (self.slope[0].abs() + self.slope[1].abs());
        let r = self.relief.bound();
        (-plane - r - self.offset, plane + r - self.offset)
    }
}

/// The meshed terrain: a regular grid of `nx` x `ny` cells over the site
/// square, two triangles per cell (diagonal from (i, j) to (i+1, j+1)).
#[derive(Debug, Clone)]
pub struct TerrainGrid {
    /// Corner (x, y) of cell (0, 0).
    pub origin: [f64; 2],
    /// Cell size (dx, dy), metres.
    pub cell: [f64; 2],
    /// Cells along x.
    pub nx: usize,
    /// Cells along y.
    pub ny: usize,
    heights: Vec<f64>,
}

impl TerrainGrid {
    /// Grid over the square |x|, |y| <= `half` with heights from `terrain`.
    pub(crate) fn new(terrain: &Terrain, half: f64, nx: usize, ny: usize) -> Self {
        let cell = [2.0 * half / nx as f64, 2.0 * half / ny as f64];
        let row = nx + 1;
        let heights = (0..row * (ny + 1))
            .into_par_iter()
            .map(|k| {
                let (x, y) = grid_xy([-half, -half], cell, row, k);
                terrain.height(x, y)
            })
            .collect();
        TerrainGrid {
            origin: [-half, -half],
            cell,
            nx,
            ny,
            heights,
        }
    }

    /// Height of the meshed surface at (x, y) (clamped to the grid):
    /// linear over the triangle that contains the point.
    pub fn height(&self, x: f64, y: f64) -> f64 {
        let fx = ((x - self.origin[0]) / self.cell[0]).clamp(0.0, self.nx as f64);
        let fy = ((y - self.origin[1]) / self.cell[1]).clamp(0.0, self.ny as f64);
        let i = (fx.floor() as usize).min(self.nx - 1);
        let j = (fy.floor() as usize).min(self.ny - 1);
        let (s, t) = (fx - i as f64, fy - j as f64);
        let row = self.nx + 1;
        let h = |di: usize, dj: usize| self.heights[(j + dj) * row + i + di];
        if s >= t {
            // Triangle (00, 10, 11).
            h(0, 0) + s * (h(1, 0) - h(0, 0)) + t * (h(1, 1) - h(1, 0))
        } else {
            // Triangle (00, 11, 01).
            h(0, 0) + t * (h(0, 1) - h(0, 0)) + s * (h(1, 1) - h(0, 1))
        }
    }

    /// The grid's triangles, without those whose three corners satisfy
    /// `covered` (hidden under the rock); unused vertices dropped.
    pub(crate) fn mesh<F>(&self, covered: F) -> (Vec<Point3<f64>>, Vec<[u32; 3]>)
    where
        F: Fn(f64, f64) -> bool + Sync,
    {
        let heights = &self.heights;
        let (vertices, faces) = grid(
            (self.origin[0], self.origin[1]),
            (self.cell[0], self.cell[1]),
            self.nx,
            self.ny,
            |k, _, _| heights[k],
        );
        let hidden: Vec<bool> = vertices.par_iter().map(|p| covered(p.x, p.y)).collect();
        filter_faces(&vertices, &faces, |f| {
            !f.iter().all(|&v| hidden[v as usize])
        })
    }
}

fn grid_xy(origin: [f64; 2], cell: [f64; 2], row: usize, k: usize) -> (f64, f64) {
    let (i, j) = (k % row, k / row);
    (
        origin[0] + i as f64 * cell[0],
        origin[1] + j as f64 * cell[1],
    )
}

/// Grid size (nx, ny) whose kept faces come close to `budget`, given the
/// faces hidden by `covered`. The hidden share is measured on a first
/// guess of the grid and assumed constant.
pub(crate) fn fit_grid<F>(half: f64, budget: usize, covered: F) -> (usize, usize)
where
    F: Fn(f64, f64) -> bool + Sync,
{
    let n0 = ((budget as f64 / 2.0).sqrt().round() as usize).max(4);
    let cell = 2.0 * half / n0 as f64;
    let row = n0 + 1;
    let hidden: Vec<bool> = (0..row * row)
        .into_par_iter()
        .map(|k| {
            let (x, y) = grid_xy([-half, -half], [cell, cell], row, k);
            covered(x, y)
        })
        .collect();
    let mut removed = 0usize;
    for j in 0..n0 {
        for i in 0..n0 {
            let h = |di: usize, dj: usize| hidden[(j + dj) * row + i + di];
            removed += usize::from(h(0, 0) && h(1, 0) && h(1, 1));
            removed += usize::from(h(0, 0) && h(1, 1) && h(0, 1));
        }
    }
    let keep = 1.0 - removed as f64 / (2 * n0 * n0) as f64;
    let cells = budget as f64 / (2.0 * keep.max(0.05));
    let nx = (cells.sqrt().round() as usize).max(4);
    let ny = ((cells / nx as f64).round() as usize).max(4);
    (nx, ny)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terrain_is_gentle_and_bounded() {
        let t = Terrain::new(5);
        assert!(t.height(0.0, 0.0).abs() < 1e-15);
        let g = t.slope[0].hypot(t.slope[1]);
        assert!((0.03..0.10).contains(&g));
        let (lo, hi) = t.height_bounds(30.0);
        for i in 0..3000 {
            let (x, y) = ((i % 61) as f64 - 30.0, (i / 61) as f64 * 0.6 - 15.0);
            let z = t.height(x, y);
            assert!(z >= lo && z <= hi, "{z} outside [{lo}, {hi}]");
        }
    }

    #[test]
    fn grid_height_matches_mesh_and_function_at_vertices() {
        let t = Terrain::new(9);
        let g = TerrainGrid::new(&t, 10.0, 20, 16);
        let (v, f) = g.mesh(|_, _| false);
        assert_eq!(f.len(), 2 * 20 * 16);
        for p in &v {
            assert_eq!(p.z.to_bits(), t.height(p.x, p.y).to_bits());
            assert!((g.height(p.x, p.y) - p.z).abs() < 1e-12);
        }
        // Inside a face, the interpolated height lies on the face's plane.
        for face in f.iter().step_by(7) {
            let [a, b, c] = face.map(|i| v[i as usize]);
            let q = Point3::from((a.coords + b.coords * 2.0 + c.coords * 3.0) / 6.0);
            assert!((g.height(q.x, q.y) - q.z).abs() < 1e-9);
        }
    }

    #[test]
    fn fitted_grid_meets_budget_with_hole() {
        let hole = |x: f64, y: f64| x * x + y * y < 100.0;
        let (nx, ny) = fit_grid(30.0, 50_000, hole);
        let t = Terrain::new(1);
        let (_, f) = TerrainGrid::new(&t, 30.0, nx, ny).mesh(hole);
        let ratio = f.len() as f64 / 50_000.0;
        assert!((ratio - 1.0).abs() < 0.03, "{} faces", f.len());
    }
}
