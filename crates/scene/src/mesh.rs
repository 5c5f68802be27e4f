//! Indexed triangle mesh with optional per-face materials.
//!
//! Positions are `f64` in the local ENU world frame (metres). The mesh is the
//! planner's model of the world and the simulator's ground truth; ray casting
//! ([`crate::raycast`]) and clearance ([`crate::clearance`]) build their
//! acceleration structures from it.

use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{Result, SceneError};

/// Surface material of a face. The ids are stored in PLY files as the face
/// property `material` (uchar).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
#[repr(u8)]
pub enum Material {
    /// Bare or mossy soil: the terrain.
    Ground = 0,
    /// Smooth rock: the object of interest of the paper's sites.
    Rock = 1,
    /// Grass tufts: high-frequency geometry and texture.
    Grass = 2,
    /// Tree trunks and canopies.
    Tree = 3,
    /// Flat high-contrast markers on posts.
    Marker = 4,
}

impl Material {
    /// All materials in id order.
    pub const ALL: [Material; 5] = [
        Material::Ground,
        Material::Rock,
        Material::Grass,
        Material::Tree,
        Material::Marker,
    ];

    /// The material with this id, if any.
    pub fn from_id(id: u8) -> Option<Material> {
        Material::ALL.get(id as usize).copied()
    }

    /// Lower-case name, as used in configs and reports.
    pub fn name(self) -> &'static str {
        match self {
            Material::Ground => "ground",
            Material::Rock => "rock",
            Material::Grass => "grass",
            Material::Tree => "tree",
            Material::Marker => "marker",
        }
    }
}

/// Axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Point3<f64>,
    /// Largest corner.
    pub max: Point3<f64>,
}

impl Aabb {
    /// The empty box (min = +inf, max = -inf); grows with [`Aabb::grow`].
    pub fn empty() -> Self {
        Aabb {
            min: Point3::from([f64::INFINITY; 3]),
            max: Point3::from([f64::NEG_INFINITY; 3]),
        }
    }

    /// Enlarges the box to contain `p`.
    pub fn grow(&mut self, p: &Point3<f64>) {
        self.min = self.min.inf(p);
        self.max = self.max.sup(p);
    }

    /// Size along each axis.
    pub fn extent(&self) -> Vector3<f64> {
        self.max - self.min
    }

    /// Whether `p` lies inside or on the box.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|i| p[i] >= self.min[i] && p[i] <= self.max[i])
    }
}

/// Indexed triangle mesh.
///
/// Invariants (checked by [`Mesh::new`] and [`Mesh::validate`]): finite
/// coordinates, indices in range, no degenerate face, and when present one
/// material per face.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    /// Vertex positions (world frame, metres).
    pub vertices: Vec<Point3<f64>>,
    /// Triangles as vertex indices, counter-clockwise seen from the front.
    pub faces: Vec<[u32; 3]>,
    /// One material per face, if the mesh carries materials.
    pub materials: Option<Vec<Material>>,
}

/// What [`Mesh::cleaned`] dropped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CleanReport {
    /// Faces dropped because a vertex index was out of range.
    pub bad_index_faces: usize,
    /// Faces dropped because a vertex had a NaN or infinite coordinate.
    pub non_finite_faces: usize,
    /// Faces dropped because they have zero area or a repeated vertex.
    pub degenerate_faces: usize,
    /// Vertices dropped because no face used them any more.
    pub unused_vertices: usize,
}

impl CleanReport {
    /// Total number of faces dropped.
    pub fn dropped_faces(&self) -> usize {
        self.bad_index_faces + self.non_finite_faces + self.degenerate_faces
    }
}

/// Vertex adjacency in compressed-row form: the neighbours of vertex `v` are
/// `neighbors[offsets[v]..offsets[v + 1]]`, sorted and unique.
#[derive(Debug, Clone)]
pub struct Adjacency {
    offsets: Vec<usize>,
    neighbors: Vec<u32>,
}

impl Adjacency {
    /// Edge neighbours of vertex `v`.
    pub fn neighbors(&self, v: usize) -> &[u32] {
        &self.neighbors[self.offsets[v]..self.offsets[v + 1]]
    }

    /// Number of vertices.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Whether there are no vertices.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Relative area below which a face counts as degenerate: area / (longest
/// edge)^2. A sliver this thin has no usable normal.
const DEGENERATE_RATIO: f64 = 1e-12;

/// Why a single face is invalid, if it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum FaceProblem {
    BadIndex(u32),
    NonFinite(u32),
    Degenerate,
}

impl Mesh {
    /// Builds a mesh and validates it.
    pub fn new(
        vertices: Vec<Point3<f64>>,
        faces: Vec<[u32; 3]>,
        materials: Option<Vec<Material>>,
    ) -> Result<Self> {
        let mesh = Mesh {
            vertices,
            faces,
            materials,
        };
        mesh.validate()?;
        Ok(mesh)
    }

    /// Number of faces.
    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.vertices.len()
    }

    fn face_problem(&self, face: &[u32; 3]) -> Option<FaceProblem> {
        for &i in face {
            match self.vertices.get(i as usize) {
                None => return Some(FaceProblem::BadIndex(i)),
                Some(p) if !p.iter().all(|c| c.is_finite()) => {
                    return Some(FaceProblem::NonFinite(i));
                }
                Some(_) => {}
            }
        }
        let [a, b, c] = face.map(|i| self.vertices[i as usize]);
        let longest = (b - a)
            .norm_squared()
            .max((c - b).norm_squared())
            .max((a - c).norm_squared());
        let area2 = (b - a).cross(&(c - a)).norm();
        if face[0] == face[1] || face[1] == face[2] || face[0] == face[2] {
            return Some(FaceProblem::Degenerate);
        }
        if longest == 0.0 || area2 * 0.5 <= DEGENERATE_RATIO * longest {
            return Some(FaceProblem::Degenerate);
        }
        None
    }

    /// Checks the invariants; the error names the first offending face or vertex.
    pub fn validate(&self) -> Result<()> {
        if let Some(m) = &self.materials {
            if m.len() != self.faces.len() {
                return Err(SceneError::InvalidMesh(format!(
                    "{} materials for {} faces",
                    m.len(),
                    self.faces.len()
                )));
            }
        }
        for (v, p) in self.vertices.iter().enumerate() {
            if !p.iter().all(|c| c.is_finite()) {
                return Err(SceneError::InvalidMesh(format!(
                    "vertex {v} has a non-finite coordinate ({}, {}, {})",
                    p.x, p.y, p.z
                )));
            }
        }
        for (f, face) in self.faces.iter().enumerate() {
            match self.face_problem(face) {
                None => {}
                Some(FaceProblem::BadIndex(i)) => {
                    return Err(SceneError::InvalidMesh(format!(
                        "face {f} refers to vertex {i}, but there are only {} vertices",
                        self.vertices.len()
                    )))
                }
                Some(FaceProblem::NonFinite(i)) => {
                    return Err(SceneError::InvalidMesh(format!(
                        "face {f} uses vertex {i}, which has a non-finite coordinate"
                    )))
                }
                Some(FaceProblem::Degenerate) => {
                    return Err(SceneError::InvalidMesh(format!(
                        "face {f} {face:?} is degenerate (zero area or repeated vertex)"
                    )))
                }
            }
        }
        Ok(())
    }

    /// A copy without the invalid faces and without unused vertices, with
    /// counts of what was dropped. For users who ask to repair a mesh rather
    /// than reject it.
    pub fn cleaned(&self) -> (Mesh, CleanReport) {
        let mut report = CleanReport::default();
        let mut keep = Vec::with_capacity(self.faces.len());
        for (f, face) in self.faces.iter().enumerate() {
            match self.face_problem(face) {
                None => keep.push(f),
                Some(FaceProblem::BadIndex(_)) => report.bad_index_faces += 1,
                Some(FaceProblem::NonFinite(_)) => report.non_finite_faces += 1,
                Some(FaceProblem::Degenerate) => report.degenerate_faces += 1,
            }
        }
        let mut remap = vec![u32::MAX; self.vertices.len()];
        let mut vertices = Vec::new();
        let faces = keep
            .iter()
            .map(|&f| {
                self.faces[f].map(|i| {
                    let slot = &mut remap[i as usize];
                    if *slot == u32::MAX {
                        *slot = vertices.len() as u32;
                        vertices.push(self.vertices[i as usize]);
                    }
                    *slot
                })
            })
            .collect();
        report.unused_vertices = self.vertices.len() - vertices.len();
        let materials = self
            .materials
            .as_ref()
            .filter(|m| m.len() == self.faces.len())
            .map(|m| keep.iter().map(|&f| m[f]).collect());
        (
            Mesh {
                vertices,
                faces,
                materials,
            },
            report,
        )
    }

    /// The three corners of face `f`.
    #[inline]
    pub fn triangle(&self, f: usize) -> [Point3<f64>; 3] {
        self.faces[f].map(|i| self.vertices[i as usize])
    }

    /// Unit normal of face `f` (right-hand rule over its vertex order).
    pub fn face_normal(&self, f: usize) -> Vector3<f64> {
        let [a, b, c] = self.triangle(f);
        (b - a).cross(&(c - a)).normalize()
    }

    /// Area of face `f` in square metres.
    pub fn face_area(&self, f: usize) -> f64 {
        let [a, b, c] = self.triangle(f);
        0.5 * (b - a).cross(&(c - a)).norm()
    }

    /// Centroid of face `f`.
    pub fn face_centroid(&self, f: usize) -> Point3<f64> {
        let [a, b, c] = self.triangle(f);
        Point3::from((a.coords + b.coords + c.coords) / 3.0)
    }

    /// Unit normals of all faces.
    pub fn face_normals(&self) -> Vec<Vector3<f64>> {
        (0..self.faces.len()).map(|f| self.face_normal(f)).collect()
    }

    /// Centroids of all faces.
    pub fn face_centroids(&self) -> Vec<Point3<f64>> {
        (0..self.faces.len())
            .map(|f| self.face_centroid(f))
            .collect()
    }

    /// Areas of all faces.
    pub fn face_areas(&self) -> Vec<f64> {
        (0..self.faces.len()).map(|f| self.face_area(f)).collect()
    }

    /// Material of face `f`, if the mesh carries materials.
    pub fn material(&self, f: usize) -> Option<Material> {
        self.materials.as_ref().map(|m| m[f])
    }

    /// Bounding box of the vertices.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::empty();
        for p in &self.vertices {
            b.grow(p);
        }
        b
    }

    /// Mean edge length over all face edges (shared edges counted per face).
    pub fn mean_edge_length(&self) -> f64 {
        if self.faces.is_empty() {
            return 0.0;
        }
        let sum: f64 = (0..self.faces.len())
            .map(|f| {
                let [a, b, c] = self.triangle(f);
                (b - a).norm() + (c - b).norm() + (a - c).norm()
            })
            .sum();
        sum / (3 * self.faces.len()) as f64
    }

    /// Edge-neighbour lists of all vertices.
    pub fn vertex_adjacency(&self) -> Adjacency {
        let n = self.vertices.len();
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(self.faces.len() * 6);
        for face in &self.faces {
            for k in 0..3 {
                let (a, b) = (face[k], face[(k + 1) % 3]);
                pairs.push((a, b));
                pairs.push((b, a));
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut offsets = vec![0usize; n + 1];
        for &(a, _) in &pairs {
            offsets[a as usize + 1] += 1;
        }
        for v in 0..n {
            offsets[v + 1] += offsets[v];
        }
        Adjacency {
            offsets,
            neighbors: pairs.into_iter().map(|(_, b)| b).collect(),
        }
    }

    /// Face-wise material histogram: `counts[id]` faces of material id.
    pub fn material_counts(&self) -> Option<[usize; Material::ALL.len()]> {
        self.materials.as_ref().map(|m| {
            let mut counts = [0usize; Material::ALL.len()];
            for &mat in m {
                counts[mat as usize] += 1;
            }
            counts
        })
    }

    /// Appends another mesh (vertices re-indexed). Materials are kept only
    /// when both meshes carry them.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.vertices.len() as u32;
        let had_faces = !self.faces.is_empty();
        self.vertices.extend_from_slice(&other.vertices);
        self.faces
            .extend(other.faces.iter().map(|f| f.map(|i| i + base)));
        self.materials = match (self.materials.take(), &other.materials) {
            (Some(mut a), Some(b)) => {
                a.extend_from_slice(b);
                Some(a)
            }
            (None, Some(b)) if !had_faces => Some(b.clone()),
            _ => None,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh::new(
            vec![
                Point3::new(0.0, 0.0, 0.0),
                Point3::new(1.0, 0.0, 0.0),
                Point3::new(1.0, 1.0, 0.0),
                Point3::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
            None,
        )
        .unwrap()
    }

    #[test]
    fn face_quantities_of_unit_square() {
        let m = quad();
        assert!((m.face_area(0) - 0.5).abs() < 1e-12);
        assert!((m.face_normal(1) - Vector3::z()).norm() < 1e-12);
        let c = m.face_centroid(0);
        assert!((c - Point3::new(2.0 / 3.0, 1.0 / 3.0, 0.0)).norm() < 1e-12);
        let b = m.bounds();
        assert_eq!(b.max, Point3::new(1.0, 1.0, 0.0));
        let adj = m.vertex_adjacency();
        assert_eq!(adj.neighbors(0), &[1, 2, 3]);
        assert_eq!(adj.neighbors(1), &[0, 2]);
    }

    #[test]
    fn validation_names_the_offending_face() {
        let mut m = quad();
        m.faces.push([0, 1, 9]);
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("face 2") && e.contains("vertex 9"), "{e}");

        let mut m = quad();
        m.vertices[3].x = f64::NAN;
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("vertex 3"), "{e}");

        let mut m = quad();
        m.faces.push([0, 0, 1]);
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("face 2") && e.contains("degenerate"), "{e}");
    }

    #[test]
    fn cleaning_reports_what_was_dropped() {
        let mut m = quad();
        m.vertices.push(Point3::new(f64::INFINITY, 0.0, 0.0));
        m.vertices.push(Point3::new(5.0, 5.0, 5.0)); // unused
        m.faces.push([0, 1, 9]); // bad index
        m.faces.push([0, 1, 4]); // non-finite
        m.faces.push([0, 1, 1]); // degenerate
        m.faces.push([0, 1, 3]); // fine
        m.materials = Some(vec![Material::Rock; m.faces.len()]);
        let (c, r) = m.cleaned();
        assert_eq!(c.n_faces(), 3);
        assert_eq!(r.bad_index_faces, 1);
        assert_eq!(r.non_finite_faces, 1);
        assert_eq!(r.degenerate_faces, 1);
        assert_eq!(r.unused_vertices, 2);
        c.validate().unwrap();
        assert_eq!(c.materials.as_ref().unwrap().len(), 3);
    }
}
