//! vp-mvs on rendered views of a procedural site, where the renderer gives
//! the exact depth: completeness and outliers per material and angle bin,
//! determinism across thread counts.

use nalgebra::{Point3, Vector3};
use vpctl_suite::mvs::{reconstruct, MvsParams, Output, View};
use vpctl_suite::scene::camera::{Camera, Intrinsics};
use vpctl_suite::scene::procedural::{generate_site, Site, SiteParams};
use vpctl_suite::scene::raycast::RayCaster;
use vpctl_suite::scene::triangulation::triangulation_angle_deg;
use vpctl_suite::scene::Material;
use vpctl_suite::sim::{render, RenderParams, Rendered};

pub fn site() -> Site {
    generate_site(&SiteParams {
        seed: 3,
        target_faces: 40_000,
        ..SiteParams::default()
    })
    .unwrap()
}

/// Three cameras `distance` m from the top of the rock, around a viewing
/// direction at `elevation_deg`, spread so that the triangulation angle at
/// the target is about `angle_deg`.
pub fn triplet_cameras(
    site: &Site,
    k: Intrinsics,
    distance: f64,
    elevation_deg: f64,
    azimuth_deg: f64,
    angle_deg: f64,
) -> Vec<Camera> {
    let rb = site.rock_bounds;
    let focus = Point3::new(
        0.5 * (rb.min.x + rb.max.x),
        0.5 * (rb.min.y + rb.max.y),
        rb.max.z,
    );
    let (el, az) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    let v = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
    let u1 = v.cross(&Vector3::z()).normalize();
    let u2 = v.cross(&u1);
    // Two of three directions at angle beta from v, 120 deg apart around
    // it, are sqrt(3) * beta apart for small beta.
    let beta = (angle_deg / 3f64.sqrt()).to_radians();
    [90.0f64, 210.0, 330.0]
        .iter()
        .map(|phi| {
            let p = phi.to_radians();
            let dir = (v + beta.tan() * (p.cos() * u1 + p.sin() * u2)).normalize();
            Camera::look_at(k, focus + distance * dir, focus).unwrap()
        })
        .collect()
}

pub fn render_views(
    site: &Site,
    caster: &RayCaster,
    cams: &[Camera],
) -> (Vec<View>, Vec<Rendered>) {
    let mut views = Vec::new();
    let mut renders = Vec::new();
    for (i, cam) in cams.iter().enumerate() {
        let r = render(&site.mesh, caster, cam, &RenderParams::default()).unwrap();
        let valid: Vec<f32> = r.depth.data.iter().copied().filter(|&d| d > 0.0).collect();
        let lo = valid.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = valid.iter().copied().fold(0.0f32, f32::max);
        // The range a sparse model would give: the visible depths plus a margin.
        let span = f64::from(hi - lo);
        let range = (f64::from(lo) - 0.2 * span, f64::from(hi) + 0.2 * span);
        views.push(View::new(&format!("v{i}.png"), *cam, r.rgb.clone(), range).unwrap());
        renders.push(r);
    }
    (views, renders)
}

/// Each view against the other two.
pub fn triplet_sources(n: usize) -> Vec<Vec<usize>> {
    (0..n)
        .map(|r| (0..n).filter(|&s| s != r).collect())
        .collect()
}

/// Per (material, angle bin): pixels visible in all views, of those the
/// ones within 1 % of the truth, output pixels, and output outliers
/// (beyond 1 % of the truth, or where the truth has no surface).
#[derive(Debug, Default, Clone, Copy)]
pub struct Tally {
    pub visible: usize,
    pub complete: usize,
    pub output: usize,
    pub outliers: usize,
    /// Output pixels beyond 5 % of the truth.
    pub gross: usize,
}

impl Tally {
    /// The cells' counts added up.
    pub fn sum<'a>(cells: impl IntoIterator<Item = &'a Tally>) -> Tally {
        cells.into_iter().fold(Tally::default(), |a, c| Tally {
            visible: a.visible + c.visible,
            complete: a.complete + c.complete,
            output: a.output + c.output,
            outliers: a.outliers + c.outliers,
            gross: a.gross + c.gross,
        })
    }
}

pub const BINS: [f64; 5] = [0.0, 5.0, 15.0, 25.0, 180.0];

fn bin_of(angle: f64) -> usize {
    BINS.windows(2)
        .position(|w| angle >= w[0] && angle < w[1])
        .unwrap_or(BINS.len() - 2)
}

pub fn evaluate(
    site: &Site,
    views: &[View],
    renders: &[Rendered],
    out: &Output,
    tally: &mut [[Tally; 4]; 5],
) {
    let centres: Vec<Point3<f64>> = views.iter().map(|v| v.camera.center()).collect();
    for (r, view) in views.iter().enumerate() {
        let Some(g) = &out.geometric[r] else { continue };
        let truth = &renders[r].depth;
        let w = truth.width as usize;
        for (idx, &t) in truth.data.iter().enumerate() {
            let (x, y) = (idx % w, idx / w);
            let est = g.depth[idx];
            if t <= 0.0 {
                if est > 0.0 {
                    tally[Material::Ground as usize][3].output += 1;
                    tally[Material::Ground as usize][3].outliers += 1;
                    tally[Material::Ground as usize][3].gross += 1;
                }
                continue;
            }
            let m = renders[r].material(&site.mesh, x as u32, y as u32).unwrap();
            let px = nalgebra::Point2::new(x as f64 + 0.5, y as f64 + 0.5);
            let p = view.camera.unproject(&px, f64::from(t));
            let angle = triangulation_angle_deg(&p, &centres);
            let cell = &mut tally[m as usize][bin_of(angle)];
            let good = est > 0.0 && (est - t).abs() <= 0.01 * t;
            if est > 0.0 {
                cell.output += 1;
                cell.outliers += usize::from(!good);
                cell.gross += usize::from((est - t).abs() > 0.05 * t);
            }
            let visible = views.iter().zip(renders).enumerate().all(|(s, (v, rs))| {
                if s == r {
                    return true;
                }
                let Some(q) = v.camera.project_in_frame(&p) else {
                    return false;
                };
                let Some(ts) = rs.depth.get(q.x as u32, q.y as u32) else {
                    return false;
                };
                let z = v.camera.cam_from_world().transform_point(&p).z;
                ts > 0.0 && (f64::from(ts) - z).abs() <= 0.01 * z
            });
            if visible {
                cell.visible += 1;
                cell.complete += usize::from(good);
            }
        }
    }
}

pub fn print_table(tally: &[[Tally; 4]; 5]) {
    eprintln!("material  angle      visible  complete  output  outliers(>1%)  >5%");
    for m in Material::ALL {
        for (b, c) in tally[m as usize].iter().enumerate() {
            if c.visible == 0 && c.output == 0 {
                continue;
            }
            eprintln!(
                "{:<8} {:>3}-{:<3}  {:>8}  {:>7.1}%  {:>6}  {:>7.2}%  {:>7.2}%",
                m.name(),
                BINS[b],
                BINS[b + 1],
                c.visible,
                100.0 * c.complete as f64 / c.visible.max(1) as f64,
                c.output,
                100.0 * c.outliers as f64 / c.output.max(1) as f64,
                100.0 * c.gross as f64 / c.output.max(1) as f64
            );
        }
    }
}

/// Issue 14's bar: rock and ground >= 80 % complete at 5-25 deg, filtered
/// outliers (beyond 1 % of the true depth) <= 2 %. Measured at 320x240,
/// 26 m away, with the default 2 geometric iterations: ground 87.8 % and
/// 88.9 % complete (5-15 and 15-25 deg), 1.8 % outliers over both; rock
/// 98.4 % and 99.7 %, 1.0 % and 0.2 %. With 6 geometric iterations ground
/// had 2.1 % outliers and this test was ignored as a known gap; `--nocapture`
/// prints the table.
#[test]
fn rock_and_ground_are_complete_and_clean_at_5_to_25_degrees() {
    let site = site();
    let caster = RayCaster::new(&site.mesh);
    let k = Intrinsics::from_hfov(320, 240, 60.0).unwrap();
    let params = MvsParams::default();
    let mut tally = [[Tally::default(); 4]; 5];
    for (az, angle) in [(0.0, 8.0), (120.0, 14.0), (240.0, 20.0)] {
        let cams = triplet_cameras(&site, k, 26.0, 55.0, az, angle);
        let (views, renders) = render_views(&site, &caster, &cams);
        let out = reconstruct(&views, &triplet_sources(3), &params, &mut |_| {}).unwrap();
        evaluate(&site, &views, &renders, &out, &mut tally);
    }
    print_table(&tally);
    for m in [Material::Rock, Material::Ground] {
        let c = Tally::sum(&tally[m as usize][1..3]);
        let completeness = c.complete as f64 / c.visible as f64;
        let outliers = c.outliers as f64 / c.output as f64;
        assert!(
            c.visible > 1000,
            "{}: only {} visible pixels",
            m.name(),
            c.visible
        );
        assert!(
            completeness >= 0.8,
            "{}: completeness {completeness:.3} < 0.8",
            m.name()
        );
        assert!(
            outliers <= 0.02,
            "{}: outlier share {outliers:.3} > 0.02",
            m.name()
        );
    }
}

#[test]
fn same_bytes_with_one_and_two_threads() {
    let site = site();
    let caster = RayCaster::new(&site.mesh);
    let k = Intrinsics::from_hfov(160, 120, 60.0).unwrap();
    let cams = triplet_cameras(&site, k, 26.0, 55.0, 30.0, 12.0);
    let (views, _) = render_views(&site, &caster, &cams);
    // With a half-resolution level, so that both pyramid levels are checked.
    let params = MvsParams {
        iterations: 3,
        coarse_levels: 1,
        coarse_min_size: 48,
        ..MvsParams::default()
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| reconstruct(&views, &triplet_sources(3), &params, &mut |_| {}).unwrap())
    };
    let (a, b) = (run(1), run(2));
    let bits = |o: &Output| -> Vec<u32> {
        o.geometric
            .iter()
            .flatten()
            .chain(o.photometric.iter().flatten())
            .flat_map(|m| {
                m.depth
                    .iter()
                    .chain(m.normal.iter().flatten())
                    .chain(&m.cost)
            })
            .map(|v| v.to_bits())
            .collect()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a.fused, b.fused);
    assert!(a.fused.len() > 1000, "{} fused points", a.fused.len());
    // Another seed gives other bytes: the seed reaches the hash.
    let c = reconstruct(
        &views,
        &triplet_sources(3),
        &MvsParams {
            seed: 1,
            ..params.clone()
        },
        &mut |_| {},
    )
    .unwrap();
    assert_ne!(bits(&a), bits(&c));
}

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
