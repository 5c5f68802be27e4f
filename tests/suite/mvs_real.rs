//! vp-mvs on real photos: its depth maps against the sparse points COLMAP
//! triangulated from the same images (tests/data/real-mvs/visp-cube, see its
//! SOURCE.md). The bar: median relative depth error <= 1 %, at least
//! 80 % of the points within 2 %. `benches/peer/sparse_agreement.py` is the
//! independent Python reference of the same score.

use std::collections::BTreeSet;
use std::path::Path;

use vpctl_suite::mvs::{run_workspace, RunOptions};
use vpctl_suite::scene::colmap;
use vpctl_suite::scene::triangulation::triangulation_angle_deg;

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let dest = to.join(path.file_name().unwrap());
        if path.is_dir() {
            copy_dir(&path, &dest);
        } else {
            std::fs::copy(&path, &dest).unwrap();
        }
    }
}

/// Relative errors |z_map - z| / z of every well-triangulated sparse point
/// (a track of at least 3 images, a reprojection error of at most 1 px, a
/// triangulation angle of at least 10 deg) in every image that observes it;
/// a pixel without depth counts as an infinite error.
fn relative_errors(ws: &Path) -> Vec<f64> {
    let rec = colmap::read_model(&ws.join("sparse")).unwrap();
    let mut errors = Vec::new();
    for point in rec.points.values() {
        let images: BTreeSet<u32> = point.track.iter().map(|&(i, _)| i).collect();
        let centres: Vec<_> = images.iter().map(|i| rec.images[i].center()).collect();
        if images.len() < 3
            || !(0.0..=1.0).contains(&point.error)
            || triangulation_angle_deg(&point.xyz, &centres) < 10.0
        {
            continue;
        }
        for &id in &images {
            let camera = rec.camera_of(id).unwrap();
            let z = camera.world_from_cam.inverse_transform_point(&point.xyz).z;
            let name = &rec.images[&id].name;
            let map = colmap::read_depth_map(
                &ws.join("stereo/depth_maps")
                    .join(format!("{name}.geometric.bin")),
            )
            .unwrap();
            let depth = camera
                .project(&point.xyz)
                .filter(|px| px.x >= 0.0 && px.y >= 0.0)
                .and_then(|px| map.get(px.x.floor() as u32, px.y.floor() as u32))
                .filter(|d| *d > 0.0);
            errors.push(depth.map_or(f64::INFINITY, |d| (f64::from(d) - z).abs() / z));
        }
    }
    errors
}

#[test]
#[ignore = "about 2 min; scripts/test.sh runs it in its long-run steps"]
fn vp_mvs_depth_agrees_with_colmap_sparse_points_on_real_photos() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real-mvs/visp-cube");
    let tmp = tempfile::tempdir().unwrap();
    let ws = tmp.path().join("ws");
    copy_dir(&data, &ws);
    let summary = run_workspace(&ws, &RunOptions::default(), &mut |_| {}).unwrap();
    assert_eq!(summary.reconstructed.len(), 9);

    let mut errors = relative_errors(&ws);
    assert!(errors.len() > 5000, "{} scored observations", errors.len());
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    let within = |t: f64| errors.iter().filter(|&&e| e <= t).count() as f64 / errors.len() as f64;
    println!(
        "{} observations: median relative error {:.3} %, within 1 % {:.1} %, within 2 % {:.1} %",
        errors.len(),
        100.0 * median,
        100.0 * within(0.01),
        100.0 * within(0.02)
    );
    assert!(median <= 0.01, "median relative depth error {median}");
    assert!(within(0.02) >= 0.8, "within 2 %: {}", within(0.02));
}
