//! Wavefront OBJ reader and writer of our own.
//!
//! Only geometry is read: `v` and `f` (forms `v`, `v/vt`, `v//vn`,
//! `v/vt/vn`, negative indices relative to the vertices so far), polygons as
//! fans. `usemtl` with one of our material names (ground, rock, grass, tree,
//! marker) gives per-face materials; a mesh gets materials only when every
//! face has a known one. Other statements (`vt`, `vn`, `o`, `g`, `s`,
//! `mtllib`, ...) are ignored. Line continuations (`\`) are not supported.

mod write;

use std::path::Path;

use nalgebra::Point3;

use super::text::{self, Lines};
use super::{Found, Target};
use crate::error::{Location, Result, SceneError};
use crate::mesh::{Material, Mesh};

pub(crate) use write::write;

/// The material with this name (case-insensitive).
fn material_by_name(name: &[u8]) -> Option<Material> {
    Material::ALL
        .into_iter()
        .find(|m| m.name().as_bytes().eq_ignore_ascii_case(name))
}

/// Resolves one face vertex token (`i`, `i/t`, `i//n`, `i/t/n`) to a 0-based
/// vertex index. `n_vertices` is the count defined so far, for negative
/// (relative) indices.
fn face_vertex(token: &[u8], n_vertices: usize) -> std::result::Result<u32, String> {
    let bad = || {
        format!(
            "'{}' is not a face vertex (expected v, v/vt, v//vn or v/vt/vn with integer indices)",
            text::show(token)
        )
    };
    let mut parts = token.split(|&b| b == b'/');
    let v = parts.next().and_then(text::parse_i64).ok_or_else(bad)?;
    for (k, part) in parts.enumerate() {
        // Texture and normal indices are not used, but a malformed one means
        // a broken line.
        if k >= 2 || !(part.is_empty() || text::parse_i64(part).is_some()) {
            return Err(bad());
        }
    }
    let index = match v {
        0 => return Err("vertex index 0 is invalid (OBJ indices start at 1)".into()),
        v if v > 0 => v - 1,
        v => {
            let i = n_vertices as i64 + v;
            if i < 0 {
                return Err(format!(
                    "relative vertex index {v} points before the first vertex \
                     ({n_vertices} vertices defined so far)"
                ));
            }
            i
        }
    };
    u32::try_from(index).map_err(|_| format!("vertex index {v} is too large"))
}

/// Reads the file, stopping early with the target's location if one is set.
fn read(bytes: &[u8], path: &Path, target: Option<Target>) -> Result<(Mesh, Option<Found>)> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut vertices: Vec<Point3<f64>> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut materials: Vec<Material> = Vec::new();
    let mut all_known = true;
    let mut current: Option<Material> = None;
    let mut n_polygons = 0usize;
    for (n, line) in Lines::new(bytes, 1) {
        let line = line.split(|&b| b == b'#').next().unwrap_or(line);
        let mut tokens = text::tokens(line);
        let Some(keyword) = tokens.next() else {
            continue;
        };
        let at = |msg: String| SceneError::parse(path, Location::Line(n), msg);
        match keyword {
            b"v" => {
                let mut xyz = [0.0f64; 3];
                for (k, c) in xyz.iter_mut().enumerate() {
                    let token = tokens.next().ok_or_else(|| {
                        at(format!(
                            "vertex {} has {k} coordinates; it needs 3",
                            vertices.len() + 1
                        ))
                    })?;
                    *c = text::parse_f64(token).ok_or_else(|| {
                        at(format!(
                            "vertex {}: '{}' is not a number",
                            vertices.len() + 1,
                            text::show(token)
                        ))
                    })?;
                }
                // Anything after x y z (a w weight, or the r g b colours
                // MeshLab writes) does not change the geometry.
                vertices.push(Point3::from(xyz));
                if target == Some(Target::Vertex(vertices.len() - 1)) {
                    return Ok((Mesh::default(), Some(found(n, vertices.len() - 1))));
                }
            }
            b"f" => {
                let first_triangle = faces.len();
                let (mut first, mut prev, mut count) = (0u32, 0u32, 0usize);
                for token in tokens {
                    let i = face_vertex(token, vertices.len())
                        .map_err(|m| at(format!("face {}: {m}", n_polygons + 1)))?;
                    match count {
                        0 => first = i,
                        1 => {}
                        _ => faces.push([first, prev, i]),
                    }
                    prev = i;
                    count += 1;
                }
                if count < 3 {
                    return Err(at(format!(
                        "face {} has {count} vertices; a face needs at least 3",
                        n_polygons + 1
                    )));
                }
                match current {
                    Some(m) if all_known => materials.resize(faces.len(), m),
                    _ => all_known = false,
                }
                if let Some(Target::Triangle(t)) = target {
                    if (first_triangle..faces.len()).contains(&t) {
                        return Ok((Mesh::default(), Some(found(n, n_polygons))));
                    }
                }
                n_polygons += 1;
            }
            b"usemtl" => {
                current = match (tokens.next(), tokens.next()) {
                    (Some(name), None) => material_by_name(name),
                    _ => None,
                };
            }
            other
                if other
                    .iter()
                    .all(|&b| b.is_ascii_alphanumeric() || b == b'_') => {}
            other => {
                return Err(at(format!(
                    "'{}' is not an OBJ statement",
                    text::show(other)
                )))
            }
        }
    }
    let materials = (all_known && !faces.is_empty()).then_some(materials);
    Ok((
        Mesh {
            vertices,
            faces,
            materials,
        },
        None,
    ))
}

fn found(line: usize, index: usize) -> Found {
    Found {
        location: Location::Line(line),
        index,
    }
}

/// Parses a whole OBJ file. Only format errors are reported; the mesh may
/// still hold out-of-range indices or non-finite coordinates.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<Mesh> {
    Ok(read(bytes, path, None)?.0)
}

/// Where in the file a vertex or triangle of the parsed mesh came from.
pub(crate) fn locate(bytes: &[u8], path: &Path, target: Target) -> Option<Found> {
    read(bytes, path, Some(target)).ok()?.1
}

#[cfg(test)]
mod tests;
