use nalgebra::Point3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

/// Closest point on triangle `abc` to `p` (Ericson, Real-Time Collision
/// Detection, 5.1.5), in f64: the brute-force reference.
fn closest_on_triangle(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Point3<f64> {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

fn brute_point_distance(mesh: &Mesh, p: &Point3<f64>) -> f64 {
    (0..mesh.n_faces())
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            (closest_on_triangle(p, &a, &b, &c) - p).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Segment-to-mesh distance by dense sampling plus ternary refinement around
/// the best sample: an independent reference (the distance along a segment
/// is a minimum of convex functions, so a fine sampling brackets it).
fn brute_segment_distance(mesh: &Mesh, a: &Point3<f64>, b: &Point3<f64>) -> f64 {
    let n = 400;
    let at = |s: f64| brute_point_distance(mesh, &(a + (b - a) * s));
    let (mut best_s, mut best) = (0.0, f64::INFINITY);
    for i in 0..=n {
        let s = f64::from(i) / f64::from(n);
        let d = at(s);
        if d < best {
            (best_s, best) = (s, d);
        }
    }
    let (mut lo, mut hi) = (
        (best_s - 1.0 / f64::from(n)).max(0.0),
        (best_s + 1.0 / f64::from(n)).min(1.0),
    );
    for _ in 0..60 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if at(m1) < at(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    best.min(at(0.5 * (lo + hi)))
}

fn terrain(seed: u64) -> Mesh {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = 12;
    let mut vertices = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            vertices.push(Point3::new(
                f64::from(i) * 2.0 + 700.0,
                f64::from(j) * 2.0,
                rng.random_range(0.0..3.0),
            ));
        }
    }
    let mut faces = Vec::new();
    let w = n + 1;
    for j in 0..n {
        for i in 0..n {
            let v = j * w + i;
            faces.push([v, v + 1, v + w + 1]);
            faces.push([v, v + w + 1, v + w]);
        }
    }
    Mesh::new(vertices, faces, None).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn point_distance_equals_brute_force(seed in any::<u64>()) {
        let mesh = terrain(seed);
        let clearance = Clearance::new(&mesh);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 1);
        for _ in 0..100 {
            let p = Point3::new(rng.random_range(695.0..730.0), rng.random_range(-5.0..30.0), rng.random_range(-2.0..12.0));
            let exact = brute_point_distance(&mesh, &p);
            let d = clearance.distance(&p);
            prop_assert!((d - exact).abs() < 1e-4, "{d} vs {exact}");
            // The bounded check agrees with the exact distance away from the boundary.
            for r in [0.5, 1.0, 2.5, 5.0] {
                if (exact - r).abs() > 1e-3 {
                    prop_assert_eq!(clearance.point_is_clear(&p, r), exact >= r);
                }
            }
        }
    }

    #[test]
    fn segment_distance_equals_brute_force(seed in any::<u64>()) {
        let mesh = terrain(seed);
        let clearance = Clearance::new(&mesh);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 2);
        for _ in 0..6 {
            let a = Point3::new(rng.random_range(695.0..730.0), rng.random_range(-5.0..30.0), rng.random_range(2.0..10.0));
            let b = Point3::new(rng.random_range(695.0..730.0), rng.random_range(-5.0..30.0), rng.random_range(2.0..10.0));
            let exact = brute_segment_distance(&mesh, &a, &b);
            let d = clearance.segment_distance(&a, &b);
            prop_assert!((d - exact).abs() < 1e-3, "{d} vs {exact}");
            for r in [0.5, 1.0, 2.5, 5.0] {
                if (exact - r).abs() > 1e-3 {
                    prop_assert_eq!(clearance.segment_is_clear(&a, &b, r), exact >= r);
                }
            }
        }
    }
}

#[test]
fn segment_through_a_wall_has_zero_clearance() {
    let v = vec![
        Point3::new(5.0, -10.0, 0.0),
        Point3::new(5.0, 10.0, 0.0),
        Point3::new(5.0, 10.0, 10.0),
        Point3::new(5.0, -10.0, 10.0),
    ];
    let wall = Mesh::new(v, vec![[0, 1, 2], [0, 2, 3]], None).unwrap();
    let c = Clearance::new(&wall);
    let (a, b) = (Point3::new(0.0, 0.0, 5.0), Point3::new(10.0, 0.0, 5.0));
    // Both ends are 5 m from the wall, but the segment crosses it.
    assert!((c.distance(&a) - 5.0).abs() < 1e-5);
    assert!(c.point_is_clear(&a, 4.0) && c.point_is_clear(&b, 4.0));
    assert!(c.segment_distance(&a, &b) < 1e-5);
    assert!(!c.segment_is_clear(&a, &b, 0.1));
    // Over the wall top with 2 m to spare.
    let (a, b) = (Point3::new(0.0, 0.0, 12.0), Point3::new(10.0, 0.0, 12.0));
    assert!((c.segment_distance(&a, &b) - 2.0).abs() < 1e-5);
    assert!(c.segment_is_clear(&a, &b, 1.9) && !c.segment_is_clear(&a, &b, 2.1));
}

#[test]
fn empty_mesh_is_clear_everywhere() {
    let c = Clearance::new(&Mesh::default());
    assert!(c.distance(&Point3::origin()).is_infinite());
    assert!(c.segment_is_clear(&Point3::origin(), &Point3::new(1.0, 0.0, 0.0), 100.0));
}
