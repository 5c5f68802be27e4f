//! PLY reader and writer of our own.
//!
//! A crate would hide where a file is broken; this reader reports the line
//! (ascii) or the element and byte offset (binary) of every problem. It reads
//! all three encodings and every scalar type, triangulates polygons as fans,
//! skips elements and properties it does not use (lists included) and maps
//! the face property `material` to [`Material`].

mod ascii;
mod binary;
pub(crate) mod header;
mod write;

use std::path::Path;

use nalgebra::{Point3, Vector3};

use self::header::{Element, Encoding, Header, Kind};
use super::{Found, PointFile, ReadWarning, Target};
use crate::error::{Location, Result, SceneError};
use crate::mesh::{Material, Mesh};

pub(crate) use write::write;

/// What the reader does with a property.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    Skip,
    /// Vertex coordinate 0 (x), 1 (y) or 2 (z).
    Coord(usize),
    /// The face's vertex index list.
    Indices,
    /// The face's material id.
    Material,
    /// Vertex normal component 0 (nx), 1 (ny) or 2 (nz).
    Normal(usize),
}

impl Role {
    /// 3 for a normal component, 0 otherwise: where a vertex scalar goes in
    /// `[x, y, z, nx, ny, nz]` is `k + normal_offset()`.
    fn normal_offset(self) -> usize {
        if matches!(self, Role::Normal(_)) {
            3
        } else {
            0
        }
    }
}

/// Which element is which, and the role of each property.
struct Plan {
    vertex: usize,
    face: Option<usize>,
    roles: Vec<Vec<Role>>,
}

fn plan(header: &Header, path: &Path) -> Result<Plan> {
    let err = |msg: String| SceneError::parse(path, Location::Header, msg);
    let vertex = header
        .elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| err("no 'vertex' element".into()))?;
    let face = header.elements.iter().position(|e| e.name == "face");
    let mut roles: Vec<Vec<Role>> = header
        .elements
        .iter()
        .map(|e| vec![Role::Skip; e.props.len()])
        .collect();
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        let el = &header.elements[vertex];
        let p = el
            .property(axis)
            .ok_or_else(|| err(format!("the vertex element has no '{axis}' property")))?;
        if !matches!(el.props[p].kind, Kind::Scalar(_)) {
            return Err(err(format!("vertex property '{axis}' is a list")));
        }
        roles[vertex][p] = Role::Coord(k);
    }
    // Normals (nx, ny, nz; vp-mvs's and COLMAP's fused.ply): all three
    // scalars or none used.
    let el = &header.elements[vertex];
    let normal = ["nx", "ny", "nz"].map(|n| {
        el.property(n)
            .filter(|&p| matches!(el.props[p].kind, Kind::Scalar(_)))
    });
    if let [Some(x), Some(y), Some(z)] = normal {
        for (k, p) in [x, y, z].into_iter().enumerate() {
            roles[vertex][p] = Role::Normal(k);
        }
    }
    if let Some(f) = face {
        let el = &header.elements[f];
        let p = el
            .property("vertex_indices")
            .or_else(|| el.property("vertex_index"))
            .ok_or_else(|| {
                err("the face element has no 'vertex_indices' (or 'vertex_index') list".into())
            })?;
        match el.props[p].kind {
            Kind::List { item, .. } if item.is_integer() => roles[f][p] = Role::Indices,
            _ => {
                return Err(err(format!(
                    "face property '{}' must be a list of integers",
                    el.props[p].name
                )))
            }
        }
        if let Some(m) = el.property("material") {
            match el.props[m].kind {
                Kind::Scalar(s) if s.is_integer() => roles[f][m] = Role::Material,
                _ => return Err(err("face property 'material' must be an integer".into())),
            }
        }
    }
    Ok(Plan {
        vertex,
        face,
        roles,
    })
}

/// Collects the mesh while a body reader walks the file, and watches for the
/// element a caller wants located.
struct Builder {
    vertices: Vec<Point3<f64>>,
    faces: Vec<[u32; 3]>,
    materials: Option<Vec<Material>>,
    normals: Option<Vec<Vector3<f64>>>,
    target: Option<Target>,
}

impl Builder {
    fn new(header: &Header, plan: &Plan, body_len: usize, target: Option<Target>) -> Self {
        // Never trust a header count for an allocation: cap it by what the
        // rest of the file could possibly hold.
        let cap = |e: &Element| (e.count as usize).min(body_len / e.min_size().max(1));
        let face_cap = plan.face.map_or(0, |f| cap(&header.elements[f]));
        let has_material = plan
            .face
            .is_some_and(|f| plan.roles[f].contains(&Role::Material));
        Builder {
            vertices: Vec::with_capacity(cap(&header.elements[plan.vertex])),
            faces: Vec::with_capacity(face_cap),
            materials: has_material.then(|| Vec::with_capacity(face_cap)),
            normals: plan.roles[plan.vertex]
                .contains(&Role::Normal(0))
                .then(|| Vec::with_capacity(cap(&header.elements[plan.vertex]))),
            target,
        }
    }

    /// Adds a polygon's fan triangles; `indices` yields the raw list values.
    fn polygon(
        &mut self,
        n: usize,
        mut indices: impl FnMut(usize) -> std::result::Result<i64, String>,
    ) -> std::result::Result<(), String> {
        if n < 3 {
            return Err(format!(
                "the list has {n} vertex indices; a face needs at least 3"
            ));
        }
        let vertex = |raw: i64| {
            u32::try_from(raw).map_err(|_| format!("vertex index {raw} is not a valid index"))
        };
        let first = vertex(indices(0)?)?;
        let mut prev = vertex(indices(1)?)?;
        for k in 2..n {
            let cur = vertex(indices(k)?)?;
            self.faces.push([first, prev, cur]);
            prev = cur;
        }
        Ok(())
    }

    /// Records the material of the face just read, for all its triangles.
    fn face_material(&mut self, id: i64) -> std::result::Result<(), String> {
        let Some(materials) = &mut self.materials else {
            return Ok(());
        };
        let material = u8::try_from(id)
            .ok()
            .and_then(Material::from_id)
            .ok_or_else(|| format!("unknown material id {id} ({})", known_materials()))?;
        materials.resize(self.faces.len(), material);
        Ok(())
    }

    /// Whether the vertex or face just read is the located target.
    fn hit(&self, is_vertex: bool, first_triangle: usize) -> bool {
        match self.target {
            Some(Target::Vertex(v)) => is_vertex && v + 1 == self.vertices.len(),
            Some(Target::Triangle(t)) => {
                !is_vertex && (first_triangle..self.faces.len()).contains(&t)
            }
            None => false,
        }
    }

    /// Records a vertex and its normal (kept only if the file has normals).
    fn vertex(&mut self, v: [f64; 6]) {
        self.vertices.push(Point3::new(v[0], v[1], v[2]));
        if let Some(normals) = &mut self.normals {
            normals.push(Vector3::new(v[3], v[4], v[5]));
        }
    }

    fn finish(self) -> (Mesh, Option<Vec<Vector3<f64>>>) {
        (
            Mesh {
                vertices: self.vertices,
                faces: self.faces,
                materials: self.materials,
            },
            self.normals,
        )
    }
}

/// "0 ground, 1 rock, ..." for error messages.
pub(crate) fn known_materials() -> String {
    let names: Vec<String> = Material::ALL
        .iter()
        .map(|m| format!("{} {}", *m as u8, m.name()))
        .collect();
    format!("known: {}", names.join(", "))
}

/// What [`read_body`] read.
struct Body {
    mesh: Mesh,
    normals: Option<Vec<Vector3<f64>>>,
    found: Option<Found>,
    warnings: Vec<ReadWarning>,
}

/// Reads the body, stopping early with the target's location if one is set.
fn read_body(bytes: &[u8], path: &Path, target: Option<Target>) -> Result<Body> {
    let header = header::parse(bytes, path)?;
    let plan = plan(&header, path)?;
    let body = &bytes[header.body_start..];
    let mut builder = Builder::new(&header, &plan, body.len(), target);
    let found = match header.encoding {
        Encoding::Ascii => ascii::read(bytes, &header, &plan, path, &mut builder)?,
        Encoding::BinaryLittleEndian => {
            binary::read::<binary::Le>(bytes, &header, &plan, path, &mut builder)?
        }
        Encoding::BinaryBigEndian => {
            binary::read::<binary::Be>(bytes, &header, &plan, path, &mut builder)?
        }
    };
    let (mesh, normals) = builder.finish();
    let warnings = header
        .notes
        .into_iter()
        .map(|(line, message)| ReadWarning {
            path: path.to_path_buf(),
            location: Location::Line(line),
            message,
        })
        .collect();
    Ok(Body {
        mesh,
        normals,
        found,
        warnings,
    })
}

/// Parses a whole PLY file with what it read with a warning. Only format
/// errors are reported; the mesh may still hold out-of-range indices or
/// non-finite coordinates.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<(Mesh, Vec<ReadWarning>)> {
    let body = read_body(bytes, path, None)?;
    Ok((body.mesh, body.warnings))
}

/// [`parse`] with the vertex normals (`nx ny nz`), if the file has them:
/// one per vertex.
pub(crate) fn parse_with_normals(bytes: &[u8], path: &Path) -> Result<PointFile> {
    let body = read_body(bytes, path, None)?;
    Ok(PointFile {
        points: body.mesh.vertices,
        normals: body.normals,
        warnings: body.warnings,
    })
}

/// Where in the file a vertex or triangle of the parsed mesh came from.
pub(crate) fn locate(bytes: &[u8], path: &Path, target: Target) -> Option<Found> {
    read_body(bytes, path, Some(target)).ok()?.found
}

#[cfg(test)]
mod tests;
