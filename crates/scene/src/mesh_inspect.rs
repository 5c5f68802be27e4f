//! What `vpctl mesh info` reports about a mesh file as read (before
//! cleaning): sizes, bounds, area, materials and the problems found. The CLI
//! only prints it.

use crate::mesh::{Aabb, Material, Mesh};

/// A mesh as found, with its problems.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshInspection {
    /// Number of vertices.
    pub vertices: usize,
    /// Number of faces.
    pub faces: usize,
    /// Bounds, when there are vertices and all are finite.
    pub bounds: Option<Aabb>,
    /// Total area and mean edge length, when every face is valid.
    pub area_and_mean_edge: Option<(f64, f64)>,
    /// Faces per material ([`Material::ALL`] order), when the mesh has materials.
    pub material_counts: Option<[usize; Material::ALL.len()]>,
    /// Problems found: a description and a count, only those with a count > 0.
    pub problems: Vec<(&'static str, usize)>,
    /// Whether the mesh can be used as it is: no face would be dropped and
    /// every vertex is finite (unused vertices alone do not matter).
    pub usable: bool,
}

impl Mesh {
    /// Inspects the mesh as read (see [`MeshInspection`]).
    pub fn inspect(&self) -> MeshInspection {
        let (_, report) = self.cleaned();
        let non_finite_vertices = self
            .vertices
            .iter()
            .filter(|p| !p.iter().all(|c| c.is_finite()))
            .count();
        let problems: Vec<(&'static str, usize)> = [
            ("vertices with non-finite coordinates", non_finite_vertices),
            ("faces with an index out of range", report.bad_index_faces),
            ("faces using a non-finite vertex", report.non_finite_faces),
            ("degenerate faces", report.degenerate_faces),
            ("unused vertices", report.unused_vertices),
        ]
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .collect();
        let valid_faces = report.dropped_faces() == 0;
        MeshInspection {
            vertices: self.n_vertices(),
            faces: self.n_faces(),
            bounds: (self.n_vertices() > 0 && non_finite_vertices == 0).then(|| self.bounds()),
            area_and_mean_edge: valid_faces
                .then(|| (self.face_areas().iter().sum(), self.mean_edge_length())),
            material_counts: self.material_counts(),
            problems,
            usable: valid_faces && non_finite_vertices == 0,
        }
    }
}

impl MeshInspection {
    /// The problems as one line ("2 degenerate faces; 1 unused vertices"),
    /// or "none".
    pub fn problems_line(&self) -> String {
        if self.problems.is_empty() {
            return "none".to_string();
        }
        self.problems
            .iter()
            .map(|(what, n)| format!("{n} {what}"))
            .collect::<Vec<_>>()
            .join("; ")
    }
}
