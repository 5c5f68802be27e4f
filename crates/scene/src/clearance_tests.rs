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

/// Distance between segments `p1`-`q1` and `p2`-`q2` (Ericson, Real-Time
/// Collision Detection, 5.1.9), in f64.
fn segment_segment_distance(
    p1: &Point3<f64>,
    q1: &Point3<f64>,
    p2: &Point3<f64>,
    q2: &Point3<f64>,
) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    let (s, t) = if a <= 1e-18 && e <= 1e-18 {
        (0.0, 0.0)
    } else if a <= 1e-18 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= 1e-18 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-18 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).norm()
}

/// Whether segment `p`-`q` crosses triangle `abc` (Moller-Trumbore).
fn segment_crosses_triangle(
    p: &Point3<f64>,
    q: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> bool {
    let (dir, e1, e2) = (q - p, b - a, c - a);
    let h = dir.cross(&e2);
    let det = e1.dot(&h);
    if det.abs() < 1e-15 {
        return false; // parallel: the edge distances below cover it
    }
    let s = p - a;
    let u = s.dot(&h) / det;
    let qv = s.cross(&e1);
    let v = dir.dot(&qv) / det;
    let t = e2.dot(&qv) / det;
    (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&t)
}

/// Exact segment-to-mesh distance, an independent reference: per triangle,
/// zero if the segment crosses it, else the least of the endpoints' distances
/// to the triangle and the segment's distances to the three edges.
fn brute_segment_distance(mesh: &Mesh, p: &Point3<f64>, q: &Point3<f64>) -> f64 {
    (0..mesh.n_faces())
        .map(|f| {
            let [a, b, c] = mesh.triangle(f);
            if segment_crosses_triangle(p, q, &a, &b, &c) {
                return 0.0;
            }
            [
                (closest_on_triangle(p, &a, &b, &c) - p).norm(),
                (closest_on_triangle(q, &a, &b, &c) - q).norm(),
                segment_segment_distance(p, q, &a, &b),
                segment_segment_distance(p, q, &b, &c),
                segment_segment_distance(p, q, &c, &a),
            ]
            .into_iter()
            .fold(f64::INFINITY, f64::min)
        })
        .fold(f64::INFINITY, f64::min)
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
            // GJK's relative tolerance (seen 4.1 mm over at 5.61 m) and
            // early contact (seen 7 mm under).
            let over = exact * GJK_RELATIVE_TOLERANCE + 1e-4;
            prop_assert!(d < exact + over && d > exact - CONTACT_TOLERANCE_M, "{d} vs {exact}");
            // Never clear when closer than r (a crash); may report contact
            // up to CONTACT_TOLERANCE_M before it happens (conservative).
            for r in [0.5, 1.0, 2.5, 5.0] {
                if clearance.segment_is_clear(&a, &b, r) {
                    prop_assert!(exact > r - 1e-3, "clear at {exact} < {r}");
                } else {
                    prop_assert!(exact < r + CONTACT_TOLERANCE_M, "contact at {exact} > {r}");
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
