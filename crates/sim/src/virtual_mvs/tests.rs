//! Tests of the virtual MVS against its own truth curves and the geometry.

// Depth maps are compared bit for bit: determinism is the point.
#![allow(clippy::float_cmp)]

use nalgebra::{Point2, Point3};
use vp_scene::procedural::{box_mesh, with_material};
use vp_scene::raycast::{RayCaster, FACE_VISIBILITY_EPSILON};
use vp_scene::{Camera, Material, Mesh};

use super::{level_camera, MvsProfile, MvsView, PixelStatus, VirtualMvs};
use crate::test_scenes::{intrinsics, tiled_plane, triplet, uniform_plane};
use vp_scene::triangulation::{point_geometry, triangulation_angle_deg};

fn refs(t: &[Camera; 3]) -> [&Camera; 3] {
    [&t[0], &t[1], &t[2]]
}

fn run(mvs: &VirtualMvs, mesh: &Mesh, cams: &[Camera; 3], level: u8, seed: u64) -> [MvsView; 3] {
    let caster = RayCaster::new(mesh);
    mvs.reconstruct_with_truth(mesh, &caster, refs(cams), level, seed)
        .unwrap()
}

/// The world point of a pixel with the given depth.
fn point_of(cam: &Camera, i: usize, depth: f64) -> Point3<f64> {
    let w = cam.intrinsics.width as usize;
    cam.unproject(
        &Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5),
        depth,
    )
}

const BIN_DEG: f64 = 5.0;

/// Observed success rate against the profile's curve per material and
/// 5-deg angle bin, over several triplets and seeds. Cameras are 30 m away
/// (11 cm/px), coarser than the reference resolution: the curves apply as is.
fn check_success_rates(profile: &MvsProfile) {
    let mvs = VirtualMvs::new(profile.clone()).unwrap();
    let mesh = tiled_plane(140.0, 3.0);
    let k = intrinsics(160, 120);
    // [material][bin] -> (pixels, successes, sum of expected probability)
    let mut acc = [[(0usize, 0usize, 0.0f64); 10]; 5];
    for (t, angle) in [3.0, 12.0, 22.0, 32.0, 42.0].into_iter().enumerate() {
        let cams = triplet(k, 30.0, angle);
        for seed in 0..3u64 {
            let views = run(&mvs, &mesh, &cams, 1, seed * 10 + t as u64);
            for (v, view) in views.iter().enumerate() {
                for (i, px) in view.truth.iter().enumerate() {
                    if !matches!(
                        px.status,
                        PixelStatus::Failed | PixelStatus::Reconstructed | PixelStatus::Outlier
                    ) {
                        continue;
                    }
                    let p = point_of(&cams[v], i, f64::from(px.true_depth));
                    let a = triangulation_angle_deg(&p, &cams.map(|c| c.center()));
                    assert!((a - f64::from(px.angle_deg)).abs() < 1e-3);
                    let m = px.material.unwrap();
                    let e = &mut acc[m as usize][((a / BIN_DEG) as usize).min(9)];
                    e.0 += 1;
                    e.1 += usize::from(px.status != PixelStatus::Failed);
                    e.2 += profile.curve(m).at_angle(a);
                }
            }
        }
    }
    let mut checked = 0;
    for m in Material::ALL {
        for (b, &(n, ok, expected)) in acc[m as usize].iter().enumerate() {
            if n < 2000 {
                continue;
            }
            let (observed, expected) = (ok as f64 / n as f64, expected / n as f64);
            eprintln!(
                "{} {m:?} {:>2}-{:>2} deg: n {n:>6} observed {observed:.3} expected {expected:.3}",
                profile.name,
                b * 5,
                b * 5 + 5
            );
            assert!(
                (observed - expected).abs() < 0.05,
                "{m:?} bin {b}: observed {observed:.3}, profile {expected:.3} over {n} px"
            );
            checked += 1;
        }
    }
    assert!(
        checked >= 20,
        "only {checked} (material, bin) cells had enough pixels"
    );
}

#[test]
fn success_rate_follows_the_sure_like_curves() {
    let mut p = MvsProfile::sure_like();
    // Small blobs: more independent samples per pixel count; blob shape is tested below.
    p.blob_size_px = 1.0;
    check_success_rates(&p);
}

#[test]
fn success_rate_follows_the_pmvs_like_curves() {
    let mut p = MvsProfile::pmvs_like();
    p.blob_size_px = 1.0;
    check_success_rates(&p);
}

#[test]
fn grass_close_up_fails_more_than_grass_from_afar() {
    let mvs = VirtualMvs::new(MvsProfile::sure_like()).unwrap();
    let mesh = uniform_plane(120.0, Material::Grass);
    let rate = |height: f64| {
        let views = run(
            &mvs,
            &mesh,
            &triplet(intrinsics(200, 150), height, 6.0),
            1,
            3,
        );
        let t = &views[0].truth;
        let seen = t
            .iter()
            .filter(|p| p.probability > 0.0 || p.status == PixelStatus::Failed)
            .count();
        let ok = t
            .iter()
            .filter(|p| p.status == PixelStatus::Reconstructed)
            .count();
        ok as f64 / seen as f64
    };
    // 0.6 cm/px against 11 cm/px at the same angle.
    let (near, far) = (rate(1.0), rate(30.0));
    assert!(near < 0.75 * far, "near {near:.3} far {far:.3}");
}

#[test]
fn failures_form_blobs_not_salt_noise() {
    let mvs = VirtualMvs::new(MvsProfile::sure_like()).unwrap();
    let mesh = uniform_plane(120.0, Material::Ground);
    let cams = triplet(intrinsics(240, 180), 30.0, 25.0);
    let views = run(&mvs, &mesh, &cams, 1, 11);
    let (w, h) = (240usize, 180usize);
    let t = &views[0].truth;
    let failed = |x: usize, y: usize| t[y * w + x].status == PixelStatus::Failed;
    let (mut n, mut surrounded, mut salt) = (0usize, 0usize, 0.0f64);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            if !failed(x, y) {
                continue;
            }
            n += 1;
            surrounded += usize::from(
                failed(x - 1, y) && failed(x + 1, y) && failed(x, y - 1) && failed(x, y + 1),
            );
            // Independent failures: all four neighbours fail with prod (1 - p).
            salt += [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)]
                .iter()
                .map(|&(a, b)| 1.0 - f64::from(t[b * w + a].probability))
                .product::<f64>();
        }
    }
    let (share, salt) = (surrounded as f64 / n as f64, salt / n as f64);
    eprintln!(
        "failed pixels {n}: {share:.3} have 4 failed neighbours, salt noise would give {salt:.3}"
    );
    assert!(n > 2000);
    assert!(
        share > 0.5 && share > 5.0 * salt,
        "share {share:.3} salt {salt:.3}"
    );
}

#[test]
fn depth_error_matches_the_predicted_sigma_and_outliers_their_share() {
    let mut profile = MvsProfile::sure_like();
    profile.outlier_share = 0.02;
    let mvs = VirtualMvs::new(profile).unwrap();
    let mesh = uniform_plane(120.0, Material::Rock);
    let cams = triplet(intrinsics(200, 150), 30.0, 15.0);
    let views = run(&mvs, &mesh, &cams, 1, 5);
    let (mut z2, mut n, mut outliers, mut checked) = (0.0, 0usize, 0usize, 0usize);
    for (v, view) in views.iter().enumerate() {
        for (i, px) in view.truth.iter().enumerate() {
            assert_eq!(px.depth, view.depth.data[i]);
            let err = f64::from(px.depth) - f64::from(px.true_depth);
            match px.status {
                PixelStatus::Reconstructed => {
                    z2 += (err / f64::from(px.sigma_depth)).powi(2);
                    n += 1;
                    if i % 997 == 0 {
                        // The sigma is the triplet's first-order uncertainty along the ray.
                        let p = point_of(&cams[v], i, f64::from(px.true_depth));
                        let g = point_geometry(&refs(&cams), &cams[v], &p, 1.0).unwrap();
                        assert!(
                            (g.sigma_depth - f64::from(px.sigma_depth)).abs()
                                < 1e-3 * g.sigma_depth
                        );
                        checked += 1;
                    }
                }
                PixelStatus::Outlier => {
                    outliers += 1;
                    let rel = (err / f64::from(px.true_depth)).abs();
                    assert!((0.099..0.401).contains(&rel), "outlier off by {rel}");
                }
                _ => assert_eq!(px.depth, 0.0),
            }
        }
    }
    let std = (z2 / n as f64).sqrt();
    let share = outliers as f64 / (outliers + n) as f64;
    eprintln!("normalised depth error std {std:.3} over {n} px; outlier share {share:.4}");
    assert!((0.8..1.2).contains(&std), "std of error / sigma = {std}");
    assert!((share - 0.02).abs() < 0.004, "outlier share {share}");
    assert!(checked > 10);
}

#[test]
fn no_depth_where_another_camera_cannot_see_the_point() {
    let mvs = VirtualMvs::new(MvsProfile::sure_like()).unwrap();
    let mut mesh = tiled_plane(120.0, 3.0);
    // A tall block that hides ground from some cameras, and views that overlap only in part.
    mesh.append(&with_material(
        box_mesh(Point3::new(-3.0, -2.0, 0.0), Point3::new(2.0, 3.0, 8.0)),
        Material::Rock,
    ));
    let k = intrinsics(160, 120);
    let cams = [
        Camera::look_at(
            k,
            Point3::new(-12.0, 0.0, 20.0),
            Point3::new(-4.0, 0.0, 0.0),
        )
        .unwrap(),
        Camera::look_at(k, Point3::new(12.0, 0.0, 20.0), Point3::new(4.0, 0.0, 0.0)).unwrap(),
        Camera::look_at(k, Point3::new(0.0, 14.0, 20.0), Point3::new(0.0, 5.0, 0.0)).unwrap(),
    ];
    let caster = RayCaster::new(&mesh);
    let views = mvs
        .reconstruct_with_truth(&mesh, &caster, refs(&cams), 1, 2)
        .unwrap();
    let mut hidden = 0;
    for (v, view) in views.iter().enumerate() {
        for (i, px) in view.truth.iter().enumerate() {
            hidden += usize::from(px.status == PixelStatus::NotVisible);
            if view.depth.data[i] == 0.0 {
                continue;
            }
            // The surface point under the pixel, lifted off its face towards
            // the query camera (M1 visibility's epsilon, against f32 round-off).
            let w = cams[v].intrinsics.width as usize;
            let (o, d) = cams[v].ray(&Point2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5));
            let hit = caster.closest_hit(&o, &d, f64::INFINITY).unwrap();
            let mut n = mesh.face_normal(hit.face as usize);
            if n.dot(&d) > 0.0 {
                n = -n;
            }
            let lifted = hit.point + n * FACE_VISIBILITY_EPSILON;
            for c in &cams {
                assert!(
                    c.project_in_frame(&hit.point).is_some(),
                    "view {v} pixel {i}: outside a frame"
                );
                assert!(
                    !caster.occluded(&c.center(), &lifted),
                    "view {v} pixel {i}: occluded"
                );
            }
        }
    }
    assert!(
        hidden > 3000,
        "the scene should hide many pixels, hid {hidden}"
    );
}

#[test]
fn pyramid_levels_have_the_right_sizes() {
    let mvs = VirtualMvs::new(MvsProfile::sure_like()).unwrap();
    let mesh = tiled_plane(100.0, 3.0);
    let caster = RayCaster::new(&mesh);
    let cams = triplet(intrinsics(321, 241), 30.0, 10.0);
    for (level, size) in [(1u8, (321, 241)), (2, (161, 121)), (3, (80, 60))] {
        let maps = mvs
            .reconstruct(&mesh, &caster, refs(&cams), level, 0)
            .unwrap();
        for m in &maps {
            assert_eq!((m.width, m.height), size, "level {level}");
            assert_eq!(m.data.len(), size.0 as usize * size.1 as usize);
            assert!(m.stats().valid_share > 0.3);
        }
        assert_eq!(
            level_camera(&cams[0], level).unwrap().intrinsics.width,
            size.0
        );
    }
    let msg = mvs
        .reconstruct(&mesh, &caster, refs(&cams), 0, 0)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("level 0"), "{msg}");
}

#[test]
fn reconstruction_is_seeded_and_thread_count_independent() {
    let mvs = VirtualMvs::new(MvsProfile::sure_like()).unwrap();
    let mesh = tiled_plane(100.0, 3.0);
    let caster = RayCaster::new(&mesh);
    let cams = triplet(intrinsics(120, 90), 30.0, 20.0);
    let a = mvs.reconstruct(&mesh, &caster, refs(&cams), 2, 42).unwrap();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = one.install(|| mvs.reconstruct(&mesh, &caster, refs(&cams), 2, 42).unwrap());
    assert_eq!(a, b);
    let c = mvs.reconstruct(&mesh, &caster, refs(&cams), 2, 43).unwrap();
    assert_ne!(a, c);
    let bytes = |m: &[vp_scene::colmap::DepthMap; 3]| {
        m.iter()
            .flat_map(|d| d.data.iter().map(|v| v.to_bits()))
            .collect::<Vec<_>>()
    };
    assert_eq!(bytes(&a), bytes(&b));
}

#[test]
fn an_invalid_profile_is_refused() {
    let mut p = MvsProfile::sure_like();
    p.outlier_share = 1.5;
    let msg = VirtualMvs::new(p).unwrap_err().to_string();
    assert!(msg.contains("outlier_share"), "{msg}");
}
