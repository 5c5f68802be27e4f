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
