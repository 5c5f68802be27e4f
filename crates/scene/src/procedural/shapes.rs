//! Simple shapes for unit tests: plane, box, icosphere, heightfield, cylinder.
//!
//! All faces are counter-clockwise seen from outside (closed shapes) or from
//! above (planes and heightfields), so face normals point outward / up. Every
//! face carries [`Material::Ground`]; use [`with_material`] to change it.
//!
//! Arguments are the programmer's, not a user's: non-finite or non-positive
//! sizes panic (documented per function).

use std::collections::HashMap;

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use crate::mesh::{Material, Mesh};

/// The same mesh with every face of material `m`.
pub fn with_material(mut mesh: Mesh, m: Material) -> Mesh {
    mesh.materials = Some(vec![m; mesh.faces.len()]);
    mesh
}

fn ground(vertices: Vec<Point3<f64>>, faces: Vec<[u32; 3]>) -> Mesh {
    let n = faces.len();
    Mesh {
        vertices,
        faces,
        materials: Some(vec![Material::Ground; n]),
    }
}

/// Regular grid of `nx` x `ny` cells with corner `(x0, y0)` and cell size
/// `(dx, dy)`, heights from `z(k, x, y)` for vertex index k. Vertex (i, j)
/// has index `k = j * (nx + 1) + i`;
/// each cell gives two faces, counter-clockwise from above. Heights are
/// evaluated in parallel but collected in order (deterministic).
pub(crate) fn grid<F>(
    origin: (f64, f64),
    cell: (f64, f64),
    nx: usize,
    ny: usize,
    z: F,
) -> (Vec<Point3<f64>>, Vec<[u32; 3]>)
where
    F: Fn(usize, f64, f64) -> f64 + Sync,
{
    let (x0, y0) = origin;
    let (dx, dy) = cell;
    let row = nx + 1;
    let vertices = (0..row * (ny + 1))
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % row, k / row);
            let (x, y) = (x0 + i as f64 * dx, y0 + j as f64 * dy);
            Point3::new(x, y, z(k, x, y))
        })
        .collect();
    let mut faces = Vec::with_capacity(2 * nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            let v00 = (j * row + i) as u32;
            let v10 = v00 + 1;
            let v01 = v00 + row as u32;
            let v11 = v01 + 1;
            faces.push([v00, v10, v11]);
            faces.push([v00, v11, v01]);
        }
    }
    (vertices, faces)
}

fn check_size(what: &str, v: f64) {
    assert!(v.is_finite() && v > 0.0, "{what} must be positive, got {v}");
}

/// Flat rectangle at z = 0 centred on the origin, `size_x` x `size_y` metres,
/// split into `nx` x `ny` cells (at least one each), normal +z.
///
/// # Panics
/// If a size is not a positive finite number.
pub fn plane(size_x: f64, size_y: f64, nx: usize, ny: usize) -> Mesh {
    check_size("size_x", size_x);
    check_size("size_y", size_y);
    let (nx, ny) = (nx.max(1), ny.max(1));
    let (v, f) = grid(
        (-0.5 * size_x, -0.5 * size_y),
        (size_x / nx as f64, size_y / ny as f64),
        nx,
        ny,
        |_, _, _| 0.0,
    );
    ground(v, f)
}

/// Heightfield of `nx` x `ny` square cells of side `spacing`, centred on the
/// origin in x and y, with z = `height(x, y)`; normals point up.
///
/// # Panics
/// If `spacing` is not a positive finite number.
pub fn heightfield<F>(nx: usize, ny: usize, spacing: f64, height: F) -> Mesh
where
    F: Fn(f64, f64) -> f64 + Sync,
{
    check_size("spacing", spacing);
    let (nx, ny) = (nx.max(1), ny.max(1));
    let (v, f) = grid(
        (-0.5 * spacing * nx as f64, -0.5 * spacing * ny as f64),
        (spacing, spacing),
        nx,
        ny,
        |_, x, y| height(x, y),
    );
    ground(v, f)
}

/// Closed axis-aligned box between `min` and `max`: 8 vertices, 12 faces,
/// normals outward; every edge is shared by exactly two faces.
///
/// # Panics
/// If the box is empty or flat along an axis.
pub fn box_mesh(min: Point3<f64>, max: Point3<f64>) -> Mesh {
    for k in 0..3 {
        check_size("box extent", max[k] - min[k]);
    }
    // Vertex k has x from bit 0, y from bit 1, z from bit 2.
    let vertices = (0..8)
        .map(|k| {
            Point3::new(
                if k & 1 == 0 { min.x } else { max.x },
                if k & 2 == 0 { min.y } else { max.y },
                if k & 4 == 0 { min.z } else { max.z },
            )
        })
        .collect();
    let quads: [[u32; 4]; 6] = [
        [0, 2, 3, 1], // z min, normal -z
        [4, 5, 7, 6], // z max, +z
        [0, 1, 5, 4], // y min, -y
        [2, 6, 7, 3], // y max, +y
        [0, 4, 6, 2], // x min, -x
        [1, 3, 7, 5], // x max, +x
    ];
    let faces = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    ground(vertices, faces)
}

/// Icosphere: an icosahedron whose faces are split in four `subdivisions`
/// times (20 * 4^s faces), vertices pushed onto the sphere. Closed, outward.
///
/// # Panics
/// If `radius` is not a positive finite number.
pub fn sphere(center: Point3<f64>, radius: f64, subdivisions: u32) -> Mesh {
    check_size("radius", radius);
    let t = f64::midpoint(1.0, 5f64.sqrt()); // golden ratio
    let mut dirs: Vec<Vector3<f64>> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vector3::from(*p).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        // The map only finds shared midpoints; new vertices are numbered in
        // face order, so the output does not depend on hashing.
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, dirs: &mut Vec<Vector3<f64>>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                dirs.push((dirs[a as usize] + dirs[b as usize]).normalize());
                (dirs.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for &[a, b, c] in &faces {
            let ab = midpoint(a, b, &mut dirs);
            let bc = midpoint(b, c, &mut dirs);
            let ca = midpoint(c, a, &mut dirs);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let vertices = dirs.iter().map(|d| center + d * radius).collect();
    ground(vertices, faces)
}

/// Open tube (no caps) from `base` to `top` with `sides` sides (at least 3)
/// and `segments` rings of quads (at least 1), radius varying linearly from
/// `radius_base` to `radius_top`; normals outward.
///
/// # Panics
/// If a radius is not positive or `base == top`.
pub fn cylinder(
    base: Point3<f64>,
    top: Point3<f64>,
    radius_base: f64,
    radius_top: f64,
    sides: usize,
    segments: usize,
) -> Mesh {
    check_size("radius_base", radius_base);
    check_size("radius_top", radius_top);
    let axis = top - base;
    check_size("cylinder length", axis.norm());
    let (sides, segments) = (sides.max(3), segments.max(1));
    let w = axis.normalize();
    // Any vector not parallel to the axis gives the ring's frame.
    let helper = if w.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = w.cross(&helper).normalize();
    let e2 = w.cross(&e1); // e1 x e2 = w: angles increase counter-clockwise about the axis
    let mut vertices = Vec::with_capacity(sides * (segments + 1));
    for j in 0..=segments {
        let s = j as f64 / segments as f64;
        let c = base + axis * s;
        let r = radius_base + (radius_top - radius_base) * s;
        for k in 0..sides {
            let a = std::f64::consts::TAU * k as f64 / sides as f64;
            vertices.push(c + (e1 * a.cos() + e2 * a.sin()) * r);
        }
    }
    let mut faces = Vec::with_capacity(2 * sides * segments);
    for j in 0..segments {
        for k in 0..sides {
            let a = (j * sides + k) as u32;
            let b = (j * sides + (k + 1) % sides) as u32;
            let c = b + sides as u32;
            let d = a + sides as u32;
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    ground(vertices, faces)
}

/// Undirected edges and how many faces use each (for closedness checks).
#[cfg(test)]
pub(crate) fn edge_use_counts(mesh: &Mesh) -> HashMap<(u32, u32), usize> {
    let mut m = HashMap::new();
    for f in &mesh.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *m.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total_area(m: &Mesh) -> f64 {
        m.face_areas().iter().sum()
    }

    /// Signed volume by the divergence theorem; positive for outward normals.
    fn volume(m: &Mesh) -> f64 {
        (0..m.n_faces())
            .map(|f| {
                let [a, b, c] = m.triangle(f);
                a.coords.dot(&b.coords.cross(&c.coords)) / 6.0
            })
            .sum()
    }

    #[test]
    fn plane_has_its_area_and_faces_up() {
        let m = plane(4.0, 3.0, 8, 5);
        m.validate().unwrap();
        assert_eq!(m.n_faces(), 2 * 8 * 5);
        assert!((total_area(&m) - 12.0).abs() < 1e-9);
        assert!(m
            .face_normals()
            .iter()
            .all(|n| (n - Vector3::z()).norm() < 1e-12));
        let b = m.bounds();
        assert_eq!((b.min.x, b.max.y, b.max.z), (-2.0, 1.5, 0.0));
    }

    #[test]
    fn box_is_closed_outward_with_its_volume() {
        let m = box_mesh(Point3::new(-1.0, 0.0, 2.0), Point3::new(2.0, 2.0, 2.5));
        m.validate().unwrap();
        assert_eq!(m.n_faces(), 12);
        assert!(edge_use_counts(&m).values().all(|&c| c == 2));
        assert!((volume(&m) - 3.0).abs() < 1e-12);
        assert!((total_area(&m) - 2.0 * (6.0 + 1.5 + 1.0)).abs() < 1e-12);
        let centre = Point3::new(0.5, 1.0, 2.25);
        for f in 0..m.n_faces() {
            assert!(m.face_normal(f).dot(&(m.face_centroid(f) - centre)) > 0.0);
        }
    }

    #[test]
    fn sphere_is_closed_outward_and_close_to_the_true_sphere() {
        let c = Point3::new(1.0, -2.0, 3.0);
        let r = 2.5;
        let m = sphere(c, r, 3);
        m.validate().unwrap();
        assert_eq!(m.n_faces(), 20 * 64);
        assert_eq!(m.n_vertices(), 10 * 64 + 2);
        assert!(edge_use_counts(&m).values().all(|&k| k == 2));
        assert!(m
            .vertices
            .iter()
            .all(|p| ((p - c).norm() - r).abs() < 1e-12));
        let area = total_area(&m) / (4.0 * std::f64::consts::PI * r * r);
        assert!(area > 0.98 && area < 1.0, "area ratio {area}");
        let vol = volume(&with_material(m.clone(), Material::Rock))
            / (4.0 / 3.0 * std::f64::consts::PI * r.powi(3));
        // Volume about the world origin equals the volume: closed surface.
        assert!(vol > 0.97 && vol < 1.0, "volume ratio {vol}");
        for f in 0..m.n_faces() {
            assert!(m.face_normal(f).dot(&(m.face_centroid(f) - c)) > 0.0);
        }
    }

    #[test]
    fn heightfield_follows_the_function_and_faces_up() {
        let m = heightfield(10, 6, 0.5, |x, y| 0.1 * x - 0.2 * y + 1.0);
        m.validate().unwrap();
        assert_eq!(m.n_faces(), 120);
        for p in &m.vertices {
            assert!((p.z - (0.1 * p.x - 0.2 * p.y + 1.0)).abs() < 1e-12);
        }
        assert!(m.face_normals().iter().all(|n| n.z > 0.9));
        // Planar: area = footprint * sqrt(1 + gx^2 + gy^2).
        let expect = 5.0 * 3.0 * (1.0f64 + 0.01 + 0.04).sqrt();
        assert!((total_area(&m) - expect).abs() < 1e-9);
    }

    #[test]
    fn cylinder_is_an_outward_tube() {
        let base = Point3::new(0.0, 0.0, 0.0);
        let top = Point3::new(0.0, 1.0, 4.0);
        let m = cylinder(base, top, 0.5, 0.5, 32, 3);
        m.validate().unwrap();
        assert_eq!(m.n_faces(), 2 * 32 * 3);
        let lateral = std::f64::consts::TAU * 0.5 * (17.0f64).sqrt();
        assert!((total_area(&m) / lateral - 1.0).abs() < 0.01);
        let w = (top - base).normalize();
        for f in 0..m.n_faces() {
            let c = m.face_centroid(f);
            let radial = (c - base) - w * (c - base).dot(&w);
            assert!(m.face_normal(f).dot(&radial) > 0.0);
        }
    }
}
