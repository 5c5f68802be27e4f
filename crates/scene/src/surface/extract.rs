//! The Poisson solve, a deterministic marching cubes near the samples, and
//! trimming.
//!
//! The crate's own extraction visits cells in hash-map order (the output
//! order changes from run to run) and follows the closed isosurface far from
//! the data. Ours visits cells in waves of sorted keys, only within the trim
//! distance of a sample, so it is reproducible and spends no time on faces
//! trimming would drop.

use std::panic::{catch_unwind, AssertUnwindSafe};

use nalgebra::{Point3, Vector3};
use nalgebra033 as na033;
use poisson_reconstruction::marching_cubes::march_cube;
use poisson_reconstruction::PoissonReconstruction;
use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};

use super::grid::PointGrid;
use super::{SurfaceParams, SurfaceSolver};
use crate::error::{Result, SceneError};
use crate::mesh::Mesh;

type Key = [i64; 3];

/// The implicit function whose zero set is the surface.
enum Implicit {
    /// Screened Poisson indicator minus its iso-value (the crate).
    Poisson(Box<PoissonReconstruction>),
    /// Implicit moving least squares: the Gaussian-weighted mean of the
    /// signed distances to the tangent planes of the `k` nearest samples.
    Imls {
        grid: PointGrid,
        normals: Vec<Vector3<f64>>,
        k: usize,
        /// Gaussian bandwidth, metres.
        h: f64,
    },
}

impl Implicit {
    fn eval(&self, p: &Point3<f64>) -> f64 {
        match self {
            Implicit::Poisson(poisson) => poisson.eval(&to033(p)),
            Implicit::Imls {
                grid,
                normals,
                k,
                h,
            } => {
                let pts = grid.points();
                let inv = 1.0 / (h * h);
                let (mut num, mut den) = (0.0, 0.0);
                for i in grid.k_nearest(p, *k) {
                    let d = p - pts[i as usize];
                    let w = (-d.norm_squared() * inv).exp();
                    num += w * d.dot(&normals[i as usize]);
                    den += w;
                }
                if den > 1e-300 {
                    num / den
                } else {
                    // Far from every sample: outside.
                    f64::INFINITY
                }
            }
        }
    }
}

/// The implicit function and the grid it is extracted on.
pub(super) struct Field {
    implicit: Implicit,
    /// Octree depth used.
    pub(super) depth: usize,
    /// Side of the finest cell, metres.
    pub(super) leaf: f64,
    /// Corner of cell (0, 0, 0).
    origin: Point3<f64>,
    /// Cells per axis inside the function's domain.
    n_cells: Key,
}

fn to033(p: &Point3<f64>) -> na033::Point3<f64> {
    na033::Point3::new(p.x, p.y, p.z)
}

/// The implicit function of `params.solver` on oriented samples.
pub(super) fn solve(
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    grid: &PointGrid,
    spacing: f64,
    params: &SurfaceParams,
) -> Result<Field> {
    match params.solver {
        SurfaceSolver::Poisson => solve_poisson(positions, normals, params),
        SurfaceSolver::Imls => Ok(imls(positions, normals, grid, spacing, params)),
    }
}

fn bounds(positions: &[Point3<f64>]) -> (Point3<f64>, Point3<f64>) {
    let mut lo = Point3::from([f64::INFINITY; 3]);
    let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
    for p in positions {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (lo, hi)
}

fn imls(
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    grid: &PointGrid,
    spacing: f64,
    params: &SurfaceParams,
) -> Field {
    let (lo, hi) = bounds(positions);
    let leaf = params.cell_size;
    let origin = lo - Vector3::repeat(leaf);
    let span = (hi + Vector3::repeat(2.0 * leaf)) - origin;
    let n_cells = [0, 1, 2].map(|a| (span[a] / leaf).ceil() as i64);
    let h = (params.smoothing * spacing).max(0.5 * leaf);
    Field {
        implicit: Implicit::Imls {
            grid: grid.clone(),
            normals: normals.to_vec(),
            k: params.field_neighbours,
            h,
        },
        depth: 0,
        leaf,
        origin,
        n_cells,
    }
}

/// Solves screened Poisson on oriented samples.
fn solve_poisson(
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    params: &SurfaceParams,
) -> Result<Field> {
    let (lo, hi) = bounds(positions);
    let extent = (hi - lo).max();
    let wanted = (extent / params.cell_size).log2().ceil().max(1.0) as usize;
    let depth = wanted.clamp(params.density_levels + 1, params.max_depth);
    // The crate's leaf and grid origin (its root box loosened by one leaf).
    let leaf = extent / f64::powi(2.0, depth as i32);
    let origin = lo - Vector3::repeat(leaf);
    let span = (hi + Vector3::repeat(leaf)) - origin;
    let n_cells = [0, 1, 2].map(|a| (span[a] / leaf).floor() as i64);
    let pts: Vec<na033::Point3<f64>> = positions.iter().map(to033).collect();
    let nrm: Vec<na033::Vector3<f64>> = normals
        .iter()
        .map(|n| na033::Vector3::new(n.x, n.y, n.z))
        .collect();
    let poisson = catch_unwind(AssertUnwindSafe(|| {
        PoissonReconstruction::from_points_and_normals(
            &pts,
            &nrm,
            params.screening,
            depth - params.density_levels,
            depth,
            params.solver_iterations,
        )
    }))
    .map_err(|_| {
        SceneError::Surface(format!(
            "the Poisson solver failed on {} samples (depth {depth})",
            positions.len()
        ))
    })?;
    Ok(Field {
        implicit: Implicit::Poisson(Box::new(poisson)),
        depth,
        leaf,
        origin,
        n_cells,
    })
}

impl Field {
    fn corner(&self, k: Key) -> Point3<f64> {
        self.origin + Vector3::new(k[0] as f64, k[1] as f64, k[2] as f64) * self.leaf
    }

    fn cell_of(&self, p: &Point3<f64>) -> Key {
        let d = (p - self.origin) / self.leaf;
        [d.x.floor() as i64, d.y.floor() as i64, d.z.floor() as i64]
    }

    fn in_domain(&self, c: Key) -> bool {
        (0..3).all(|a| c[a] >= 0 && c[a] < self.n_cells[a])
    }
}

/// Corner offsets in the crate's marching-cubes order (v0..v7).
const CORNERS: [Key; 8] = [
    [0, 0, 0],
    [1, 0, 0],
    [1, 1, 0],
    [0, 1, 0],
    [0, 0, 1],
    [1, 0, 1],
    [1, 1, 1],
    [0, 1, 1],
];

fn add(a: Key, b: Key) -> Key {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Marching cubes over the cells reachable along the isosurface from the
/// samples' cells, never farther than `reach` from a sample. Vertices are
/// welded; faces keep the crate's winding (fixed by [`trim`]).
pub(super) fn extract(field: &Field, positions: &[Point3<f64>], reach: f64) -> Mesh {
    let near = PointGrid::with_cell(positions, reach.max(field.leaf));
    let mut values: FxHashMap<Key, f64> = FxHashMap::default();
    let mut visited: FxHashSet<Key> = FxHashSet::default();
    let mut crossing: Vec<Key> = Vec::new();
    let mut wave: Vec<Key> = positions
        .iter()
        .map(|p| field.cell_of(p))
        .filter(|&c| field.in_domain(c))
        .collect();
    wave.sort_unstable();
    wave.dedup();
    // Cells in a wave are new; their corners are evaluated once.
    let half_diag = 0.5 * 3f64.sqrt() * field.leaf;
    while !wave.is_empty() {
        visited.extend(wave.iter().copied());
        let mut corners: Vec<Key> = wave
            .iter()
            .flat_map(|&c| CORNERS.map(|o| add(c, o)))
            .filter(|k| !values.contains_key(k))
            .collect();
        corners.sort_unstable();
        corners.dedup();
        let vals: Vec<f64> = corners
            .par_iter()
            .map(|&k| field.implicit.eval(&field.corner(k)))
            .collect();
        values.extend(corners.into_iter().zip(vals));
        let crosses: Vec<Key> = wave
            .iter()
            .copied()
            .filter(|&c| {
                let v = CORNERS.map(|o| values[&add(c, o)]);
                v.iter().any(|&x| x <= 0.0) && v.iter().any(|&x| x > 0.0)
            })
            .collect();
        let mut next: Vec<Key> = crosses
            .iter()
            .flat_map(|&c| (0..27).map(move |i| add(c, [i % 3 - 1, (i / 3) % 3 - 1, i / 9 - 1])))
            .filter(|c| field.in_domain(*c) && !visited.contains(c))
            .collect();
        next.sort_unstable();
        next.dedup();
        let keep: Vec<bool> = next
            .par_iter()
            .map(|&c| {
                let centre = field.corner(c) + Vector3::repeat(0.5 * field.leaf);
                near.any_within(&centre, reach + half_diag)
            })
            .collect();
        crossing.extend(crosses);
        wave = next
            .into_iter()
            .zip(keep)
            .filter_map(|(c, k)| k.then_some(c))
            .collect();
    }
    crossing.sort_unstable();
    let soups: Vec<Vec<na033::Point3<f64>>> = crossing
        .par_iter()
        .map(|&c| {
            let v = CORNERS.map(|o| values[&add(c, o)]);
            let mut out = Vec::new();
            march_cube(
                &to033(&field.corner(c)),
                &to033(&field.corner(add(c, [1, 1, 1]))),
                &v,
                0.0,
                &mut out,
            );
            out
        })
        .collect();
    weld(soups.iter().flatten(), field)
}

/// Indexed mesh from a triangle soup: vertices equal to 2^-20 of a leaf
/// are one (adjacent cells compute a shared edge's vertex to within
/// rounding).
fn weld<'a>(soup: impl Iterator<Item = &'a na033::Point3<f64>>, field: &Field) -> Mesh {
    let scale = f64::powi(2.0, 20) / field.leaf;
    let mut index: FxHashMap<Key, u32> = FxHashMap::default();
    let mut vertices = Vec::new();
    let mut corner = Vec::with_capacity(3);
    let mut faces = Vec::new();
    for p in soup {
        let p = Point3::new(p.x, p.y, p.z);
        let d = (p - field.origin) * scale;
        let k = [d.x.round() as i64, d.y.round() as i64, d.z.round() as i64];
        let id = *index.entry(k).or_insert_with(|| {
            vertices.push(p);
            (vertices.len() - 1) as u32
        });
        corner.push(id);
        if corner.len() == 3 {
            faces.push([corner[0], corner[1], corner[2]]);
            corner.clear();
        }
    }
    Mesh {
        vertices,
        faces,
        materials: None,
    }
}

/// Drops faces whose centroid is farther than `trim` from every sample, and
/// orients the rest like the samples' normals (the winding that agrees with
/// the nearest samples' normals over most of the area wins).
pub(super) fn trim(mesh: &Mesh, grid: &PointGrid, normals: &[Vector3<f64>], trim: f64) -> Mesh {
    let verdicts: Vec<Option<f64>> = (0..mesh.faces.len())
        .into_par_iter()
        .map(|f| {
            let c = mesh.face_centroid(f);
            let nearest = grid.k_nearest(&c, 1);
            let &i = nearest.first()?;
            if (grid.points()[i as usize] - c).norm() > trim {
                return None;
            }
            let [a, b, c] = mesh.triangle(f);
            Some((b - a).cross(&(c - a)).dot(&normals[i as usize]))
        })
        .collect();
    let agreement: f64 = verdicts.iter().flatten().sum();
    let faces: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .zip(&verdicts)
        .filter(|(_, v)| v.is_some())
        .map(|(&[a, b, c], _)| {
            if agreement >= 0.0 {
                [a, b, c]
            } else {
                [a, c, b]
            }
        })
        .collect();
    Mesh {
        vertices: mesh.vertices.clone(),
        faces,
        materials: None,
    }
    .cleaned()
    .0
}

/// Drops connected pieces (sharing vertices) of fewer than `min_faces`
/// faces, and unused vertices.
pub(super) fn drop_small_pieces(mesh: Mesh, min_faces: usize) -> Mesh {
    let n = mesh.vertices.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for f in &mesh.faces {
        let a = find(&mut parent, f[0]);
        for &v in &f[1..] {
            let b = find(&mut parent, v);
            if a != b {
                parent[b as usize] = a;
            }
        }
    }
    let mut count = vec![0usize; n];
    let roots: Vec<u32> = mesh.faces.iter().map(|f| find(&mut parent, f[0])).collect();
    for &r in &roots {
        count[r as usize] += 1;
    }
    let faces: Vec<[u32; 3]> = mesh
        .faces
        .iter()
        .zip(&roots)
        .filter(|(_, &r)| count[r as usize] >= min_faces)
        .map(|(f, _)| *f)
        .collect();
    Mesh {
        vertices: mesh.vertices,
        faces,
        materials: None,
    }
    .cleaned()
    .0
}

/// Union-find root of `v`, halving paths.
fn find(parent: &mut [u32], mut v: u32) -> u32 {
    while parent[v as usize] != v {
        parent[v as usize] = parent[parent[v as usize] as usize];
        v = parent[v as usize];
    }
    v
}
