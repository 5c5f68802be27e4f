//! A hash grid over points: k nearest neighbours and "any point within r".
//!
//! Query results are sorted by (distance, index), so they never depend on
//! the hash map's iteration order. The map hashes with rustc's Fx hash:
//! the cell lookups of the neighbour queries were a twentieth of a demo's
//! CPU time with the standard library's SipHash, which defends against
//! adversarial keys that grid cells are not.

use nalgebra::Point3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

type Key = [i64; 3];

/// Uniform hash grid over a point set, sized from the points' spread.
#[derive(Debug, Clone)]
pub struct PointGrid {
    points: Vec<Point3<f64>>,
    cell: f64,
    cells: FxHashMap<Key, Vec<u32>>,
    /// Smallest and largest occupied cell index per axis.
    lo: Key,
    hi: Key,
}

impl PointGrid {
    /// Indexes `points` (finite, at least one). The cell is about twice the
    /// spacing of points spread over a surface filling their bounding box's
    /// largest face.
    pub fn new(points: &[Point3<f64>]) -> Self {
        let mut lo = Point3::from([f64::INFINITY; 3]);
        let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let e = hi - lo;
        let area = (e.x * e.y).max(e.y * e.z).max(e.x * e.z);
        let extent = e.max();
        let n = points.len().max(1) as f64;
        let mut cell = 2.0 * (area / n).sqrt();
        if !(cell > extent * 1e-4) {
            cell = (extent * 1e-2).max(1e-9);
        }
        Self::with_cell(points, cell)
    }

    /// Indexes `points` with cells of side `cell` (> 0).
    pub fn with_cell(points: &[Point3<f64>], cell: f64) -> Self {
        let mut cells: FxHashMap<Key, Vec<u32>> = FxHashMap::default();
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for (i, p) in points.iter().enumerate() {
            let k = key(p, cell);
            for a in 0..3 {
                lo[a] = lo[a].min(k[a]);
                hi[a] = hi[a].max(k[a]);
            }
            cells.entry(k).or_default().push(i as u32);
        }
        PointGrid {
            points: points.to_vec(),
            cell,
            cells,
            lo,
            hi,
        }
    }

    /// Largest ring around cell `c` that holds an occupied cell.
    fn max_ring(&self, c: Key) -> i64 {
        (0..3)
            .map(|a| (c[a] - self.lo[a]).abs().max((self.hi[a] - c[a]).abs()))
            .max()
            .unwrap_or(0)
    }

    /// The indexed points.
    pub fn points(&self) -> &[Point3<f64>] {
        &self.points
    }

    /// Indices of the `k` points nearest to `p` (fewer if there are fewer),
    /// nearest first, ties by index.
    pub fn k_nearest(&self, p: &Point3<f64>, k: usize) -> Vec<u32> {
        let c = key(p, self.cell);
        let mut found: Vec<(f64, u32)> = Vec::new();
        for r in 0..=self.max_ring(c) {
            self.ring(c, r, |i| {
                found.push(((self.points[i as usize] - p).norm_squared(), i));
            });
            if found.len() >= k {
                found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                // Unseen points are farther than r cells from p.
                let reach = r as f64 * self.cell;
                if found[k - 1].0 <= reach * reach {
                    break;
                }
            }
        }
        found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        found.truncate(k);
        found.into_iter().map(|(_, i)| i).collect()
    }

    /// Whether some point lies within `radius` of `p`.
    pub fn any_within(&self, p: &Point3<f64>, radius: f64) -> bool {
        let c = key(p, self.cell);
        let r2 = radius * radius;
        let rings = (radius / self.cell).ceil();
        if !(rings < self.max_ring(c) as f64) {
            return self.points.iter().any(|q| (q - p).norm_squared() <= r2);
        }
        let rings = rings as i64;
        let mut hit = false;
        for r in 0..=rings {
            self.ring(c, r, |i| {
                hit |= (self.points[i as usize] - p).norm_squared() <= r2;
            });
            if hit {
                return true;
            }
        }
        false
    }

    /// Distance from `p` to the nearest point (infinite for an empty grid).
    pub fn nearest_distance(&self, p: &Point3<f64>) -> f64 {
        self.k_nearest(p, 1)
            .first()
            .map_or(f64::INFINITY, |&i| (self.points[i as usize] - p).norm())
    }

    /// Median over points of the distance to the nearest other point
    /// (coincident points count as 0).
    pub fn median_spacing(&self) -> f64 {
        let mut d: Vec<f64> = (0..self.points.len())
            .into_par_iter()
            .map(|i| {
                let p = &self.points[i];
                self.k_nearest(p, 2)
                    .into_iter()
                    .find(|&j| j as usize != i)
                    .map_or(0.0, |j| (self.points[j as usize] - p).norm())
            })
            .collect();
        if d.is_empty() {
            return 0.0;
        }
        d.sort_by(f64::total_cmp);
        d[d.len() / 2]
    }

    /// Calls `f` with every point in the cells at Chebyshev distance `r`
    /// from cell `c`.
    fn ring(&self, c: Key, r: i64, mut f: impl FnMut(u32)) {
        for dx in -r..=r {
            for dy in -r..=r {
                let edge = dx.abs() == r || dy.abs() == r;
                let mut visit = |dz: i64| {
                    if let Some(ids) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        for &i in ids {
                            f(i);
                        }
                    }
                };
                if edge {
                    (-r..=r).for_each(&mut visit);
                } else {
                    visit(-r);
                    if r > 0 {
                        visit(r);
                    }
                }
            }
        }
    }
}

fn key(p: &Point3<f64>, cell: f64) -> Key {
    [
        (p.x / cell).floor() as i64,
        (p.y / cell).floor() as i64,
        (p.z / cell).floor() as i64,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn k_nearest_matches_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let pts: Vec<Point3<f64>> = (0..500)
            .map(|_| {
                Point3::new(
                    rng.random_range(-10.0..10.0),
                    rng.random_range(-10.0..10.0),
                    rng.random_range(-0.5..0.5),
                )
            })
            .collect();
        let grid = PointGrid::new(&pts);
        for q in pts
            .iter()
            .take(50)
            .chain([Point3::new(40.0, 3.0, -7.0)].iter())
        {
            let mut brute: Vec<(f64, u32)> = pts
                .iter()
                .enumerate()
                .map(|(i, p)| ((p - q).norm_squared(), i as u32))
                .collect();
            brute.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let want: Vec<u32> = brute.iter().take(9).map(|e| e.1).collect();
            assert_eq!(grid.k_nearest(q, 9), want);
            let d = brute[0].0.sqrt();
            assert!(grid.any_within(q, d * 1.0001 + 1e-12));
            assert!(d == 0.0 || !grid.any_within(q, d * 0.999));
        }
    }
}
