//! Surface meshes from sparse 3D points (SfM output): 2.5D Delaunay with
//! spike removal and a maximum edge length.
//!
//! A 2.5D mesh is a height field over the ground plane: for aerial views of
//! open terrain it is the practical default (the paper's online meshing plays
//! the same role). It cannot represent two surfaces above one another — ground
//! under a tree canopy — because every (x, y) has one height; where points
//! stack, the highest one is kept, giving a digital surface model. Planning
//! on such a mesh treats canopies as solid, which errs on the safe side for
//! obstacle clearance.

use nalgebra::Point3;
use spade::{DelaunayTriangulation, HasPosition, Triangulation};

use crate::error::{Result, SceneError};
use crate::mesh::Mesh;

/// Parameters of [`mesh_from_points`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshingParams {
    /// Faces with a 3D edge longer than this are dropped (metres): they would
    /// bridge gaps where no points were seen.
    pub max_edge: f64,
    /// A point is a spike outlier when its height differs from the median of
    /// its Delaunay neighbours by more than `spike_factor` times their median
    /// absolute deviation ...
    pub spike_factor: f64,
    /// ... and by more than this many metres (so flat areas with tiny
    /// deviations do not lose points).
    pub min_spike: f64,
    /// Points closer than this in (x, y) are merged, keeping the highest.
    pub merge_distance: f64,
}

impl Default for MeshingParams {
    fn default() -> Self {
        MeshingParams {
            max_edge: 5.0,
            spike_factor: 5.0,
            min_spike: 0.5,
            merge_distance: 1e-3,
        }
    }
}

/// What [`mesh_from_points`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MeshingReport {
    /// Points given.
    pub input_points: usize,
    /// Points dropped for non-finite coordinates.
    pub non_finite: usize,
    /// Points merged into a higher point at the same (x, y).
    pub merged: usize,
    /// Points dropped as spikes.
    pub spikes: usize,
    /// Faces dropped for an edge longer than `max_edge`.
    pub long_faces: usize,
    /// Sliver faces dropped (footprint area below 1% of the longest edge squared).
    pub slivers: usize,
}

/// Footprint / (longest edge)^2 below which a face is a sliver. An
/// equilateral triangle has 0.43.
const SLIVER_RATIO: f64 = 0.01;

#[derive(Debug, Clone, Copy)]
struct Vertex {
    p: Point3<f64>,
}

impl HasPosition for Vertex {
    type Scalar = f64;
    fn position(&self) -> spade::Point2<f64> {
        spade::Point2::new(self.p.x, self.p.y)
    }
}

fn triangulate(points: Vec<Vertex>) -> Result<DelaunayTriangulation<Vertex>> {
    DelaunayTriangulation::bulk_load(points)
        .map_err(|e| SceneError::InvalidArgument(format!("Delaunay triangulation failed: {e}")))
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_unstable_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// Builds a 2.5D surface mesh from sparse points. Faces point up (+z).
/// Deterministic: the result depends only on the points and parameters.
pub fn mesh_from_points(
    points: &[Point3<f64>],
    params: &MeshingParams,
) -> Result<(Mesh, MeshingReport)> {
    if !(params.max_edge > 0.0 && params.spike_factor > 0.0 && params.min_spike >= 0.0) {
        return Err(SceneError::InvalidArgument(format!(
            "meshing parameters must be positive: {params:?}"
        )));
    }
    let mut report = MeshingReport {
        input_points: points.len(),
        ..MeshingReport::default()
    };
    let mut pts: Vec<Point3<f64>> = points
        .iter()
        .copied()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .collect();
    report.non_finite = points.len() - pts.len();

    // Merge stacked points on a grid of merge_distance, keeping the highest.
    let cell = params.merge_distance.max(1e-9);
    pts.sort_by(|a, b| {
        let key = |p: &Point3<f64>| ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64);
        key(a).cmp(&key(b)).then(b.z.total_cmp(&a.z))
    });
    let before = pts.len();
    pts.dedup_by_key(|p| ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64));
    report.merged = before - pts.len();

    // Spikes: compare each point with its Delaunay neighbours.
    let tri = triangulate(pts.iter().map(|&p| Vertex { p }).collect())?;
    let mut keep = Vec::with_capacity(pts.len());
    for v in tri.vertices() {
        let z = v.data().p.z;
        let mut nz: Vec<f64> = v.out_edges().map(|e| e.to().data().p.z).collect();
        if nz.len() >= 3 {
            let m = median(&mut nz);
            let mut dev: Vec<f64> = nz.iter().map(|h| (h - m).abs()).collect();
            let mad = median(&mut dev);
            let d = (z - m).abs();
            if d > params.min_spike && d > params.spike_factor * mad {
                report.spikes += 1;
                continue;
            }
        }
        keep.push(*v.data());
    }
    let tri = triangulate(keep)?;

    let vertices: Vec<Point3<f64>> = tri.vertices().map(|v| v.data().p).collect();
    let max2 = params.max_edge * params.max_edge;
    let mut faces = Vec::with_capacity(tri.num_inner_faces());
    for f in tri.inner_faces() {
        let idx = f.vertices().map(|v| v.fix().index() as u32);
        let [a, b, c] = idx.map(|i| vertices[i as usize]);
        if (b - a).norm_squared() > max2
            || (c - b).norm_squared() > max2
            || (a - c).norm_squared() > max2
        {
            report.long_faces += 1;
            continue;
        }
        // Nearly collinear triples on the convex hull make slivers whose
        // normal is arbitrary; a real 2.5D face has a fair footprint.
        let footprint = ((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y)).abs() * 0.5;
        let longest2 = (b - a)
            .norm_squared()
            .max((c - b).norm_squared())
            .max((a - c).norm_squared());
        if footprint < SLIVER_RATIO * longest2 {
            report.slivers += 1;
            continue;
        }
        faces.push(idx);
    }
    let (mesh, _) = Mesh {
        vertices,
        faces,
        materials: None,
    }
    .cleaned();
    Ok((mesh, report))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn terrain(x: f64, y: f64) -> f64 {
        0.1 * x + 0.5 * (0.3 * y).sin()
    }

    fn samples(n: usize, seed: u64) -> Vec<Point3<f64>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let (x, y) = (rng.random_range(0.0..40.0), rng.random_range(0.0..40.0));
                Point3::new(x, y, terrain(x, y))
            })
            .collect()
    }

    #[test]
    fn mesh_of_terrain_samples_follows_the_terrain_and_faces_up() {
        let pts = samples(3000, 1);
        let (mesh, report) = mesh_from_points(&pts, &MeshingParams::default()).unwrap();
        mesh.validate().unwrap();
        assert_eq!(report.spikes, 0);
        assert_eq!(mesh.n_vertices(), 3000);
        for f in 0..mesh.n_faces() {
            assert!(
                mesh.face_normal(f).z > 0.5,
                "face {f} normal {} area {}",
                mesh.face_normal(f),
                mesh.face_area(f)
            );
            let c = mesh.face_centroid(f);
            assert!((c.z - terrain(c.x, c.y)).abs() < 0.1);
        }
        let area: f64 = mesh.face_areas().iter().sum();
        assert!(
            area > 0.9 * 1600.0 && area < 1.1 * 1600.0 * 1.01,
            "area {area}"
        );
    }

    #[test]
    fn spikes_are_removed_and_gaps_are_not_bridged() {
        let mut pts = samples(3000, 2);
        // Three SfM outliers 8 m above and below the surface.
        pts.push(Point3::new(10.0, 10.0, terrain(10.0, 10.0) + 8.0));
        pts.push(Point3::new(20.0, 25.0, terrain(20.0, 25.0) - 8.0));
        pts.push(Point3::new(30.0, 5.0, terrain(30.0, 5.0) + 8.0));
        // A hole: nothing seen inside a 12 m square.
        pts.retain(|p| {
            !(p.x > 14.0 && p.x < 26.0 && p.y > 14.0 && p.y < 26.0) || p.z > 5.0 || p.z < -5.0
        });
        let (mesh, report) = mesh_from_points(&pts, &MeshingParams::default()).unwrap();
        assert_eq!(report.spikes, 3);
        assert!(report.long_faces > 0);
        for f in 0..mesh.n_faces() {
            let c = mesh.face_centroid(f);
            assert!((c.z - terrain(c.x, c.y)).abs() < 0.2, "spike left at {c}");
            assert!(
                !(c.x > 16.0 && c.x < 24.0 && c.y > 16.0 && c.y < 24.0),
                "hole bridged at {c}"
            );
        }
    }

    #[test]
    fn stacked_points_keep_the_highest_and_bad_points_are_dropped() {
        let mut pts = samples(500, 3);
        pts.push(Point3::new(pts[0].x, pts[0].y, pts[0].z - 3.0)); // ground under a canopy point
        pts.push(Point3::new(f64::NAN, 1.0, 1.0));
        let (mesh, report) = mesh_from_points(&pts, &MeshingParams::default()).unwrap();
        assert_eq!(report.non_finite, 1);
        assert_eq!(report.merged, 1);
        assert!(mesh.vertices.contains(&pts[0]));
        assert!(mesh_from_points(
            &pts,
            &MeshingParams {
                max_edge: 0.0,
                ..MeshingParams::default()
            }
        )
        .is_err());
        // Too few points: an empty mesh, not an error.
        let (empty, _) = mesh_from_points(&pts[..2], &MeshingParams::default()).unwrap();
        assert_eq!(empty.n_faces(), 0);
    }
}
