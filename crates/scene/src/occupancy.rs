//! Free-space knowledge: a voxel map carved by the rays from cameras to the
//! points they observed, as exploration planners keep it (OctoMap,
//! nbvplanner), and the distance from any position to space never observed.
//!
//! Why: a mesh holds only the surfaces that were reconstructed. A branch no
//! image has seen is not in it, and a planner that treats every unobserved
//! volume as free can fly into it. Space is known to be free only where a
//! camera looked through it at something behind. Every voxel starts
//! [`Voxel::Unknown`]; each observation ray (camera centre to observed
//! point) marks the voxels it crosses [`Voxel::Free`] and the voxel of the
//! point [`Voxel::Occupied`]. Occupied marks win over free ones whatever the
//! order of the rays, so the map is a pure function of the set of rays.
//!
//! The planner asks one question: how far is a position from unknown space
//! ([`FreeSpace::clearance`])? A position (or a segment) is safe in
//! observed-free space when no unknown voxel lies within the safety
//! distance; surfaces that were observed (occupied voxels) are the mesh
//! clearance's business. The distances come from an exact Euclidean distance
//! transform (Felzenszwalb & Huttenlocher 2012) over voxel centres, made
//! conservative by one voxel diagonal.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use crate::camera::Camera;
use crate::error::{Result, SceneError};
use crate::mesh::Aabb;

/// Most voxels a map may hold (a 1 m map of 1 km x 1 km x 200 m).
pub const MAX_VOXELS: usize = 200_000_000;

/// What is known about one voxel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Voxel {
    /// No ray crossed it.
    Unknown = 0,
    /// A ray crossed it on its way to an observed point.
    Free = 1,
    /// It holds an observed point.
    Occupied = 2,
}

/// A dense voxel grid over a box.
#[derive(Debug, Clone)]
pub struct OccupancyMap {
    origin: Point3<f64>,
    voxel: f64,
    dims: [usize; 3],
    cells: Vec<Voxel>,
}

impl OccupancyMap {
    /// An all-unknown map covering `bounds` with cubes of `voxel_m`.
    pub fn new(bounds: &Aabb, voxel_m: f64) -> Result<Self> {
        let finite = bounds
            .min
            .iter()
            .chain(bounds.max.iter())
            .all(|v| v.is_finite());
        if !(voxel_m.is_finite() && voxel_m > 0.0) {
            return Err(SceneError::InvalidArgument(format!(
                "occupancy map: voxel size must be a positive number of metres, not {voxel_m}"
            )));
        }
        if !finite || (0..3).any(|i| bounds.max[i] < bounds.min[i]) {
            return Err(SceneError::InvalidArgument(format!(
                "occupancy map: the box {:?}..{:?} is empty or not finite",
                <[f64; 3]>::from(bounds.min),
                <[f64; 3]>::from(bounds.max)
            )));
        }
        let extent = bounds.max - bounds.min;
        let dims = [0, 1, 2].map(|i| ((extent[i] / voxel_m).ceil() as usize).max(1));
        let n = dims[0]
            .checked_mul(dims[1])
            .and_then(|v| v.checked_mul(dims[2]))
            .filter(|&n| n <= MAX_VOXELS)
            .ok_or_else(|| {
                SceneError::InvalidArgument(format!(
                    "occupancy map: {}x{}x{} voxels of {voxel_m} m exceed the limit of {MAX_VOXELS}; \
                     use larger voxels or a smaller flight volume",
                    dims[0], dims[1], dims[2]
                ))
            })?;
        Ok(OccupancyMap {
            origin: bounds.min,
            voxel: voxel_m,
            dims,
            cells: vec![Voxel::Unknown; n],
        })
    }

    /// Edge length of a voxel, metres.
    pub fn voxel_size(&self) -> f64 {
        self.voxel
    }

    /// Voxels along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    fn index(&self, v: [usize; 3]) -> usize {
        v[0] + self.dims[0] * (v[1] + self.dims[1] * v[2])
    }

    /// The voxel holding `p`, if inside the map.
    fn voxel_of(&self, p: &Point3<f64>) -> Option<[usize; 3]> {
        let mut v = [0; 3];
        for i in 0..3 {
            let c = ((p[i] - self.origin[i]) / self.voxel).floor();
            if !(c >= 0.0 && c < self.dims[i] as f64) {
                return None;
            }
            v[i] = c as usize;
        }
        Some(v)
    }

    /// What is known at `p` (unknown outside the map).
    pub fn state(&self, p: &Point3<f64>) -> Voxel {
        self.voxel_of(p)
            .map_or(Voxel::Unknown, |v| self.cells[self.index(v)])
    }

    /// Voxels crossed by the segment `a`-`b` before the voxel of `b`, in
    /// order (Amanatides & Woo 1987), clipped to the map.
    fn crossed(&self, a: &Point3<f64>, b: &Point3<f64>) -> Vec<usize> {
        let mut out = Vec::new();
        let d = b - a;
        let len = d.norm();
        if !(len.is_finite() && len > 0.0) {
            return out;
        }
        let dir = d / len;
        // Clip the segment to the map box (slab test), so rays from cameras
        // outside the map still carve the part inside.
        let (mut t0, mut t1) = (0.0_f64, len);
        for i in 0..3 {
            let lo = self.origin[i];
            let hi = lo + self.dims[i] as f64 * self.voxel;
            if dir[i].abs() < 1e-12 {
                if a[i] < lo || a[i] >= hi {
                    return out;
                }
            } else {
                let (ta, tb) = ((lo - a[i]) / dir[i], (hi - a[i]) / dir[i]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if t0 >= t1 {
            return out;
        }
        let end = self.voxel_of(b);
        // Start just inside the box.
        let start = a + dir * (t0 + 1e-9 * self.voxel.max(1.0));
        let Some(mut v) = self.voxel_of(&start) else {
            return out;
        };
        let mut step = [0i64; 3];
        let mut t_max = [f64::INFINITY; 3];
        let mut t_delta = [f64::INFINITY; 3];
        for i in 0..3 {
            if dir[i] > 1e-12 {
                step[i] = 1;
                let next = self.origin[i] + (v[i] + 1) as f64 * self.voxel;
                t_max[i] = (next - a[i]) / dir[i];
                t_delta[i] = self.voxel / dir[i];
            } else if dir[i] < -1e-12 {
                step[i] = -1;
                let next = self.origin[i] + v[i] as f64 * self.voxel;
                t_max[i] = (next - a[i]) / dir[i];
                t_delta[i] = -self.voxel / dir[i];
            }
        }
        loop {
            if Some(v) == end {
                break;
            }
            out.push(self.index(v));
            let axis = (0..3)
                .min_by(|&i, &j| t_max[i].total_cmp(&t_max[j]))
                .unwrap_or(0);
            if t_max[axis] > t1 {
                break;
            }
            let next = v[axis] as i64 + step[axis];
            if next < 0 || next >= self.dims[axis] as i64 {
                break;
            }
            v[axis] = next as usize;
            t_max[axis] += t_delta[axis];
        }
        out
    }

    /// Carves every observation ray `(camera centre, observed point)`:
    /// the voxels before the point become free, the point's voxel occupied.
    /// Rays with a non-finite end are skipped.
    pub fn carve(&mut self, rays: &[(Point3<f64>, Point3<f64>)]) {
        let finite = |p: &Point3<f64>| p.iter().all(|v| v.is_finite());
        let rays: Vec<_> = rays
            .iter()
            .filter(|(a, b)| finite(a) && finite(b))
            .collect();
        let free: Vec<Vec<usize>> = rays.par_iter().map(|(a, b)| self.crossed(a, b)).collect();
        for i in free.into_iter().flatten() {
            if self.cells[i] == Voxel::Unknown {
                self.cells[i] = Voxel::Free;
            }
        }
        for (_, b) in rays {
            if let Some(v) = self.voxel_of(b) {
                let i = self.index(v);
                self.cells[i] = Voxel::Occupied;
            }
        }
    }

    /// Marks free the unknown voxels lying wholly at or above `z` in every
    /// column that at least `min_views` of `cameras` look at just above `z`:
    /// the operator's statement that nothing floats above the highest
    /// observed point (no wires, no overhangs), so the airspace over the
    /// observed tops may be crossed.
    ///
    /// Why only looked-at columns: an object standing in a column and
    /// taller than `z` fills the column's lowest voxel wholly above `z`. If
    /// that voxel lies inside the frustum of a camera whose centre is not
    /// below `z`, the line of sight between them stays above `z`, where
    /// nothing was observed, so the object would have been pictured (and
    /// with `min_views` images, triangulated) and raised the observed top.
    /// Freeing the whole map instead let a tree taller than anything
    /// observed, in ground no camera pictured, count as free airspace
    /// (site 1170, docs/campaign-findings.md). Columns are taken from the
    /// frusta rather than from the observation rays, which are too sparse
    /// at the edge of the first flight. A voxel counts as pictured when its
    /// whole bounding sphere is inside the frustum.
    pub fn mark_free_above(&mut self, z: f64, cameras: &[Camera], min_views: usize) {
        let [nx, ny, nz] = self.dims;
        let k0 = ((z - self.origin.z) / self.voxel).ceil().max(0.0) as usize;
        if k0 >= nz || !z.is_finite() {
            return;
        }
        let zc = self.origin.z + (k0 as f64 + 0.5) * self.voxel;
        let r = self.voxel * 3f64.sqrt() / 2.0;
        let frusta: Vec<(Point3<f64>, [Vector3<f64>; 4])> = cameras
            .iter()
            .filter(|c| c.center().z >= z)
            .filter_map(|c| Some((c.center(), frustum_planes(c)?)))
            .collect();
        let (ox, oy, v) = (self.origin.x, self.origin.y, self.voxel);
        let mut views = vec![0u16; nx * ny];
        views.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            let y = oy + (j as f64 + 0.5) * v;
            for (c, planes) in &frusta {
                // Each side plane n.(p - c) >= r bounds x on this row.
                let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
                for n in planes {
                    let s = n.y * (y - c.y) + n.z * (zc - c.z) - r;
                    if n.x.abs() < 1e-12 {
                        if s < 0.0 {
                            hi = f64::NEG_INFINITY;
                        }
                    } else if n.x > 0.0 {
                        lo = lo.max(c.x - s / n.x);
                    } else {
                        hi = hi.min(c.x - s / n.x);
                    }
                }
                let first = ((lo - ox) / v - 0.5).ceil().max(0.0);
                let last = ((hi - ox) / v - 0.5).floor().min(nx as f64 - 1.0);
                if first <= last {
                    for w in &mut row[first as usize..=last as usize] {
                        *w = w.saturating_add(1);
                    }
                }
            }
        });
        let looked: Vec<bool> = views.iter().map(|&w| usize::from(w) >= min_views).collect();
        for layer in self.cells[k0 * nx * ny..].chunks_mut(nx * ny) {
            for (c, &seen) in layer.iter_mut().zip(&looked) {
                if seen && *c == Voxel::Unknown {
                    *c = Voxel::Free;
                }
            }
        }
    }

    /// Counts of unknown, free and occupied voxels.
    pub fn counts(&self) -> [usize; 3] {
        let mut n = [0; 3];
        for &c in &self.cells {
            n[c as usize] += 1;
        }
        n
    }

    /// The distance queries of this map.
    pub fn free_space(self) -> FreeSpace {
        let dist = distance_to_unknown(&self.cells, self.dims, self.voxel);
        FreeSpace { map: self, dist }
    }
}

/// Unit normals of the four side planes of `cam`'s frustum, pointing
/// inwards: a point `p` is pictured when `n.(p - centre) >= 0` for all four.
/// `None` for a camera whose corner rays are degenerate.
fn frustum_planes(cam: &Camera) -> Option<[Vector3<f64>; 4]> {
    let k = &cam.intrinsics;
    let (w, h) = (f64::from(k.width), f64::from(k.height));
    let d = [(0.0, 0.0), (w, 0.0), (w, h), (0.0, h)]
        .map(|(x, y)| cam.ray(&nalgebra::Point2::new(x, y)).1);
    let axis = cam.axis();
    let mut out = [Vector3::zeros(); 4];
    for i in 0..4 {
        let n = d[i].cross(&d[(i + 1) % 4]);
        let n = n.try_normalize(1e-12)?;
        out[i] = if n.dot(&axis) >= 0.0 { n } else { -n };
    }
    Some(out)
}

/// Distance queries to unknown space (see the module docs).
#[derive(Debug, Clone)]
pub struct FreeSpace {
    map: OccupancyMap,
    /// Per voxel, distance from its centre to the nearest unknown voxel's
    /// centre, metres (infinite when nothing is unknown).
    dist: Vec<f32>,
}

impl FreeSpace {
    /// The carved map.
    pub fn map(&self) -> &OccupancyMap {
        &self.map
    }

    /// A lower bound of the distance from `p` to unknown space (any point
    /// of an unknown voxel, or outside the map), metres; 0 when `p` itself
    /// is in unknown space.
    pub fn clearance(&self, p: &Point3<f64>) -> f64 {
        let m = &self.map;
        let Some(v) = m.voxel_of(p) else {
            return 0.0;
        };
        if m.cells[m.index(v)] == Voxel::Unknown {
            return 0.0;
        }
        // Centre-to-centre distance less half a diagonal at each end.
        let inner = f64::from(self.dist[m.index(v)]) - m.voxel * 3f64.sqrt();
        let mut to_edge = f64::INFINITY;
        for i in 0..3 {
            let lo = m.origin[i];
            let hi = lo + m.dims[i] as f64 * m.voxel;
            to_edge = to_edge.min(p[i] - lo).min(hi - p[i]);
        }
        inner.min(to_edge).max(0.0)
    }

    /// Whether no unknown space lies within `radius` of `p`.
    pub fn point_is_clear(&self, p: &Point3<f64>, radius: f64) -> bool {
        self.clearance(p) >= radius
    }

    /// Whether no unknown space lies within `radius` of any point of the
    /// segment `a`-`b`: samples every half voxel, each asked for half a
    /// step more.
    pub fn segment_is_clear(&self, a: &Point3<f64>, b: &Point3<f64>, radius: f64) -> bool {
        let (step, samples) = self.samples(a, b);
        samples
            .into_iter()
            .all(|p| self.point_is_clear(&p, radius + 0.5 * step))
    }

    /// The leg of a vehicle standing at `a` to `b`: as
    /// [`FreeSpace::segment_is_clear`], except that while the leg is not
    /// yet `radius` clear it may stay as close to unknown space as the
    /// vehicle already is (never closer), provided `a` is in known space.
    /// Once clear, the leg stays clear.
    ///
    /// Why: a camera pictures the ground around it, so the last position of
    /// a first flight lies at the edge of what it pictured, closer to
    /// unknown space than the safety distance; refusing every leg out of
    /// there refuses every plan (README's manual loop), while leaving by a
    /// leg that gets no closer to unknown space adds no risk the flight did
    /// not already take. "As close" compares the distances of voxel
    /// centres to unknown voxel centres, so the leg may come up to one and
    /// a half voxel diagonals closer than the vehicle.
    pub fn leg_is_clear(&self, a: &Point3<f64>, b: &Point3<f64>, radius: f64) -> bool {
        let (step, samples) = self.samples(a, b);
        let Some(start) = self.centre_distance(a) else {
            return false;
        };
        let mut clear = false;
        samples.into_iter().all(|p| {
            if self.point_is_clear(&p, radius + 0.5 * step) {
                clear = true;
                true
            } else {
                !clear && self.centre_distance(&p).is_some_and(|d| d >= start)
            }
        })
    }

    /// Points every half voxel along `a`-`b`, ends included, and the step.
    fn samples(&self, a: &Point3<f64>, b: &Point3<f64>) -> (f64, Vec<Point3<f64>>) {
        let d: Vector3<f64> = b - a;
        let step = 0.5 * self.map.voxel;
        let n = (d.norm() / step).ceil().max(1.0) as usize;
        let points = (0..=n).map(|i| a + d * (i as f64 / n as f64)).collect();
        (step, points)
    }

    /// Distance from the centre of `p`'s voxel to the nearest unknown voxel
    /// centre or the map's edge; `None` when `p` is in unknown space.
    fn centre_distance(&self, p: &Point3<f64>) -> Option<f64> {
        let m = &self.map;
        let v = m.voxel_of(p)?;
        let i = m.index(v);
        if m.cells[i] == Voxel::Unknown {
            return None;
        }
        let to_edge = (0..3)
            .map(|k| (v[k] as f64 + 0.5).min(m.dims[k] as f64 - v[k] as f64 - 0.5) * m.voxel)
            .fold(f64::INFINITY, f64::min);
        Some(f64::from(self.dist[i]).min(to_edge))
    }
}

/// Exact Euclidean distance from every voxel centre to the nearest unknown
/// voxel centre: three separable passes of the 1D squared distance
/// transform (lower envelope of parabolas), lines in parallel.
fn distance_to_unknown(cells: &[Voxel], dims: [usize; 3], voxel: f64) -> Vec<f32> {
    let mut sq: Vec<f64> = cells
        .iter()
        .map(|&c| {
            if c == Voxel::Unknown {
                0.0
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let [nx, ny, nz] = dims;
    // x: lines are contiguous.
    sq.par_chunks_mut(nx).for_each(edt_1d);
    // y and z: gather each line, transform, scatter back.
    for (len, stride) in [(ny, nx), (nz, nx * ny)] {
        let starts: Vec<usize> = (0..nx * ny * nz)
            .filter(|&i| (i / stride) % len == 0)
            .collect();
        let lines: Vec<(usize, Vec<f64>)> = starts
            .par_iter()
            .map(|&s| {
                let mut line: Vec<f64> = (0..len).map(|k| sq[s + k * stride]).collect();
                edt_1d(&mut line);
                (s, line)
            })
            .collect();
        for (s, line) in lines {
            for (k, v) in line.into_iter().enumerate() {
                sq[s + k * stride] = v;
            }
        }
    }
    sq.into_iter().map(|d| (d.sqrt() * voxel) as f32).collect()
}

/// In place: `f[q] <- min_p (q - p)^2 + f[p]` (Felzenszwalb & Huttenlocher).
fn edt_1d(f: &mut [f64]) {
    let n = f.len();
    let src: Vec<f64> = f.to_vec();
    // Parabolas of the lower envelope (their apexes) and their boundaries.
    let mut apex: Vec<usize> = Vec::with_capacity(n);
    let mut from: Vec<f64> = Vec::with_capacity(n + 1);
    for q in 0..n {
        if !src[q].is_finite() {
            continue;
        }
        loop {
            let Some(&p) = apex.last() else {
                apex.push(q);
                from.push(f64::NEG_INFINITY);
                break;
            };
            let (qf, pf) = (q as f64, p as f64);
            let s = ((src[q] + qf * qf) - (src[p] + pf * pf)) / (2.0 * (qf - pf));
            if s <= from[from.len() - 1] {
                apex.pop();
                from.pop();
            } else {
                apex.push(q);
                from.push(s);
                break;
            }
        }
    }
    if apex.is_empty() {
        return;
    }
    let mut k = 0;
    for (q, out) in f.iter_mut().enumerate() {
        let qf = q as f64;
        while k + 1 < apex.len() && from[k + 1] < qf {
            k += 1;
        }
        let p = apex[k] as f64;
        *out = (qf - p) * (qf - p) + src[apex[k]];
    }
}

#[cfg(test)]
#[path = "occupancy_tests.rs"]
mod tests;
