use std::collections::HashMap;

use nalgebra::Point3;

use super::*;
use crate::camera::Intrinsics;
use crate::mesh::Material;
use crate::raycast::RayCaster;
use crate::roi::Roi;
use crate::Camera;

/// Closed octahedron with radius `r`, outward faces.
fn octahedron(r: f64) -> Mesh {
    let v = vec![
        Point3::new(r, 0.0, 0.0),
        Point3::new(-r, 0.0, 0.0),
        Point3::new(0.0, r, 0.0),
        Point3::new(0.0, -r, 0.0),
        Point3::new(0.0, 0.0, r),
        Point3::new(0.0, 0.0, -r),
    ];
    let f = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    Mesh::new(v, f, Some(vec![Material::Rock; 8])).unwrap()
}

fn sphere(r: f64, max_edge: f64) -> Mesh {
    let (mut m, _) = split_faces(&octahedron(r), max_edge).unwrap();
    for p in &mut m.vertices {
        *p = Point3::from(p.coords.normalize() * r);
    }
    m
}

fn edge_use_counts(m: &Mesh) -> HashMap<(u32, u32), usize> {
    let mut counts = HashMap::new();
    for f in &m.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *counts.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    counts
}

#[test]
fn split_bounds_edges_keeps_area_and_stays_conforming() {
    let m = octahedron(10.0);
    let area: f64 = m.face_areas().iter().sum();
    let (s, parent) = split_faces(&m, 1.5).unwrap();
    assert!(s.n_faces() > 100);
    for f in 0..s.n_faces() {
        let [a, b, c] = s.triangle(f);
        assert!((b - a).norm().max((c - b).norm()).max((a - c).norm()) <= 1.5 + 1e-12);
    }
    let split_area: f64 = s.face_areas().iter().sum();
    assert!((area - split_area).abs() < 1e-9 * area);
    // Each parent's children cover exactly its area.
    for p in 0..m.n_faces() {
        let child_area: f64 = (0..s.n_faces())
            .filter(|&f| parent[f] as usize == p)
            .map(|f| s.face_area(f))
            .sum();
        assert!((child_area - m.face_area(p)).abs() < 1e-9);
    }
    // Closed input stays closed: every edge is used by exactly two faces
    // (a T-junction would leave edges used once).
    assert!(edge_use_counts(&s).values().all(|&c| c == 2));
    assert_eq!(s.materials.as_ref().unwrap().len(), s.n_faces());
    s.validate().unwrap();
    // Normals keep their orientation.
    for (f, &p) in parent.iter().enumerate() {
        assert!(s.face_normal(f).dot(&m.face_normal(p as usize)) > 0.999);
    }
}

#[test]
fn split_with_large_limit_is_identity_and_rejects_bad_limits() {
    let m = octahedron(1.0);
    let (s, parent) = split_faces(&m, 10.0).unwrap();
    assert_eq!(s, m);
    assert_eq!(parent, (0..8).collect::<Vec<u32>>());
    assert!(split_faces(&m, 0.0).is_err());
    assert!(split_faces(&m, f64::NAN).is_err());
}

#[test]
fn shrunk_sphere_lies_inside_and_expanded_outside() {
    let r = 5.0;
    let m = sphere(r, 0.8);
    let se = shrink_and_expand(&m, 3);
    let radius = |mesh: &Mesh| {
        mesh.vertices.iter().map(|p| p.coords.norm()).sum::<f64>() / mesh.n_vertices() as f64
    };
    let (rs, re) = (radius(&se.shrunk), radius(&se.expanded));
    assert!(rs < r - 1e-3, "shrunk radius {rs}");
    assert!(re > r + 1e-3, "expanded radius {re}");
    // Expansion moves back out by about twice the shrink: r_e - r ~ r - r_s.
    assert!(
        (re - r) > 0.5 * (r - rs) && (re - r) < 2.0 * (r - rs),
        "r {r} rs {rs} re {re}"
    );
    // A flat plane does not move (interior vertices).
    let plane = Mesh::new(
        (0..5)
            .flat_map(|j| (0..5).map(move |i| Point3::new(f64::from(i), f64::from(j), 0.0)))
            .collect(),
        (0..4u32)
            .flat_map(|j| {
                (0..4u32).flat_map(move |i| {
                    [
                        [j * 5 + i, j * 5 + i + 1, j * 5 + i + 6],
                        [j * 5 + i, j * 5 + i + 6, j * 5 + i + 5],
                    ]
                })
            })
            .collect(),
        None,
    )
    .unwrap();
    let se = shrink_and_expand(&plane, 3);
    assert!(se.shrunk.vertices.iter().all(|p| p.z == 0.0));
}

fn grid(n: u32, spacing: f64) -> Mesh {
    let w = n + 1;
    let vertices = (0..w)
        .flat_map(|j| {
            (0..w).map(move |i| Point3::new(f64::from(i) * spacing, f64::from(j) * spacing, 0.0))
        })
        .collect();
    let faces = (0..n)
        .flat_map(|j| {
            (0..n).flat_map(move |i| {
                [
                    [j * w + i, j * w + i + 1, (j + 1) * w + i + 1],
                    [j * w + i, (j + 1) * w + i + 1, (j + 1) * w + i],
                ]
            })
        })
        .collect();
    Mesh::new(vertices, faces, None).unwrap()
}

#[test]
fn roi_box_and_ground_polygon_select_by_centroid() {
    let m = grid(10, 1.0);
    let caster = RayCaster::new(&m);
    let b = Roi::Box {
        min: [0.0, 0.0, -1.0],
        max: [5.0, 5.0, 1.0],
    };
    assert_eq!(b.select(&m, &caster).unwrap().len(), 50);
    // Triangle polygon x + y < 10.5 (no centroid on its border).
    let p = Roi::Polygon {
        polygon: vec![[0.0, 0.0], [10.5, 0.0], [0.0, 10.5]],
        holes: Vec::new(),
        z_min: -1.0,
        z_max: 1.0,
    };
    let sel = p.select(&m, &caster).unwrap();
    // Cells (i, j) with i + j <= 9: 55 cells of 2 faces.
    assert!(sel.iter().all(|&f| {
        let c = m.face_centroid(f as usize);
        c.x + c.y < 10.5
    }));
    assert_eq!(sel.len(), 110);
    // A hole over cells (0..2, 0..2) takes their 8 faces out.
    let holed = Roi::Polygon {
        polygon: vec![[0.0, 0.0], [10.5, 0.0], [0.0, 10.5]],
        holes: vec![vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]],
        z_min: -1.0,
        z_max: 1.0,
    };
    assert_eq!(holed.select(&m, &caster).unwrap().len(), 102);
    // Height range excludes everything.
    let high = Roi::Polygon {
        polygon: vec![[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]],
        holes: Vec::new(),
        z_min: 1.0,
        z_max: 2.0,
    };
    assert!(high.select(&m, &caster).unwrap().is_empty());
    let bad = Roi::Polygon {
        polygon: vec![[0.0, 0.0], [1.0, 0.0]],
        holes: Vec::new(),
        z_min: 0.0,
        z_max: 1.0,
    };
    assert!(bad.select(&m, &caster).is_err());
}

#[test]
fn roi_image_polygon_selects_visible_faces_inside_the_drawn_polygon() {
    let mut m = grid(10, 1.0);
    // A roof over x in 0..3 hides the ground below it from the camera.
    let base = m.vertices.len() as u32;
    m.vertices.extend([
        Point3::new(0.0, -1.0, 5.0),
        Point3::new(3.0, -1.0, 5.0),
        Point3::new(3.0, 11.0, 5.0),
        Point3::new(0.0, 11.0, 5.0),
    ]);
    m.faces
        .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    let caster = RayCaster::new(&m);
    let k = Intrinsics::from_hfov(1000, 1000, 90.0).unwrap();
    let cam = Camera::from_yaw_pitch(
        k,
        Point3::new(5.0, 5.0, 30.0),
        0.0,
        -std::f64::consts::FRAC_PI_2,
    );
    // The whole image.
    let roi = Roi::ImagePolygon {
        camera: cam,
        polygon: vec![[0.0, 0.0], [1000.0, 0.0], [1000.0, 1000.0], [0.0, 1000.0]],
    };
    let sel = roi.select(&m, &caster).unwrap();
    // A ground face is selected exactly when the ray from the camera to its
    // centroid passes the roof's height (z = 5) beside the roof (x > 3).
    for f in 0..200u32 {
        let c = m.face_centroid(f as usize);
        let x_at_roof = 5.0 + (c.x - 5.0) * 25.0 / 30.0;
        assert_eq!(sel.contains(&f), x_at_roof > 3.0, "face {f} at {c}");
    }
    assert!(sel.contains(&(m.n_faces() as u32 - 1)));
}

#[test]
fn submesh_keeps_geometry_and_materials() {
    let m = octahedron(2.0);
    let s = submesh(&m, &[1, 5]);
    assert_eq!(s.n_faces(), 2);
    assert_eq!(s.n_vertices(), 4);
    assert!((s.face_area(0) - m.face_area(1)).abs() < 1e-12);
    assert_eq!(s.materials.unwrap(), vec![Material::Rock; 2]);
}
