use super::*;
use nalgebra::Point3;
use vp_scene::Intrinsics;

/// `a` equals `b` to rounding.
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-12
}

fn close_all(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| close(*x, *y))
}

fn outcome(pixels: usize, measured: usize) -> TripletOutcome {
    TripletOutcome {
        strategy: "F1x2".into(),
        site: 7,
        iteration: 1,
        triplet: 0,
        planned_angle_deg: Some(22.5),
        stats: OutputStats {
            pixels,
            output: measured,
            measured,
        },
        success: measured > 0,
    }
}

#[test]
fn planned_angles_fall_in_five_degree_bins_and_the_last_bin_is_open() {
    let angles = [2.5, 7.5, 7.5, 5.0, 42.5, 47.0, -1.0, f64::NAN];
    // [0,5): 2.5; [5,10): 7.5, 7.5, 5.0; [40,..): 42.5, 47.0.
    assert_eq!(angle_histogram(angles, 9), vec![1, 3, 0, 0, 0, 0, 0, 0, 2]);
    assert_eq!(angle_histogram(angles, 0), Vec::<u64>::new());
}

#[test]
fn quartiles_interpolate_between_ranks() {
    let q = five_numbers(&[4.0, 1.0, 3.0, 2.0]).unwrap();
    assert!(close_all(&q, &[1.0, 1.75, 2.5, 3.25, 4.0]), "{q:?}");
    // NaN is left out: 0, 0.1, 0.3.
    let q = five_numbers(&[0.3, 0.0, f64::NAN, 0.1]).unwrap();
    assert!(close_all(&q, &[0.0, 0.05, 0.1, 0.2, 0.3]), "{q:?}");
    assert!(close_all(&five_numbers(&[0.4]).unwrap(), &[0.4; 5]));
    assert!(five_numbers(&[]).is_none());
}

#[test]
fn success_at_a_threshold_counts_the_triplets_at_or_above_it() {
    let o = [
        outcome(100, 0),
        outcome(100, 1),
        outcome(100, 5),
        outcome(100, 10),
        outcome(100, 30),
        outcome(0, 0),
    ];
    let share = |t| success_share(&o, t);
    // > 0 px: 4 of 6; >= 1 %: the same 4 (1 of 100 is 1 %); >= 10 %: 2;
    // >= 25 %: 1.
    assert!(close(share(0.0), 4.0 / 6.0));
    assert!(close(share(0.01), 4.0 / 6.0));
    assert!(close(share(0.10), 2.0 / 6.0));
    assert!(close(share(0.25), 1.0 / 6.0));
    assert!(success_share(&[], 0.0).is_nan());
    // Success never grows with the threshold.
    let s: Vec<f64> = SUCCESS_THRESHOLDS.iter().map(|&t| share(t)).collect();
    assert!(s.windows(2).all(|w| w[0] >= w[1]), "{s:?}");
}

#[test]
fn depth_errors_fall_in_two_centimetre_bins_with_overflow_bins() {
    type H = DepthErrorHistogram;
    assert_eq!(H::bin_of(-0.51), 0);
    assert_eq!(H::bin_of(-0.49), 1);
    assert_eq!(H::bin_of(-0.01), 25);
    assert_eq!(H::bin_of(0.01), 26);
    assert_eq!(H::bin_of(0.49), 50);
    assert_eq!(H::bin_of(0.5), 51);
    assert_eq!(H::bin_of(3.0), 51);
    let (lo, hi) = H::bin_range(26);
    assert!(lo.abs() < 1e-12 && (hi - 0.02).abs() < 1e-12, "{lo} {hi}");
    assert!(H::bin_range(0).0.is_infinite() && close(H::bin_range(0).1, -0.5));
    let (lo, hi) = H::bin_range(51);
    assert!(close(lo, 0.5) && hi.is_infinite() && hi > 0.0);
}

#[test]
fn the_one_sigma_figures_count_only_pixels_with_a_sigma() {
    let mut h = DepthErrorHistogram::default();
    h.add(0.01, Some(0.0205)); // within its sigma
    h.add(-0.03, Some(0.0105)); // outside
    h.add(0.6, None); // one camera misses it: no sigma
    h.add(-0.7, Some(0.0305)); // outside
    assert_eq!(h.pixels, 4);
    assert_eq!((h.with_sigma, h.within_sigma), (3, 1));
    assert_eq!(h.counts[26] + h.counts[24] + h.counts[51] + h.counts[0], 4);
    assert_eq!(h.counts.iter().sum::<u64>(), 4);
    assert!((h.within_sigma_share() - 1.0 / 3.0).abs() < 1e-12);
    // Sigmas 10.5, 20.5, 30.5 mm: the median is the 20-21 mm bin's centre.
    assert!((h.median_sigma_m().unwrap() - 0.0205).abs() < 1e-12);
    // |error| <= 4 cm: 0.01 and -0.03 of 4 pixels.
    assert!((h.share_within_bins(0.04) - 0.5).abs() < 1e-12);
    // Merging two halves gives the whole.
    let (mut a, mut b) = (
        DepthErrorHistogram::default(),
        DepthErrorHistogram::default(),
    );
    a.add(0.01, Some(0.0205));
    a.add(-0.03, Some(0.0105));
    b.add(0.6, None);
    b.add(-0.7, Some(0.0305));
    a.merge(&b);
    assert_eq!(a, h);
    let empty = DepthErrorHistogram::default();
    assert!(empty.median_sigma_m().is_none() && empty.within_sigma_share().is_nan());
    let mut far = DepthErrorHistogram::default();
    far.add(0.0, Some(5.0));
    assert!(far.median_sigma_m().is_some_and(f64::is_infinite));
}

#[test]
fn the_papers_bound_holds_68_percent_of_the_errors() {
    // |errors| 0.5, 1.5, ..., 9.5 mm: 68.3 % of 10 is the 7th smallest.
    let mut h = DepthErrorHistogram::default();
    for k in 0..10 {
        let e = (f64::from(k) + 0.5) * 1e-3;
        h.add(if k % 2 == 0 { e } else { -e }, None);
    }
    assert!(close(h.measured_bound_m().unwrap(), 0.0065));
    // Of 3 (1.5, 2.5, 3.5 mm): the 3rd.
    let mut h = DepthErrorHistogram::default();
    for e in [0.0015, -0.0025, 0.0035] {
        h.add(e, None);
    }
    assert!(close(h.measured_bound_m().unwrap(), 0.0035));
    assert!(DepthErrorHistogram::default().measured_bound_m().is_none());
}

#[test]
fn rock_errors_take_rock_pixels_with_a_depth_in_the_region() {
    let k = Intrinsics::from_hfov(4, 1, 60.0).unwrap();
    let cam = Camera::from_yaw_pitch(
        k,
        Point3::new(0.0, 0.0, 10.0),
        0.0,
        -std::f64::consts::FRAC_PI_2,
    );
    let px = |material, status, sigma_depth| PixelTruth {
        status,
        material: Some(material),
        true_depth: 10.0,
        depth: 0.0,
        angle_deg: 20.0,
        probability: 0.0,
        sigma_depth,
    };
    let truth = vec![
        px(Material::Rock, PixelStatus::Visible, 0.05),
        px(Material::Ground, PixelStatus::Visible, 0.05),
        px(Material::Rock, PixelStatus::Visible, 0.05),
        px(Material::Rock, PixelStatus::NotVisible, 0.0),
    ];
    // Pixel 0: 3 cm behind (within 1 sigma); 1: ground; 2: no depth; 3: 1 m
    // in front, seen by one camera only.
    let depth = DepthMap {
        width: 4,
        height: 1,
        data: vec![10.03, 10.0, 0.0, 9.0],
    };
    let cams = [cam, cam, cam];
    let depths = [depth.clone(), depth.clone(), depth];
    let truths = [truth.clone(), truth.clone(), truth];
    let h = rock_errors(&cams, &depths, &truths, None);
    assert_eq!((h.pixels, h.with_sigma, h.within_sigma), (6, 3, 3));
    assert_eq!(h.counts[DepthErrorHistogram::bin_of(0.03)], 3);
    assert_eq!(h.counts[0], 3);
    // A region away from the surface counts nothing.
    let away = Aabb {
        min: Point3::new(100.0, 100.0, 0.0),
        max: Point3::new(101.0, 101.0, 1.0),
    };
    assert_eq!(rock_errors(&cams, &depths, &truths, Some(&away)).pixels, 0);
    let around = Aabb {
        min: Point3::new(-50.0, -50.0, -1.0),
        max: Point3::new(50.0, 50.0, 1.0),
    };
    assert_eq!(
        rock_errors(&cams, &depths, &truths, Some(&around)).pixels,
        6
    );
}

/// A Grid reference over a rock plane, its depths 5 cm behind the truth:
/// every rock pixel in the region counts; a pixel has a 1 sigma exactly
/// where a source sees its point, and a wider baseline gives a smaller one.
#[test]
fn a_grid_reference_has_a_sigma_where_a_source_sees_the_point() {
    use crate::render::{render, RenderParams};
    use crate::sfm::SparseCandidates;
    use vp_scene::raycast::RayCaster;

    // 1 px is 14 cm at 20 m: the sigmas stay well under 2 m.
    const W: u32 = 160;
    const H: u32 = 120;
    let cfg = crate::config::CampaignConfig::quick();
    let rock = crate::test_scenes::uniform_plane(60.0, Material::Rock);
    let caster = RayCaster::new(&rock);
    let candidates = SparseCandidates::new(&rock, cfg.sfm.points_per_m2, 11);
    let scene = Scene {
        mesh: &rock,
        caster: &caster,
        texture_seed: 3,
        candidates: &candidates,
    };
    let k = Intrinsics::from_hfov(W, H, 60.0).unwrap();
    let down = std::f64::consts::FRAC_PI_2;
    let at = |x: f64, pitch: f64| Camera::from_yaw_pitch(k, Point3::new(x, 0.0, 20.0), 0.0, pitch);
    let reference = at(0.0, -down);
    let truth = render(&rock, &caster, &reference, &RenderParams::default()).unwrap();
    let behind = DepthMap {
        data: truth
            .depth
            .data
            .iter()
            .map(|&t| if t > 0.0 { t + 0.05 } else { 0.0 })
            .collect(),
        ..truth.depth.clone()
    };
    let region = Aabb {
        min: Point3::new(-30.0, -30.0, -1.0),
        max: Point3::new(30.0, 30.0, 1.0),
    };
    let errors = |cams: &[Camera], region: &Aabb| {
        reference_rock_errors(&scene, &truth, &behind, cams, region, 1.0)
    };
    let near = at(4.0, -down);
    let h = errors(&[reference, near], &region);
    assert_eq!(h.pixels, u64::from(W * H));
    assert_eq!(h.counts[DepthErrorHistogram::bin_of(0.05)], h.pixels);
    // The pixels whose ground point the source (4 m aside) has in frame.
    let seen = (0..W * H)
        .filter(|&i| {
            let px = Point2::new(f64::from(i % W) + 0.5, f64::from(i / W) + 0.5);
            let p = reference.unproject(&px, f64::from(truth.depth.data[i as usize]));
            near.project_in_frame(&p).is_some()
        })
        .count() as u64;
    assert!(seen > 0 && seen < h.pixels, "{seen}");
    assert_eq!(h.with_sigma, seen);
    // Twice the baseline, a smaller first-order sigma.
    let far = errors(&[reference, at(8.0, -down)], &region);
    assert!(far.median_sigma_m().unwrap() < h.median_sigma_m().unwrap());
    // No source, or one looking up: no sigma. Ground, or outside the
    // region: not counted.
    assert_eq!(errors(&[reference], &region).with_sigma, 0);
    assert_eq!(errors(&[reference, at(0.0, down)], &region).with_sigma, 0);
    let away = Aabb {
        min: Point3::new(40.0, 40.0, -1.0),
        max: Point3::new(50.0, 50.0, 1.0),
    };
    assert_eq!(errors(&[reference, near], &away).pixels, 0);
    let ground = crate::test_scenes::uniform_plane(60.0, Material::Ground);
    let ground_scene = Scene {
        mesh: &ground,
        ..scene
    };
    let h = reference_rock_errors(
        &ground_scene,
        &truth,
        &behind,
        &[reference, near],
        &region,
        1.0,
    );
    assert_eq!(h.pixels, 0);
}
