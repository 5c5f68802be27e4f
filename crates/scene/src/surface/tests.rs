use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

/// A jittered grid on the plane z = height(x, y) over [-s, s]^2, seen from
/// two cameras above (no normals).
fn terrain(s: f64, step: f64, height: impl Fn(f64, f64) -> f64) -> Vec<SurfaceSample> {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = (2.0 * s / step) as i32;
    let mut out = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let x = -s + f64::from(i) * step + rng.random_range(-0.2..0.2) * step;
            let y = -s + f64::from(j) * step + rng.random_range(-0.2..0.2) * step;
            out.push(SurfaceSample {
                position: Point3::new(x, y, height(x, y)),
                normal: None,
                seen_from: vec![Point3::new(-20.0, 0.0, 30.0), Point3::new(20.0, 5.0, 25.0)],
            });
        }
    }
    out
}

fn sphere(n: usize, r: f64) -> Vec<SurfaceSample> {
    // Fibonacci sphere: even spacing, normals given.
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let rho = (1.0 - z * z).sqrt();
            let a = golden * i as f64;
            let d = Vector3::new(rho * a.cos(), rho * a.sin(), z);
            SurfaceSample {
                position: Point3::from(d * r),
                normal: Some(d),
                seen_from: Vec::new(),
            }
        })
        .collect()
}

fn max_vertex_error(mesh: &Mesh, f: impl Fn(&Point3<f64>) -> f64) -> f64 {
    mesh.vertices.iter().map(f).fold(0.0, f64::max)
}

#[test]
fn flat_ground_from_viewpoints_is_flat_and_faces_up() {
    let samples = terrain(10.0, 0.3, |_, _| 1.0);
    let (mesh, report) =
        reconstruct_surface_with_report(&samples, &SurfaceParams::default()).unwrap();
    mesh.validate().unwrap();
    let err = max_vertex_error(&mesh, |p| (p.z - 1.0).abs());
    assert!(err < 0.05, "vertex off the plane by {err} m");
    // The plane may overshoot the samples' square by up to the trim distance.
    let area: f64 = mesh.face_areas().iter().sum();
    let most = (20.0 + 2.0 * report.trim_distance).powi(2);
    assert!(
        area > 0.97 * 400.0 && area < most,
        "area {area}, at most {most}"
    );
    let up = mesh.face_normals().iter().filter(|n| n.z > 0.9).count();
    assert_eq!(up, mesh.n_faces(), "every face must face the cameras (+z)");
}

#[test]
fn sphere_with_normals_is_round_and_closed() {
    let samples = sphere(4000, 5.0);
    let params = SurfaceParams {
        cell_size: 0.25,
        ..SurfaceParams::default()
    };
    let (mesh, report) = reconstruct_surface_with_report(&samples, &params).unwrap();
    assert_eq!(report.estimated_normals, 0);
    let err = max_vertex_error(&mesh, |p| (p.coords.norm() - 5.0).abs());
    assert!(err < 0.1, "vertex off the sphere by {err} m");
    let area: f64 = mesh.face_areas().iter().sum();
    let want = 4.0 * std::f64::consts::PI * 25.0;
    assert!((area - want).abs() < 0.05 * want, "area {area} vs {want}");
    // Outward: the face normal agrees with the radial direction.
    for f in 0..mesh.n_faces() {
        assert!(mesh.face_normal(f).dot(&mesh.face_centroid(f).coords) > 0.0);
    }
}

#[test]
fn trimming_keeps_a_hole_open() {
    // A 20 m square with a 6 m hole: Poisson would bridge it; trimming at
    // 1 m must leave it open.
    let samples: Vec<SurfaceSample> = terrain(10.0, 0.3, |_, _| 0.0)
        .into_iter()
        .filter(|s| s.position.x.abs() > 3.0 || s.position.y.abs() > 3.0)
        .collect();
    let params = SurfaceParams {
        trim_distance: Some(1.0),
        ..SurfaceParams::default()
    };
    let mesh = reconstruct_surface(&samples, &params).unwrap();
    let in_hole = (0..mesh.n_faces())
        .filter(|&f| {
            let c = mesh.face_centroid(f);
            c.x.abs() < 1.5 && c.y.abs() < 1.5
        })
        .count();
    assert_eq!(
        in_hole, 0,
        "faces invented in the middle of the unseen hole"
    );
}

#[test]
fn same_input_gives_the_same_mesh() {
    let samples = terrain(6.0, 0.25, |x, y| 0.3 * (0.5 * x).sin() + 0.2 * y);
    let a = reconstruct_surface(&samples, &SurfaceParams::default()).unwrap();
    for _ in 0..3 {
        let b = reconstruct_surface(&samples, &SurfaceParams::default()).unwrap();
        assert_eq!(a.vertices, b.vertices);
        assert_eq!(a.faces, b.faces);
    }
}

fn surface_error(samples: &[SurfaceSample]) -> String {
    match reconstruct_surface(samples, &SurfaceParams::default()) {
        Ok(m) => panic!("accepted, {} faces", m.n_faces()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn too_few_samples_are_refused_with_the_minimum() {
    let samples = terrain(1.0, 0.5, |_, _| 0.0); // 25 samples
    let e = surface_error(&samples[..MIN_SURFACE_SAMPLES - 1]);
    assert!(e.contains("19 samples given, at least 20"), "{e}");
}

#[test]
fn a_sample_without_normal_or_viewpoint_is_named() {
    let mut samples = terrain(3.0, 0.5, |_, _| 0.0);
    samples[7].seen_from.clear();
    let e = surface_error(&samples);
    assert!(
        e.contains("sample 7") && e.contains("neither a normal nor a camera"),
        "{e}"
    );
}

#[test]
fn non_finite_input_is_named() {
    let mut samples = terrain(3.0, 0.5, |_, _| 0.0);
    samples[3].position.y = f64::NAN;
    let e = surface_error(&samples);
    assert!(e.contains("sample 3 has a non-finite position"), "{e}");
    let mut samples = terrain(3.0, 0.5, |_, _| 0.0);
    samples[4].normal = Some(Vector3::zeros());
    let e = surface_error(&samples);
    assert!(e.contains("sample 4 has an unusable normal"), "{e}");
    let mut samples = terrain(3.0, 0.5, |_, _| 0.0);
    samples[5]
        .seen_from
        .push(Point3::new(0.0, f64::INFINITY, 1.0));
    let e = surface_error(&samples);
    assert!(
        e.contains("sample 5 is seen from a non-finite camera"),
        "{e}"
    );
}

#[test]
fn degenerate_sets_are_refused() {
    let at = |p: Point3<f64>| SurfaceSample {
        position: p,
        normal: Some(Vector3::z()),
        seen_from: Vec::new(),
    };
    let same: Vec<_> = (0..50).map(|_| at(Point3::new(1.0, 2.0, 3.0))).collect();
    assert!(surface_error(&same).contains("all 50 samples are at one point"));
    let line: Vec<_> = (0..50)
        .map(|i| at(Point3::new(f64::from(i), 2.0 * f64::from(i), 3.0)))
        .collect();
    assert!(surface_error(&line).contains("all 50 samples lie on one line"));
}

#[test]
fn bad_parameters_are_refused_by_name() {
    let samples = terrain(3.0, 0.5, |_, _| 0.0);
    let params = SurfaceParams {
        cell_size: 0.0,
        ..SurfaceParams::default()
    };
    let e = reconstruct_surface(&samples, &params)
        .unwrap_err()
        .to_string();
    assert!(e.contains("cell_size = 0"), "{e}");
    let e = toml::from_str::<SurfaceParams>("cell_sise = 1.0").unwrap_err();
    assert!(e.to_string().contains("cell_sise"), "{e}");
}

#[test]
fn poisson_solver_meshes_a_small_sphere() {
    // Depth 4 (8 m extent at 0.5 m): the crate is quick at small depths.
    let samples = sphere(1500, 4.0);
    let params = SurfaceParams {
        solver: SurfaceSolver::Poisson,
        ..SurfaceParams::default()
    };
    let (mesh, report) = reconstruct_surface_with_report(&samples, &params).unwrap();
    assert_eq!(report.depth, 4);
    let err = max_vertex_error(&mesh, |p| (p.coords.norm() - 4.0).abs());
    assert!(err < 0.3, "vertex off the sphere by {err} m");
    let area: f64 = mesh.face_areas().iter().sum();
    let want = 4.0 * std::f64::consts::PI * 16.0;
    assert!((area - want).abs() < 0.15 * want, "area {area} vs {want}");
}
