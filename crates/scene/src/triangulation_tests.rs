use super::*;
use crate::Intrinsics;
use proptest::prelude::*;

fn cam_at(c: Point3<f64>) -> Camera {
    let k = Intrinsics::from_hfov(400, 300, 60.0).unwrap();
    Camera::look_at(k, c, Point3::new(0.0, 0.0, 0.0)).unwrap()
}

#[test]
fn angle_is_largest_pairwise_angle() {
    let p = Point3::origin();
    let cs = [
        Point3::new(10.0, 0.0, 10.0),
        Point3::new(-10.0, 0.0, 10.0),
        Point3::new(0.0, 0.0, 10.0),
    ];
    assert!((triangulation_angle_deg(&p, &cs) - 90.0).abs() < 1e-9);
    assert!(triangulation_angle_deg(&p, &cs[..1]).abs() < 1e-12);
    // A centre on the point has no ray: it is skipped, not NaN.
    let with_p = [cs[0], p, cs[2]];
    assert!((triangulation_angle_deg(&p, &with_p) - 45.0).abs() < 1e-9);
}

proptest! {
    /// The one-acos form agrees with the largest of the pairwise angles
    /// (what labelgen's copy computed) and with the unit-ray form (what the
    /// planner's copy computed).
    #[test]
    fn angle_forms_agree(cs in proptest::collection::vec((-50.0f64..50.0, -50.0f64..50.0, 1.0f64..60.0), 2..5)) {
        let p = Point3::origin();
        let centres: Vec<Point3<f64>> = cs.iter().map(|&(x, y, z)| Point3::new(x, y, z)).collect();
        let mut want = 0.0f64;
        for (i, a) in centres.iter().enumerate() {
            for b in &centres[i + 1..] {
                want = want.max((a - p).angle(&(b - p)));
            }
        }
        let units: Vec<Vector3<f64>> = centres.iter().map(|c| (c - p).normalize()).collect();
        let got = triangulation_angle_deg(&p, &centres);
        prop_assert!((got - want.to_degrees()).abs() < 1e-6, "{got} vs {}", want.to_degrees());
        prop_assert!((largest_pairwise_angle_deg(&units) - got).abs() < 1e-9);
    }
}

#[test]
fn closed_form_eigenvalues_match_decomposition() {
    let mats = [
        Matrix3::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 1.0),
        Matrix3::new(2.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 1.5),
        // Rank 2 plus a little, like a sum of camera informations.
        Matrix3::new(1e8, 2e7, 0.0, 2e7, 5e7, 1e3, 0.0, 1e3, 1e4),
    ];
    for m in mats {
        let eig = m.symmetric_eigenvalues();
        let (lo, hi) = (eig.min(), eig.max());
        assert!((smallest_eigenvalue(&m) - lo).abs() <= 1e-9 * m.norm());
        assert!((largest_eigenvalue(&m) - hi).abs() <= 1e-9 * m.norm());
    }
}

#[test]
fn uncertainty_grows_with_distance_and_shrinks_with_baseline() {
    let p = Point3::new(0.0, 0.0, 0.0);
    let triplet = |d: f64, b: f64| {
        [
            cam_at(Point3::new(b, 0.1, d)),
            cam_at(Point3::new(-b, 0.2, d)),
            cam_at(Point3::new(0.0, b, d)),
        ]
    };
    let g = |d, b| {
        let t = triplet(d, b);
        let refs: Vec<&Camera> = t.iter().collect();
        point_geometry(&refs, &t[0], &p, 1.0).unwrap()
    };
    let near = g(20.0, 5.0);
    let far = g(40.0, 5.0);
    let wide = g(20.0, 10.0);
    assert!(far.sigma_ray > 3.0 * near.sigma_ray);
    assert!(wide.sigma_ray < near.sigma_ray);
    assert!(near.sigma_max >= near.sigma_ray);
    // sigma_max is the largest sigma along any direction.
    let cov = point_covariance(&triplet(20.0, 5.0), &p, 1.0).unwrap();
    for dir in [Vector3::x(), Vector3::y(), Vector3::z()] {
        assert!(sigma_along(&cov, &dir) <= near.sigma_max * (1.0 + 1e-9));
    }
}

/// The planner's f_unc used `1 / smallest eigenvalue of the information`
/// and the simulator `largest eigenvalue of the covariance`: the same number.
#[test]
fn information_and_covariance_give_the_same_sigma_max() {
    let p = Point3::new(0.5, -0.3, 0.2);
    let cams = [
        cam_at(Point3::new(6.0, 0.0, 25.0)),
        cam_at(Point3::new(-3.0, 5.0, 25.0)),
        cam_at(Point3::new(-3.0, -5.0, 25.0)),
    ];
    let info = information(&cams, &p, 0.7);
    let cov = covariance(&info).unwrap();
    let via_info = 1.0 / smallest_eigenvalue(&info).sqrt();
    assert!((sigma_max(&cov) - via_info).abs() <= 1e-9 * via_info);
}

/// Regression: the simulator's copy refused the whole point when one camera
/// had it behind; labelgen's skipped that camera. Skipping is right: a
/// camera behind the point never observed it, so it adds no information,
/// and the two cameras that did observe it still fix it.
#[test]
fn camera_behind_the_point_adds_no_information() {
    let p = Point3::origin();
    let front = [
        cam_at(Point3::new(5.0, 0.0, 20.0)),
        cam_at(Point3::new(-5.0, 0.0, 20.0)),
    ];
    let behind = {
        let k = Intrinsics::from_hfov(400, 300, 60.0).unwrap();
        Camera::look_at(k, Point3::new(0.0, 0.0, 20.0), Point3::new(1.0, 0.0, 40.0)).unwrap()
    };
    assert_eq!(camera_information(&behind, &p, 1.0), Matrix3::zeros());
    let two = point_covariance(&front, &p, 1.0).unwrap();
    let three = point_covariance(front.iter().chain([&behind]), &p, 1.0).unwrap();
    assert_eq!(two, three);
}

/// Regression: labelgen's copy inverted any matrix `try_inverse` accepted, so
/// two cameras at one spot (no baseline) gave a finite sigma of thousands of
/// metres instead of "cannot triangulate". The relative singularity test
/// (the simulator's) is right.
#[test]
fn no_baseline_gives_no_covariance() {
    let p = Point3::origin();
    let c = cam_at(Point3::new(0.0, 5.0, 20.0));
    assert!(point_covariance([&c, &c], &p, 1.0).is_none());
    // One camera alone cannot fix a point either.
    assert!(point_covariance([&c], &p, 1.0).is_none());
    // Nor can cameras with the point behind them.
    assert!(covariance(&Matrix3::zeros()).is_none());
}
