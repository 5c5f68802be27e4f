//! Turns a failed [`Mesh::validate`] of a loaded mesh into an error that
//! points into the file: the vertex or face (polygon) at fault and its line
//! or byte offset.
//!
//! Locating is done only on failure, by reading the file again up to the
//! element concerned, so the normal path stores no per-element positions.

use std::path::Path;

use super::{obj, ply, FileType, Found, Target};
use crate::error::{Location, SceneError};
use crate::mesh::Mesh;

/// The first problem [`Mesh::validate`] would report, with its indices.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Problem {
    /// A vertex with a NaN or infinite coordinate.
    NonFinite(usize),
    /// A triangle refers to a vertex that does not exist.
    BadIndex { triangle: usize, vertex: u32 },
    /// A triangle uses a vertex twice.
    Repeated { triangle: usize, vertex: u32 },
    /// A triangle of zero area.
    Degenerate { triangle: usize },
    /// Anything else, in `validate`'s words.
    Other(String),
}

/// The first problem of `mesh`, or `None` if it is valid. The mesh is
/// borrowed mutably only to probe faces one by one without copying vertices;
/// it is left unchanged.
pub(super) fn first_problem(mesh: &mut Mesh) -> Option<Problem> {
    let error = mesh.validate().err()?;
    // Same order as `Mesh::validate`: vertices first, then faces in order.
    if let Some(v) = mesh
        .vertices
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Some(Problem::NonFinite(v));
    }
    let n = mesh.vertices.len();
    // A one-face mesh over the same vertices reuses `validate`'s own
    // degeneracy test rather than copying its threshold here.
    let mut probe = Mesh {
        vertices: std::mem::take(&mut mesh.vertices),
        faces: vec![[0; 3]],
        materials: None,
    };
    let mut problem = None;
    for (triangle, face) in mesh.faces.iter().enumerate() {
        if let Some(&vertex) = face.iter().find(|&&i| i as usize >= n) {
            problem = Some(Problem::BadIndex { triangle, vertex });
            break;
        }
        if let Some(k) = (0..3).find(|&k| face[k] == face[(k + 1) % 3]) {
            problem = Some(Problem::Repeated {
                triangle,
                vertex: face[k],
            });
            break;
        }
        probe.faces[0] = *face;
        if probe.validate().is_err() {
            problem = Some(Problem::Degenerate { triangle });
            break;
        }
    }
    mesh.vertices = probe.vertices;
    Some(problem.unwrap_or_else(|| Problem::Other(error.to_string())))
}

/// The error for `problem`, naming `origin` and the place in `bytes`.
pub(super) fn error(
    problem: &Problem,
    mesh: &Mesh,
    bytes: &[u8],
    file_type: FileType,
    origin: &Path,
) -> SceneError {
    // OBJ counts vertices and faces from 1, PLY elements from 0.
    let base = usize::from(file_type == FileType::Obj);
    let (target, what) = match *problem {
        Problem::NonFinite(v) => {
            let p = mesh.vertices[v];
            let what = format!("non-finite coordinate ({}, {}, {})", p.x, p.y, p.z);
            (Target::Vertex(v), what)
        }
        Problem::BadIndex { triangle, vertex } => {
            let what = format!(
                "refers to vertex {}, but the file has only {} vertices",
                vertex as usize + base,
                mesh.vertices.len()
            );
            (Target::Triangle(triangle), what)
        }
        Problem::Repeated { triangle, vertex } => {
            let what = format!("uses vertex {} twice", vertex as usize + base);
            (Target::Triangle(triangle), what)
        }
        Problem::Degenerate { triangle } => {
            let [a, b, c] = mesh.faces[triangle].map(|i| i as usize + base);
            let what =
                format!("triangle ({a}, {b}, {c}) has zero area (collinear or coincident corners)");
            (Target::Triangle(triangle), what)
        }
        Problem::Other(ref message) => {
            return SceneError::parse(origin, Location::Header, message.clone())
        }
    };
    let found = match file_type {
        FileType::Ply => ply::locate(bytes, origin, target),
        FileType::Obj => obj::locate(bytes, origin, target),
    };
    let (kind, mesh_index) = match target {
        Target::Vertex(v) => ("vertex", v),
        Target::Triangle(t) => ("face", t),
    };
    // Locating re-reads a file that already parsed, so it finds the element;
    // the fallback only keeps this path free of panics.
    let Found { location, index } = found.unwrap_or(Found {
        location: Location::Element {
            kind: kind.to_string(),
            index: mesh_index,
            byte: None,
        },
        index: mesh_index,
    });
    // An element location already names the element; a line does not.
    let message = if matches!(location, Location::Element { .. }) {
        what
    } else {
        format!("{kind} {}: {what}", index + base)
    };
    SceneError::parse(origin, location, message)
}
