//! Ray casting over a mesh with an 8-wide BVH: obvhs builds the tree (CWBVH),
//! `raycast/bvh8.rs` decodes it into float boxes and 4-triangle packets and
//! traverses it (about twice obvhs's own traversal on aerial rays, with the
//! same answers; see that file).
//!
//! Visibility is the hot path of planning and label generation: every
//! "does camera i see triangle t" is a segment test here. [`RayCaster`] builds
//! the BVH once per mesh and answers closest-hit and occlusion queries, single
//! or in parallel batches.
//!
//! obvhs works in `f32`. To keep precision for scenes far from the world
//! origin (COLMAP models often are), the BVH is built in a local frame centred
//! on the mesh bounds; queries go in and results come out in `f64` world
//! coordinates. Within a few hundred metres of that centre, `f32` resolves
//! positions to about 10 µm.

use std::time::Duration;

use glam::Vec3A;
use nalgebra::{Point2, Point3, Vector3};
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

use bvh8::{Bvh8, Bvh8Ray};

use crate::camera::Camera;
use crate::mesh::Mesh;

/// A ray hit, in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction, metres.
    pub t: f64,
    /// Index of the face hit.
    pub face: u32,
    /// Barycentric coordinates of the hit point with respect to the face's
    /// three vertices (sum to 1; computed in `f32`).
    pub bary: [f64; 3],
    /// The hit point.
    pub point: Point3<f64>,
}

/// Relative shortening of an occlusion segment at its far end, so that a
/// target lying exactly on a surface does not occlude itself through `f32`
/// round-off. Callers that test visibility of a surface point should still
/// offset the point along its normal (see [`RayCaster::visible_faces`]).
const SEGMENT_END_TOLERANCE: f64 = 1e-5;

/// Offset of a face centroid along its normal before the occlusion test of
/// [`RayCaster::visible_faces`], in metres (docs/design.md#shared-geometry,
/// visibility of a face).
pub const FACE_VISIBILITY_EPSILON: f64 = 1e-3;

/// obvhs build parameters of the tree (see `RayCaster::new`).
const BVH_BUILD: BvhBuildParams = BvhBuildParams::medium_build();

/// BVH over one mesh, ready for queries. Cheap to share across threads.
pub struct RayCaster {
    /// obvhs's tree, decoded for traversal (see `raycast/bvh8.rs`).
    bvh: Bvh8,
    /// World position of the local frame's origin (the centre of the mesh bounds).
    offset: Vector3<f64>,
    /// Largest side of the mesh bounds (1 for an empty mesh), for ray sort keys.
    extent: f64,
    /// Number of faces of the mesh.
    n_faces: usize,
}

impl RayCaster {
    /// Builds the BVH of `mesh`.
    ///
    /// # Performance
    /// About 120-150 ms for 200k faces on one core (obvhs `medium_build`),
    /// plus a few ms to decode the tree.
    pub fn new(mesh: &Mesh) -> Self {
        let bounds = mesh.bounds();
        let offset = if mesh.vertices.is_empty() {
            Vector3::zeros()
        } else {
            (bounds.min.coords + bounds.max.coords) * 0.5
        };
        let local = |p: &Point3<f64>| {
            let q = p.coords - offset;
            Vec3A::new(q.x as f32, q.y as f32, q.z as f32)
        };
        let build_tris: Vec<Triangle> = (0..mesh.n_faces())
            .map(|f| {
                let [a, b, c] = mesh.triangle(f);
                Triangle {
                    v0: local(&a),
                    v1: local(&b),
                    v2: local(&c),
                }
            })
            .collect();
        let bvh = build_cwbvh_from_tris(&build_tris, BVH_BUILD, &mut Duration::default());
        let extent = bounds.extent().max();
        RayCaster {
            bvh: Bvh8::new(&bvh, &build_tris),
            offset,
            extent: if extent > 0.0 { extent } else { 1.0 },
            n_faces: mesh.n_faces(),
        }
    }

    /// Number of faces of the mesh.
    pub fn n_faces(&self) -> usize {
        self.n_faces
    }

    fn local_ray(&self, origin: &Point3<f64>, dir: &Vector3<f64>, t_max: f64) -> Bvh8Ray {
        let o = origin.coords - self.offset;
        Bvh8Ray::new(
            Vec3A::new(o.x as f32, o.y as f32, o.z as f32),
            // `+ 0.0` turns a negative zero into a positive one: obvhs picks
            // slab planes by the sign bits, and -0.0 made axis-aligned rays
            // miss flat geometry.
            Vec3A::new(dir.x as f32 + 0.0, dir.y as f32 + 0.0, dir.z as f32 + 0.0),
            0.0,
            t_max as f32,
        )
    }

    /// Closest surface hit along the ray from `origin` in unit direction
    /// `dir`, up to distance `t_max` (use `f64::INFINITY` for no limit).
    /// `dir` must be unit length so that `t` is a distance.
    pub fn closest_hit(&self, origin: &Point3<f64>, dir: &Vector3<f64>, t_max: f64) -> Option<Hit> {
        let ray = self.local_ray(origin, dir, t_max);
        Some(world_hit(origin, dir, &self.bvh.closest_hit(&ray)?))
    }

    /// Whether any surface lies on the open segment from `from` to `to`.
    /// A surface exactly at `to` is ignored (see the `f32` note in the module doc).
    pub fn occluded(&self, from: &Point3<f64>, to: &Point3<f64>) -> bool {
        let d = to - from;
        let len = d.norm();
        if !(len > 0.0) {
            return false;
        }
        let ray = self.local_ray(from, &(d / len), len * (1.0 - SEGMENT_END_TOLERANCE));
        self.bvh.any_hit(&ray)
    }

    /// [`RayCaster::closest_hit`] for many rays, in parallel. Each ray is
    /// `(origin, unit direction)`. The answers are those of
    /// [`RayCaster::closest_hit`], bit for bit.
    ///
    /// # Performance
    /// Each thread walks several rays at once, a node of each in turn, so
    /// that their cache misses overlap (see `Bvh8::closest_hits`). Large
    /// batches over a BVH larger than the last-level cache are traced in a
    /// coherent order (rays sorted by direction bin, then by the Morton
    /// code of their origin) so that consecutive rays visit the same BVH
    /// nodes and triangles while they are in cache; the results come back
    /// in input order.
    pub fn closest_hits(
        &self,
        rays: &[(Point3<f64>, Vector3<f64>)],
        t_max: f64,
    ) -> Vec<Option<Hit>> {
        self.trace_coherent(
            rays,
            |(o, d)| (*o, *d),
            |rays| {
                let mut out = vec![None; rays.len()];
                out.par_chunks_mut(TRACE_CHUNK)
                    .zip(rays.par_chunks(TRACE_CHUNK))
                    .for_each(|(out, chunk)| {
                        let local: Vec<Bvh8Ray> = chunk
                            .iter()
                            .map(|(o, d)| self.local_ray(o, d, t_max))
                            .collect();
                        self.bvh.closest_hits(&local, |i, hit| {
                            let (o, d) = &chunk[i];
                            out[i] = hit.map(|h| world_hit(o, d, &h));
                        });
                    });
                out
            },
        )
    }

    /// [`RayCaster::occluded`] for many segments, in parallel (coherent order
    /// as in [`RayCaster::closest_hits`]).
    ///
    /// # Performance
    /// Segments are walked one at a time: walking several at once, as
    /// [`RayCaster::closest_hits`] does, did not make these short,
    /// early-exiting walks measurably faster (docs/performance.md).
    pub fn occluded_batch(&self, segments: &[(Point3<f64>, Point3<f64>)]) -> Vec<bool> {
        self.trace_coherent(
            segments,
            |(a, b)| (*a, b - a),
            |segments| {
                segments
                    .par_iter()
                    .with_min_len(256)
                    .map(|(a, b)| self.occluded(a, b))
                    .collect()
            },
        )
    }

    /// Answers `items` with `query` (which answers a slice of items in
    /// order, in parallel), in the coherent order of the rays `ray_of` gives
    /// where that pays (see [`COHERENT_BVH_BYTES`]); the answers come back
    /// in input order.
    fn trace_coherent<I: Sync + Send + Copy, R: Send + Copy + Default>(
        &self,
        items: &[I],
        ray_of: impl Fn(&I) -> (Point3<f64>, Vector3<f64>) + Sync,
        query: impl Fn(&[I]) -> Vec<R> + Sync,
    ) -> Vec<R> {
        let sort = items.len() >= COHERENT_BATCH && self.bvh.bytes() >= COHERENT_BVH_BYTES;
        self.trace(items, ray_of, query, sort)
    }

    /// [`RayCaster::trace_coherent`], sorting or not as told.
    fn trace<I: Sync + Send + Copy, R: Send + Copy + Default>(
        &self,
        items: &[I],
        ray_of: impl Fn(&I) -> (Point3<f64>, Vector3<f64>) + Sync,
        query: impl Fn(&[I]) -> Vec<R> + Sync,
        sort: bool,
    ) -> Vec<R> {
        if !sort {
            return query(items);
        }
        let mut order: Vec<(u64, u32)> = items
            .par_iter()
            .enumerate()
            .map(|(i, item)| {
                let (o, d) = ray_of(item);
                (self.coherence_key(&o, &d), i as u32)
            })
            .collect();
        order.par_sort_unstable();
        // Gather the items in that order first: a plain gather keeps many
        // cache misses in flight, where a miss at the start of each query
        // would stall it.
        let sorted: Vec<I> = order.par_iter().map(|&(_, i)| items[i as usize]).collect();
        let answers = query(&sorted);
        let mut out = vec![R::default(); items.len()];
        for (&(_, i), a) in order.iter().zip(answers) {
            out[i as usize] = a;
        }
        out
    }

    /// Sort key for ray coherence: 6 bits of direction (4 bins per axis) above
    /// 30 bits of origin Morton code (10 bits per axis over the mesh bounds,
    /// padded by their size on every side). Only the direction matters for
    /// length: a segment's unnormalised direction bins the same.
    fn coherence_key(&self, o: &Point3<f64>, d: &Vector3<f64>) -> u64 {
        let bin = |v: f64, n: f64| (v.clamp(0.0, 0.999_999) * n) as u64;
        let d = d.try_normalize(0.0).unwrap_or_else(Vector3::z);
        let dir = spread_bits(bin(0.5 + 0.5 * d.x, 4.0))
            | spread_bits(bin(0.5 + 0.5 * d.y, 4.0)) << 1
            | spread_bits(bin(0.5 + 0.5 * d.z, 4.0)) << 2;
        let rel = |i: usize| (o[i] - self.offset[i] + 1.5 * self.extent) / (3.0 * self.extent);
        let morton = spread_bits(bin(rel(0), 1024.0))
            | spread_bits(bin(rel(1), 1024.0)) << 1
            | spread_bits(bin(rel(2), 1024.0)) << 2;
        dir << 30 | morton
    }

    /// For each point: inside the camera's image, in front of it, and not
    /// occluded from the camera centre.
    pub fn visible_points(&self, camera: &Camera, points: &[Point3<f64>]) -> Vec<bool> {
        let c = camera.center();
        points
            .par_iter()
            .with_min_len(256)
            .map(|p| camera.in_frustum(p) && !self.occluded(&c, p))
            .collect()
    }

    /// For each face of `mesh` (the mesh this caster was built from, or a
    /// refinement of it with the same surface): visible from `camera` in the
    /// sense of M1 (docs/design.md#shared-geometry) — centroid inside the
    /// image and in front, front-facing (normal . ray < 0), and not occluded
    /// on the segment from the camera centre to the centroid offset by
    /// [`FACE_VISIBILITY_EPSILON`] along the normal.
    pub fn visible_faces(&self, camera: &Camera, mesh: &Mesh) -> Vec<bool> {
        let c = camera.center();
        (0..mesh.n_faces())
            .into_par_iter()
            .with_min_len(256)
            .map(|f| {
                let p = mesh.face_centroid(f);
                let n = mesh.face_normal(f);
                camera.in_frustum(&p)
                    && n.dot(&(p - c)) < 0.0
                    && !self.occluded(&c, &(p + n * FACE_VISIBILITY_EPSILON))
            })
            .collect()
    }

    /// Depth image seen by `camera` (distance along the optical axis, 0 where
    /// no surface), with the face id image (`u32::MAX` where no surface).
    /// Rays go through pixel centres.
    pub fn render_depth(&self, camera: &Camera) -> (Vec<f32>, Vec<u32>) {
        let k = camera.intrinsics;
        let axis = camera.axis();
        let (w, h) = (k.width as usize, k.height as usize);
        let mut depth = vec![0f32; w * h];
        let mut faces = vec![u32::MAX; w * h];
        depth
            .par_chunks_mut(w)
            .zip(faces.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, (drow, frow))| {
                for x in 0..w {
                    let px = Point2::new(x as f64 + 0.5, y as f64 + 0.5);
                    let (o, d) = camera.ray(&px);
                    if let Some(hit) = self.closest_hit(&o, &d, f64::INFINITY) {
                        drow[x] = (hit.t * d.dot(&axis)) as f32;
                        frow[x] = hit.face;
                    }
                }
            });
        (depth, faces)
    }
}

/// Rays per parallel task of the batch queries: enough that the walks
/// interleaved on a thread rarely run short of rays.
const TRACE_CHUNK: usize = 512;

/// Batches at least this large are traced in coherent order...
const COHERENT_BATCH: usize = 16_384;

/// ...if the BVH is at least this large. A smaller one stays in the last
/// level cache whatever the order, and sorting costs more than it saves:
/// on the 200k-face site (a 14 MB BVH) the key, the sort and the gather
/// took 35 % of the occlusion time, and tracing 1M aerial rays in input
/// order was 1.3-1.8x faster for occlusion, the same for closest hits.
const COHERENT_BVH_BYTES: usize = 32 << 20;

/// The world-frame hit of the ray from `origin` in direction `dir` that
/// the traversal found.
fn world_hit(origin: &Point3<f64>, dir: &Vector3<f64>, hit: &bvh8::Bvh8Hit) -> Hit {
    let t = f64::from(hit.t);
    // Barycentrics from the leaf packet, which the traversal just read
    // (in cache); the world-frame triangle would cost a miss.
    let (u, v) = (f64::from(hit.u), f64::from(hit.v));
    Hit {
        t,
        face: hit.face,
        bary: [1.0 - u - v, u, v],
        point: origin + dir * t,
    }
}

/// Spreads the low 10 bits of `x` to every third bit (Morton interleave).
fn spread_bits(x: u64) -> u64 {
    let mut x = x & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    (x | x << 2) & 0x0924_9249
}

mod bvh8;

#[cfg(test)]
mod tests;
