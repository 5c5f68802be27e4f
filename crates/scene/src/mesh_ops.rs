//! Mesh operations of the paper: face splitting (M1), shrinking and expanding
//! (labelgen stage 3) and submeshes. Region-of-interest selection is in
//! [`crate::roi`].

use std::collections::HashMap;

use nalgebra::{Point3, Vector3};

use crate::error::{Result, SceneError};
use crate::mesh::Mesh;

/// Splits faces until no edge is longer than `max_edge` (M1: "split until the
/// max edge length <= the average edge length before splitting").
///
/// Every edge longer than `max_edge` is bisected at its midpoint, recursively
/// (longest edge first within a face). An edge's split points depend only on
/// the edge itself, so the two faces that share it split it identically and
/// the result stays conforming (no T-junctions). Returns the new mesh and,
/// for each new face, the index of the face it came from. Materials follow
/// their faces.
pub fn split_faces(mesh: &Mesh, max_edge: f64) -> Result<(Mesh, Vec<u32>)> {
    if !(max_edge > 0.0) {
        return Err(SceneError::InvalidArgument(format!(
            "split_faces: max edge length must be positive, got {max_edge}"
        )));
    }
    let max2 = max_edge * max_edge;
    let mut vertices = mesh.vertices.clone();
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
    let mut faces = Vec::with_capacity(mesh.n_faces());
    let mut parent = Vec::with_capacity(mesh.n_faces());
    let mut stack = Vec::new();
    for (f, &face) in mesh.faces.iter().enumerate() {
        stack.push(face);
        while let Some(tri) = stack.pop() {
            let len2 = |k: usize| {
                (vertices[tri[(k + 1) % 3] as usize] - vertices[tri[k] as usize]).norm_squared()
            };
            // Longest edge k runs from tri[k] to tri[k+1]; ties go to the lower k.
            let k = (0..3).fold(0, |best, k| if len2(k) > len2(best) { k } else { best });
            if len2(k) <= max2 {
                faces.push(tri);
                parent.push(f as u32);
                continue;
            }
            let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let key = (a.min(b), a.max(b));
            let m = *midpoints.entry(key).or_insert_with(|| {
                let p =
                    Point3::from((vertices[a as usize].coords + vertices[b as usize].coords) * 0.5);
                vertices.push(p);
                (vertices.len() - 1) as u32
            });
            // Push the second half first so the first half is emitted first.
            stack.push([m, b, c]);
            stack.push([a, m, c]);
        }
    }
    let materials = mesh
        .materials
        .as_ref()
        .map(|mats| parent.iter().map(|&p| mats[p as usize]).collect());
    Ok((
        Mesh {
            vertices,
            faces,
            materials,
        },
        parent,
    ))
}

/// Result of [`shrink_and_expand`].
#[derive(Debug, Clone)]
pub struct ShrunkExpanded {
    /// The mesh after the shrinking iterations.
    pub shrunk: Mesh,
    /// The shrunk mesh expanded again.
    pub expanded: Mesh,
}

/// The two auxiliary meshes of labelgen stage 3
/// (docs/design.md#training-labels-labelgen).
///
/// Shrink: `iterations` (paper: 3) rounds in which every vertex moves half way
/// to the mean of its edge neighbours, all vertices updated together. Expand:
/// starting from the shrunk mesh, every vertex moves opposite to the average
/// of the total shrink displacements of itself and its neighbours, by twice
/// that average's length. On a convex bump the shrunk mesh lies inside the
/// surface and the expanded mesh outside it; together they bracket where the
/// true surface can be.
pub fn shrink_and_expand(mesh: &Mesh, iterations: usize) -> ShrunkExpanded {
    let adjacency = mesh.vertex_adjacency();
    let mut pos = mesh.vertices.clone();
    for _ in 0..iterations {
        pos = (0..pos.len())
            .map(|v| {
                let nb = adjacency.neighbors(v);
                if nb.is_empty() {
                    return pos[v];
                }
                let mean = nb
                    .iter()
                    .fold(Vector3::zeros(), |acc, &n| acc + pos[n as usize].coords)
                    / nb.len() as f64;
                Point3::from((pos[v].coords + mean) * 0.5)
            })
            .collect();
    }
    let displacement: Vec<Vector3<f64>> =
        pos.iter().zip(&mesh.vertices).map(|(s, o)| s - o).collect();
    let expanded = (0..pos.len())
        .map(|v| {
            let nb = adjacency.neighbors(v);
            let sum = nb
                .iter()
                .fold(displacement[v], |acc, &n| acc + displacement[n as usize]);
            let mean = sum / (nb.len() + 1) as f64;
            pos[v] - mean * 2.0
        })
        .collect();
    ShrunkExpanded {
        shrunk: Mesh {
            vertices: pos,
            faces: mesh.faces.clone(),
            materials: mesh.materials.clone(),
        },
        expanded: Mesh {
            vertices: expanded,
            faces: mesh.faces.clone(),
            materials: mesh.materials.clone(),
        },
    }
}

/// The faces `faces` of `mesh` as a mesh of their own (unused vertices dropped,
/// materials kept).
pub fn submesh(mesh: &Mesh, faces: &[u32]) -> Mesh {
    let mut remap = vec![u32::MAX; mesh.n_vertices()];
    let mut vertices = Vec::new();
    let new_faces = faces
        .iter()
        .map(|&f| {
            mesh.faces[f as usize].map(|v| {
                if remap[v as usize] == u32::MAX {
                    remap[v as usize] = vertices.len() as u32;
                    vertices.push(mesh.vertices[v as usize]);
                }
                remap[v as usize]
            })
        })
        .collect();
    Mesh {
        vertices,
        faces: new_faces,
        materials: mesh
            .materials
            .as_ref()
            .map(|m| faces.iter().map(|&f| m[f as usize]).collect()),
    }
}

#[cfg(test)]
#[path = "mesh_ops_tests.rs"]
mod tests;
