//! Guards of vp-mvs's speed-ups: each faster setting keeps the quality of
//! the slower one it replaced on rendered rock and ground (completeness
//! within 1 point, outliers at most 0.2 points more, unless a guard says
//! otherwise).

use vpctl_suite::mvs::{reconstruct, MvsParams, View};
use vpctl_suite::scene::camera::{Camera, Intrinsics};
use vpctl_suite::scene::procedural::Site;
use vpctl_suite::scene::raycast::RayCaster;
use vpctl_suite::scene::Material;
use vpctl_suite::sim::Rendered;

use crate::mvs::{evaluate, render_views, site, triplet_cameras, triplet_sources, Tally};

/// Completeness and outlier share (see [`Tally`]) on rock and ground at
/// 5-25 degrees, summed over the given triplets.
fn rock_and_ground_score(
    site: &Site,
    triplets: &[(Vec<View>, Vec<Rendered>)],
    params: &MvsParams,
) -> (f64, f64) {
    let mut tally = [[Tally::default(); 4]; 5];
    for (views, renders) in triplets {
        let sources = triplet_sources(views.len());
        let out = reconstruct(views, &sources, params, &mut |_| {}).unwrap();
        evaluate(site, views, renders, &out, &mut tally);
    }
    let c = Tally::sum(
        [Material::Rock, Material::Ground]
            .iter()
            .flat_map(|&m| &tally[m as usize][1..3]),
    );
    (
        c.complete as f64 / c.visible.max(1) as f64,
        c.outliers as f64 / c.output.max(1) as f64,
    )
}

/// The guards' bar: a faster setting's (completeness, outliers) `new`
/// keeps the quality of `old`: completeness within 1 point, outliers at
/// most 0.2 points more.
fn assert_keeps_quality(new: (f64, f64), old: (f64, f64)) {
    assert!(new.0 >= old.0 - 0.01, "{new:?} vs {old:?}");
    assert!(new.1 <= old.1 + 0.002, "{new:?} vs {old:?}");
}

/// The triplet the quality guards below compare settings on: 320x240, 26 m
/// from the rock, 14 degrees.
fn quality_triplet(site: &Site) -> (Vec<View>, Vec<Rendered>) {
    quality_triplet_sized(site, 320, 240)
}

/// [`quality_triplet`]'s cameras with `width` x `height` images.
fn quality_triplet_sized(site: &Site, width: u32, height: u32) -> (Vec<View>, Vec<Rendered>) {
    let caster = RayCaster::new(&site.mesh);
    let k = Intrinsics::from_hfov(width, height, 60.0).unwrap();
    render_views(
        site,
        &caster,
        &triplet_cameras(site, k, 26.0, 55.0, 120.0, 14.0),
    )
}

/// Coarse-to-fine (a half-resolution level, then `fine_iterations` at full
/// resolution) keeps the quality of a single-scale run on rock and ground:
/// completeness within 3 points, outliers within 1 point. Guards the speed-up
/// of the pyramid against a silent loss of quality.
#[test]
fn coarse_to_fine_keeps_single_scale_quality() {
    let site = site();
    let triplets = [quality_triplet(&site)];
    let single = rock_and_ground_score(
        &site,
        &triplets,
        &MvsParams {
            coarse_levels: 0,
            ..MvsParams::default()
        },
    );
    let multi = rock_and_ground_score(
        &site,
        &triplets,
        &MvsParams {
            coarse_levels: 1,
            coarse_min_size: 100,
            ..MvsParams::default()
        },
    );
    eprintln!("single scale: {single:?}, coarse-to-fine: {multi:?} (completeness, outliers)");
    assert!(single.0 > 0.8, "single scale completeness {}", single.0);
    assert!(multi.0 >= single.0 - 0.03, "{multi:?} vs {single:?}");
    assert!(multi.1 <= single.1 + 0.01, "{multi:?} vs {single:?}");
}

/// The default two coarse levels keep the quality of one on rock and ground
/// (completeness within 1 point, outliers at most 0.2 points more): the
/// quality triplet with `coarse_min_size` lowered so that both levels run
/// (160 x 120, then 80 x 60). Guards the default's speed-up.
#[test]
fn two_coarse_levels_keep_the_quality_of_one() {
    let site = site();
    let triplets = [quality_triplet(&site)];
    let levels = |coarse_levels| MvsParams {
        coarse_levels,
        coarse_min_size: 60,
        ..MvsParams::default()
    };
    let one = rock_and_ground_score(&site, &triplets, &levels(1));
    let two = rock_and_ground_score(&site, &triplets, &levels(2));
    eprintln!("one coarse level: {one:?}, two: {two:?} (completeness, outliers)");
    assert_keeps_quality(two, one);
}

/// Three coarse levels keep the quality of two on rock and ground
/// (completeness within 1 point, outliers at most 0.2 points more): the
/// quality cameras at 640 x 480, with `coarse_min_size` lowered so that the
/// three levels run (320 x 240, 160 x 120, 80 x 60) and two stop at
/// 160 x 120. Guards the default's speed-up (docs/performance.md, "Stop 57").
#[test]
fn three_coarse_levels_keep_the_quality_of_two() {
    let site = site();
    let triplets = [quality_triplet_sized(&site, 640, 480)];
    let levels = |coarse_levels| MvsParams {
        coarse_levels,
        coarse_min_size: 60,
        ..MvsParams::default()
    };
    assert_eq!(MvsParams::default().coarse_levels, 3);
    let two = rock_and_ground_score(&site, &triplets, &levels(2));
    let three = rock_and_ground_score(&site, &triplets, &levels(3));
    eprintln!("two coarse levels: {two:?}, three: {three:?} (completeness, outliers)");
    assert_keeps_quality(three, two);
    // Not vacuous: two levels reconstruct most of rock and ground.
    assert!(two.0 > 0.8, "{two:?}");
}

/// Two propagation neighbours at the finer levels (`fine_neighbours`, the
/// default) keep the quality of four on rock and ground (as above: 640 x 480,
/// three coarse levels). Guards the default's speed-up ("Stop 59").
#[test]
fn two_fine_neighbours_keep_the_quality_of_four() {
    let site = site();
    let triplets = [quality_triplet_sized(&site, 640, 480)];
    let neighbours = |fine_neighbours| MvsParams {
        fine_neighbours,
        coarse_min_size: 60,
        ..MvsParams::default()
    };
    assert_eq!(MvsParams::default().fine_neighbours, 2);
    let four = rock_and_ground_score(&site, &triplets, &neighbours(4));
    let two = rock_and_ground_score(&site, &triplets, &neighbours(2));
    eprintln!("four fine neighbours: {four:?}, two: {two:?} (completeness, outliers)");
    assert_keeps_quality(two, four);
    assert!(four.0 > 0.8, "{four:?}");
}

/// The window without its four corner samples (`window_drop_corners`: 32
/// samples, four 8-lane chunks) keeps the quality of the whole 6 x 6 grid
/// on rock and ground: completeness within 1 point, outliers at most 0.2
/// points more. Guards the option (off by default: see the parameter).
#[test]
fn a_window_without_corners_keeps_the_quality_of_the_whole_grid() {
    let site = site();
    let triplets = [quality_triplet(&site)];
    let window = |window_drop_corners| MvsParams {
        window_drop_corners,
        ..MvsParams::default()
    };
    assert_eq!(window(true).window_sample_count(), 32);
    assert_eq!(window(false).window_sample_count(), 36);
    let without = rock_and_ground_score(&site, &triplets, &window(true));
    let whole = rock_and_ground_score(&site, &triplets, &window(false));
    eprintln!("without corners: {without:?}, whole grid: {whole:?} (completeness, outliers)");
    assert_keeps_quality(without, whole);
}

/// Settling pixels whose cost and neighbours stopped changing by more than
/// the default `settle_cost` keeps the quality of settling only those where
/// nothing changed at all (0), on rock and ground: completeness within 1
/// point, outliers at most 0.2 points more. Guards the default's speed-up.
#[test]
fn settled_pixels_keep_the_quality_of_updating_every_changing_pixel() {
    let site = site();
    let triplets = [quality_triplet(&site)];
    let settle = |settle_cost| MvsParams {
        settle_cost,
        ..MvsParams::default()
    };
    let default = MvsParams::default().settle_cost;
    assert!(default > 0.0);
    let settled = rock_and_ground_score(&site, &triplets, &settle(default));
    let every = rock_and_ground_score(&site, &triplets, &settle(0.0));
    eprintln!("settle_cost {default}: {settled:?}, 0: {every:?} (completeness, outliers)");
    assert_keeps_quality(settled, every);
}

/// The default geometric pass (`geom_iterations`, 1) keeps the quality of
/// six iterations on rock and ground: completeness within 1 point, outliers
/// at most 0.2 points more. Guards the default's speed-up.
#[test]
fn default_geometric_iterations_keep_the_quality_of_six() {
    let site = site();
    let triplets = [quality_triplet(&site)];
    let default = rock_and_ground_score(&site, &triplets, &MvsParams::default());
    let six = rock_and_ground_score(
        &site,
        &triplets,
        &MvsParams {
            geom_iterations: 6,
            ..MvsParams::default()
        },
    );
    eprintln!("default: {default:?}, six: {six:?} (completeness, outliers)");
    assert_keeps_quality(default, six);
}

/// Leaving the pixels whose photometric plane the sources already agree
/// with as they are in the geometric pass (`geom_settled_px`, 1) keeps the
/// quality of updating every pixel (0, COLMAP's way), on rock and ground.
/// Guards the default's speed-up.
#[test]
fn settled_geometric_pixels_keep_the_quality_of_all() {
    let site = site();
    let triplets = [quality_triplet(&site)];
    let default = rock_and_ground_score(&site, &triplets, &MvsParams::default());
    let every = rock_and_ground_score(
        &site,
        &triplets,
        &MvsParams {
            geom_settled_px: 0.0,
            ..MvsParams::default()
        },
    );
    eprintln!("geom_settled_px default: {default:?}, 0: {every:?} (completeness, outliers)");
    assert_keeps_quality(default, every);
}

/// Perturbation-only refinement in the passes that start from solved planes
/// (`seeded_random_candidates = false`) keeps the quality of trying random
/// planes there too, on rock and ground with a coarse level
/// (so that both seeded passes, the finer level and the geometric pass, are
/// checked): completeness within 1 point, outliers at most 0.2 points more,
/// the geometric-iterations guard's bar. Guards the default's speed-up.
#[test]
fn perturbation_only_refinement_keeps_the_quality_of_random_candidates() {
    let site = site();
    let triplets = [quality_triplet(&site)];
    let with_coarse = MvsParams {
        coarse_levels: 1,
        coarse_min_size: 100,
        seeded_random_candidates: false,
        ..MvsParams::default()
    };
    let perturbed = rock_and_ground_score(&site, &triplets, &with_coarse);
    let random = rock_and_ground_score(
        &site,
        &triplets,
        &MvsParams {
            seeded_random_candidates: true,
            ..with_coarse.clone()
        },
    );
    eprintln!("perturbation only: {perturbed:?}, with random candidates: {random:?} (completeness, outliers)");
    assert_keeps_quality(perturbed, random);
}

/// The table behind the default `geom_iterations` (docs/performance.md):
/// completeness, outliers and time for 0-6 geometric iterations over three
/// triplets (8, 14 and 20 degrees) at two resolutions, with the guard's bar
/// checked on all of them. Minutes in release: run with --ignored.
/// Scoring each pixel's hypotheses on only its best `seeded_sources` (4)
/// sources for the seed plane keeps the quality of scoring all of them, on
/// rock and ground seen by nine views (three triplets a few degrees of
/// azimuth apart, 320 x 240, both coarse levels run), each against the
/// other eight: completeness within 1 point, outliers at most 0.2 points
/// more, the bar of the guards above. Guards the default's speed-up, which
/// only views with more than 4 sources see.
#[test]
fn seeded_source_subsets_keep_the_quality_of_every_source() {
    let site = site();
    let caster = RayCaster::new(&site.mesh);
    let k = Intrinsics::from_hfov(320, 240, 60.0).unwrap();
    let cams: Vec<Camera> = [105.0, 120.0, 135.0]
        .iter()
        .flat_map(|&az| triplet_cameras(&site, k, 26.0, 55.0, az, 14.0))
        .collect();
    let nine = [render_views(&site, &caster, &cams)];
    let sources = |seeded_sources| MvsParams {
        seeded_sources,
        coarse_min_size: 60,
        ..MvsParams::default()
    };
    assert_eq!(MvsParams::default().seeded_sources, 4);
    let subset = rock_and_ground_score(&site, &nine, &sources(4));
    let every = rock_and_ground_score(&site, &nine, &sources(0));
    eprintln!("best 4 sources: {subset:?}, every source: {every:?} (completeness, outliers)");
    assert_keeps_quality(subset, every);
    // Not vacuous: the nine views agree on most of rock and ground.
    assert!(every.0 > 0.5, "{every:?}");
}

#[test]
#[ignore = "minutes: prints the table behind the default geom_iterations"]
fn geometric_iterations_table() {
    let site = site();
    let caster = RayCaster::new(&site.mesh);
    for (w, h) in [(320, 240), (640, 480)] {
        let k = Intrinsics::from_hfov(w, h, 60.0).unwrap();
        let triplets: Vec<_> = [(0.0, 8.0), (120.0, 14.0), (240.0, 20.0)]
            .iter()
            .map(|&(az, angle)| {
                render_views(
                    &site,
                    &caster,
                    &triplet_cameras(&site, k, 26.0, 55.0, az, angle),
                )
            })
            .collect();
        let mut scores = Vec::new();
        for geom_iterations in [0, 1, 2, 3, 4, 6] {
            let params = MvsParams {
                geom_iterations,
                ..MvsParams::default()
            };
            let t0 = std::time::Instant::now();
            let (complete, outliers) = rock_and_ground_score(&site, &triplets, &params);
            eprintln!(
                "{w}x{h}, geom_iterations {geom_iterations}: {:.1} s, complete {:.2} %, outliers {:.2} %",
                t0.elapsed().as_secs_f64(),
                100.0 * complete,
                100.0 * outliers
            );
            scores.push((geom_iterations, complete, outliers));
        }
        let of = |n: u32| scores.iter().find(|s| s.0 == n).unwrap();
        let (default, six) = (of(MvsParams::default().geom_iterations), of(6));
        assert!(default.1 >= six.1 - 0.01, "{default:?} vs {six:?}");
        assert!(default.2 <= six.2 + 0.002, "{default:?} vs {six:?}");
    }
}
