//! Triplet sampling on a synthetic sparse model.

mod common;

use nalgebra::Point3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use vp_labelgen::synthetic::sparse_model;
use vp_labelgen::triplets::{
    candidate_triplets, median_angle, read_triplet_list, sample_triplets, write_image_lists,
    write_triplet_list, TripletParams,
};
use vp_scene::colmap::Reconstruction;
use vp_scene::{Camera, Intrinsics};

fn model() -> Reconstruction {
    let w = common::world();
    let k = Intrinsics::from_hfov(400, 300, 70.0).unwrap();
    let mut cams = Vec::new();
    for j in 0..5 {
        for i in 0..5 {
            let c = Point3::new(-18.0 + 9.0 * f64::from(i), -18.0 + 9.0 * f64::from(j), 30.0);
            let target = Point3::new(c.x * 0.6, c.y * 0.6 + 0.5, 0.0);
            cams.push((
                format!("grid_{j}_{i}.jpg"),
                Camera::look_at(k, c, target).unwrap(),
            ));
        }
    }
    // A row of three close cameras far from equilateral.
    for (n, x) in [0.0, 1.0, 12.0].iter().enumerate() {
        let c = Point3::new(*x - 6.0, 30.0, 32.0);
        cams.push((
            format!("row_{n}.jpg"),
            Camera::look_at(k, c, Point3::new(-2.0, 5.0, 0.0)).unwrap(),
        ));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let points: Vec<Point3<f64>> = (0..800)
        .filter_map(|_| {
            let (x, y) = (rng.random_range(-30.0..30.0), rng.random_range(-30.0..30.0));
            let top = Point3::new(x, y, 50.0);
            // Not exactly vertical: an axis-aligned ray misses in the BVH (see report).
            let down = nalgebra::Vector3::new(1e-3, 1e-3, -1.0).normalize();
            w.caster
                .closest_hit(&top, &down, f64::INFINITY)
                .map(|h| h.point)
        })
        .collect();
    sparse_model(&cams, &w.caster, &points)
}

fn centres_and_points(
    m: &Reconstruction,
    names: &[String; 3],
) -> ([Point3<f64>; 3], Vec<Point3<f64>>) {
    let imgs = names
        .clone()
        .map(|n| m.images.values().find(|i| i.name == n).unwrap().clone());
    let sees = |img: &vp_scene::colmap::ColmapImage, p: &vp_scene::colmap::Point3D| {
        p.track.iter().any(|t| t.0 == img.id)
    };
    let pts = m
        .points
        .values()
        .filter(|p| imgs.iter().all(|i| sees(i, p)))
        .map(|p| p.xyz)
        .collect();
    (imgs.map(|i| i.center()), pts)
}

#[test]
fn triplets_fall_in_their_bins_and_are_near_equilateral() {
    let m = model();
    let params = TripletParams {
        per_bin: 4,
        ..TripletParams::default()
    };
    let all = candidate_triplets(&m, &params).unwrap();
    assert!(all.len() > 20, "{} candidates", all.len());
    let mut bins_seen = std::collections::BTreeSet::new();
    for t in &all {
        let (c, pts) = centres_and_points(&m, &t.images);
        let (angle, ratio) = median_angle(&c, &pts).unwrap();
        assert!((angle - t.angle_deg).abs() < 1e-9);
        assert!(ratio >= 0.5, "{t:?} ratio {ratio}");
        let e = &params.bin_edges;
        assert!(e[t.bin] <= angle && angle < e[t.bin + 1], "{t:?}");
        assert!(pts.len() >= params.min_shared_points);
        bins_seen.insert(t.bin);
    }
    assert!(bins_seen.len() >= 3, "bins {bins_seen:?}");
    // The row of cameras sees enough shared points but is far from equilateral.
    let row = ["row_0.jpg", "row_1.jpg", "row_2.jpg"].map(String::from);
    let (c, pts) = centres_and_points(&m, &row);
    assert!(pts.len() >= params.min_shared_points);
    let (_, ratio) = median_angle(&c, &pts).unwrap();
    assert!(ratio < 0.5);
    assert!(!all.iter().any(|t| t.images == row));
    let sampled = sample_triplets(&m, &params).unwrap();
    for b in 0..5 {
        let in_bin = all.iter().filter(|t| t.bin == b).count();
        assert_eq!(sampled.iter().filter(|t| t.bin == b).count(), in_bin.min(4));
    }
}

#[test]
fn sampling_is_deterministic_by_seed() {
    let m = model();
    let p = |seed| TripletParams {
        per_bin: 3,
        seed,
        ..TripletParams::default()
    };
    let a = sample_triplets(&m, &p(1)).unwrap();
    assert_eq!(a, sample_triplets(&m, &p(1)).unwrap());
    assert_ne!(a, sample_triplets(&m, &p(2)).unwrap());
}

#[test]
fn triplet_list_round_trips_and_bad_lines_are_named() {
    let m = model();
    let t = sample_triplets(
        &m,
        &TripletParams {
            per_bin: 2,
            ..TripletParams::default()
        },
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("triplets.txt");
    write_triplet_list(&path, &t).unwrap();
    let back = read_triplet_list(&path).unwrap();
    assert_eq!(back.len(), t.len());
    for (a, b) in back.iter().zip(&t) {
        assert_eq!((a.bin, &a.images), (b.bin, &b.images));
        assert!((a.angle_deg - b.angle_deg).abs() < 1e-4);
    }
    write_image_lists(&dir.path().join("lists"), &t, false).unwrap();
    let first = std::fs::read_to_string(dir.path().join("lists/t0000.txt")).unwrap();
    assert_eq!(
        first.lines().collect::<Vec<_>>(),
        t[0].images.iter().map(String::as_str).collect::<Vec<_>>()
    );
    assert!(write_image_lists(&dir.path().join("lists"), &t, false).is_err());
    std::fs::write(&path, "# c\n0\t5.0\ta.jpg\tb.jpg\tc.jpg\n1\tx\ta\tb\tc\n").unwrap();
    let err = read_triplet_list(&path).unwrap_err().to_string();
    assert!(err.contains("line 3") && err.contains("angle"), "{err}");
}
