//! M1: exact f(t), pruned enumeration against plain enumeration, hand values.

use nalgebra::{Point3, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use vp_planner::fulfillment::{best_triplet, best_triplet_plain, sample_triangles, Fulfillment};
use vp_planner::quality::{CamTerm, ConfCurve, Requirements};
use vp_scene::raster::{AngleBins, ConfidenceImage};
use vp_scene::raycast::RayCaster;
use vp_scene::{Camera, Intrinsics, Mesh};

fn k() -> Intrinsics {
    Intrinsics::from_hfov(1200, 800, 60.0).unwrap()
}

fn req(gsd: f64, acc: f64) -> Requirements {
    Requirements {
        r_desired: 1.0 / (gsd * gsd),
        accuracy: acc,
        alpha: 0.5,
        bins: AngleBins::paper(),
    }
}

/// Camera at distance `d` from `p`, direction (azimuth, elevation) in degrees, looking at `p`.
fn cam_at(p: &Point3<f64>, d: f64, az: f64, el: f64) -> Camera {
    let (sa, ca) = az.to_radians().sin_cos();
    let (se, ce) = el.to_radians().sin_cos();
    let c = p + Vector3::new(ce * ca, ce * sa, se) * d;
    Camera::look_at(k(), c, *p).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The pruned search returns exactly the plain maximum, for any camera
    /// set and any confidence curve (including saturating resolution and
    /// accuracy, where pruning bites hardest).
    #[test]
    fn pruned_enumeration_equals_plain_enumeration(
        cams in prop::collection::vec((5.0f64..120.0, 0.0f64..360.0, 20.0f64..89.0), 0..14),
        curve in prop::collection::vec(0.0f32..1.0, 9),
        gsd in prop::sample::select(vec![0.002, 0.008, 0.05]),
        acc in prop::sample::select(vec![0.001, 0.008, 0.1]),
        with_conf in any::<bool>(),
    ) {
        let p = Point3::new(1.0, 2.0, 3.0);
        let n = Vector3::new(0.1, -0.2, 1.0).normalize();
        let terms: Vec<CamTerm> = cams.iter().map(|&(d, az, el)| CamTerm::new(&cam_at(&p, d, az, el), &p, &n, 1.0)).collect();
        let r = req(gsd, acc);
        let curve = ConfCurve(curve);
        let conf = with_conf.then_some(&curve);
        let fast = best_triplet(&terms, conf, &r).map(|b| b.value);
        let plain = best_triplet_plain(&terms, conf, &r).map(|b| b.value);
        prop_assert_eq!(fast, plain);
    }
}

/// One big horizontal triangle; the sampled triangles are its split faces.
fn one_triangle() -> Mesh {
    Mesh::new(
        vec![
            Point3::new(-10.0, -10.0, 0.0),
            Point3::new(10.0, -10.0, 0.0),
            Point3::new(0.0, 10.0, 0.0),
        ],
        vec![[0, 1, 2]],
        None,
    )
    .unwrap()
}

#[test]
fn f_matches_hand_computation_for_a_symmetric_triplet() {
    let mesh = one_triangle();
    let caster = RayCaster::new(&mesh);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let sampled = sample_triangles(&mesh, &[0], 10, &mut rng).unwrap();
    let p = sampled.1[0].centroid;
    // Three cameras at D = 30 m around the normal with half-cone beta = 20 deg,
    // each looking at p: on the optical axis, so the information of each is
    // (f/D)^2 (I - u u^T) / sigma^2.
    let (d, beta) = (30.0f64, 20.0f64);
    let cams: Vec<Camera> = [90.0, 210.0, 330.0]
        .iter()
        .map(|&az| cam_at(&p, d, az, 90.0 - beta))
        .collect();
    let r = req(0.008, 0.008);
    // Confidence falling linearly per bin: 1.0, 0.9, ..., 0.2 at the bin centres.
    let mut img = ConfidenceImage::zeros(1200, 800, 100, AngleBins::paper()).unwrap();
    for (i, v) in img.values_mut().iter_mut().enumerate() {
        *v = 1.0 - 0.1 * (i % 9) as f32;
    }
    let confs = vec![Some(&img); 3];
    let ful = Fulfillment::new(r, 1.0, 3, sampled, &caster, &cams, &confs);

    let f = k().focal();
    let (sb, cb) = beta.to_radians().sin_cos();
    let f_res = (f * f * cb / (d * d) * 0.008 * 0.008).min(1.0);
    let kk = f * f / (d * d);
    let lmin = (3.0 * kk * sb * sb).min(kk * (3.0 - 1.5 * sb * sb));
    let f_unc = (0.008 * lmin.sqrt()).min(1.0);
    let gamma = 2.0 * (3f64.sqrt() / 2.0 * sb).asin().to_degrees();
    // Bin centres 2.5, 7.5, ...: linear between them.
    let pos = (gamma - 2.5) / 5.0;
    let i = pos.floor();
    let conf = (1.0 - 0.1 * i) - 0.1 * (pos - i);
    let expected = (0.5 * f_res + 0.5 * f_unc) * conf;
    let got = ful.f(0);
    assert!(
        (got - expected).abs() < 1e-5,
        "f = {got}, by hand {expected} (f_res {f_res}, f_unc {f_unc}, angle {gamma}, conf {conf})"
    );
    assert!(ful.covered(0));
    // w = 1 - f / f_conf(t*).
    assert!((ful.weight(0) - (1.0 - 0.5 * f_res - 0.5 * f_unc)).abs() < 1e-5);
}

#[test]
fn no_prediction_equals_confidence_one() {
    let mesh = one_triangle();
    let caster = RayCaster::new(&mesh);
    let sampled = sample_triangles(&mesh, &[0], 50, &mut ChaCha8Rng::seed_from_u64(3)).unwrap();
    let p = Point3::new(0.0, 0.0, 0.0);
    let cams: Vec<Camera> = (0..5)
        .map(|i| {
            cam_at(
                &p,
                25.0 + f64::from(i),
                f64::from(i) * 70.0,
                50.0 + f64::from(i) * 5.0,
            )
        })
        .collect();
    let one = ConfidenceImage::constant(1.0);
    let a = Fulfillment::new(
        req(0.008, 0.008),
        1.0,
        3,
        sampled.clone(),
        &caster,
        &cams,
        &[None; 5],
    );
    let b = Fulfillment::new(
        req(0.008, 0.008),
        1.0,
        3,
        sampled,
        &caster,
        &cams,
        &[Some(&one); 5],
    );
    assert!(a.mean_f() > 0.0);
    for t in 0..a.tris.len() {
        assert_eq!(a.f(t).to_bits(), b.f(t).to_bits(), "bit-identical f");
    }
}

#[test]
fn fewer_than_c_cameras_leave_triangles_uncovered() {
    let mesh = one_triangle();
    let caster = RayCaster::new(&mesh);
    let sampled = sample_triangles(&mesh, &[0], 20, &mut ChaCha8Rng::seed_from_u64(3)).unwrap();
    let p = Point3::new(0.0, 0.0, 0.0);
    let cams: Vec<Camera> = (0..3)
        .map(|i| cam_at(&p, 30.0, f64::from(i) * 120.0, 60.0))
        .collect();
    let ful = Fulfillment::new(
        req(0.008, 0.008),
        1.0,
        4,
        sampled,
        &caster,
        &cams,
        &[None; 3],
    );
    assert!(ful.coverage().abs() < 1e-15);
    assert!(ful.mean_f().abs() < 1e-15);
    assert!((0..ful.tris.len()).all(|t| (ful.weight(t) - 1.0).abs() < 1e-15));
    // Selection takes every triangle with a positive weight when there are few.
    assert_eq!(
        ful.select(1000, &mut ChaCha8Rng::seed_from_u64(1)).len(),
        ful.tris.len()
    );
}
