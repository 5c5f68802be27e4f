//! vp-mvs on a COLMAP dense workspace written to disk: the outputs in
//! COLMAP's layout, and bad input refused with the file and the problem,
//! leaving nothing behind.

use std::path::Path;

use vpctl_suite::mvs::{run_workspace, MvsParams, RunOptions};
use vpctl_suite::scene::camera::Intrinsics;
use vpctl_suite::scene::colmap::{self, CameraModel, ColmapCamera, ColmapImage, Reconstruction};
use vpctl_suite::scene::raycast::RayCaster;

use crate::mvs::{render_views, site, triplet_cameras};

/// A workspace with three rendered 160x120 views of the site (no sparse
/// points: runs need a depth range). Returns the depth range to use.
pub fn make_workspace(dir: &Path, model: CameraModel) -> (f64, f64) {
    let site = site();
    let caster = RayCaster::new(&site.mesh);
    let k = Intrinsics::from_hfov(160, 120, 60.0).unwrap();
    let cams = triplet_cameras(&site, k, 26.0, 55.0, 30.0, 12.0);
    let (views, _) = render_views(&site, &caster, &cams);
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let mut rec = Reconstruction::default();
    let params = match model {
        CameraModel::Pinhole => vec![k.fx, k.fy, k.cx, k.cy],
        CameraModel::SimpleRadial => vec![k.fx, k.cx, k.cy, 0.01],
        _ => unreachable!(),
    };
    rec.cameras.insert(
        1,
        ColmapCamera {
            id: 1,
            model,
            width: 160,
            height: 120,
            params,
        },
    );
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for (i, v) in views.iter().enumerate() {
        let name = format!("im{i}.png");
        v.rgb.save(dir.join("images").join(&name)).unwrap();
        rec.images.insert(
            i as u32 + 1,
            ColmapImage {
                id: i as u32 + 1,
                camera_id: 1,
                name,
                cam_from_world: v.camera.cam_from_world(),
                points2d: Vec::new(),
            },
        );
        lo = lo.min(v.depth_range.0);
        hi = hi.max(v.depth_range.1);
    }
    colmap::write_text(&dir.join("sparse"), &rec).unwrap();
    (lo, hi)
}

fn options(range: (f64, f64)) -> RunOptions {
    RunOptions {
        images: None,
        depth_range: Some(range),
        params: MvsParams {
            iterations: 3,
            ..MvsParams::default()
        },
    }
}

/// Files under `dir` other than the inputs (images/, sparse/).
fn outputs(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        if name != "images" && name != "sparse" {
            out.push(name);
        }
    }
    out
}

#[test]
fn workspace_run_writes_colmap_layout_that_vp_scene_reads() {
    let dir = tempfile::tempdir().unwrap();
    let range = make_workspace(dir.path(), CameraModel::Pinhole);
    let summary = run_workspace(dir.path(), &options(range), &mut |_| {}).unwrap();
    assert_eq!(summary.reconstructed, ["im0.png", "im1.png", "im2.png"]);
    let stereo = dir.path().join("stereo");
    for name in &summary.reconstructed {
        for kind in ["photometric", "geometric"] {
            let d = colmap::read_depth_map(
                &stereo.join("depth_maps").join(format!("{name}.{kind}.bin")),
            )
            .unwrap();
            assert_eq!((d.width, d.height), (160, 120));
            let n = colmap::read_normal_map(
                &stereo
                    .join("normal_maps")
                    .join(format!("{name}.{kind}.bin")),
            )
            .unwrap();
            // Every valid depth has a unit normal; nearly all face the
            // camera's axis (a grazing normal at the image border may not).
            let (mut valid, mut facing) = (0usize, 0usize);
            for (dv, nv) in d.data.iter().zip(&n.data) {
                if *dv > 0.0 {
                    let len = (nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]).sqrt();
                    assert!((len - 1.0).abs() < 1e-3, "{nv:?}");
                    valid += 1;
                    facing += usize::from(nv[2] < 0.0);
                }
            }
            assert!(facing as f64 >= 0.95 * valid as f64, "{facing} of {valid}");
        }
    }
    assert!(
        summary.geometric_valid_share.iter().all(|&s| s > 0.3),
        "{summary:?}"
    );
    let cloud = vpctl_suite::scene::io::load_mesh_raw(&summary.fused_path).unwrap();
    assert_eq!(cloud.n_vertices(), summary.fused_points);
    assert!(summary.fused_points > 1000);
    // No temporary files left.
    let leftovers: Vec<_> = std::fs::read_dir(dir.path().join("stereo/depth_maps"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn bad_workspaces_are_refused_naming_file_and_problem_leaving_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let range = make_workspace(root, CameraModel::Pinhole);
    let err = |opts: &RunOptions| {
        run_workspace(root, opts, &mut |_| {})
            .unwrap_err()
            .to_string()
    };

    // Empty and inverted depth ranges.
    let e = err(&options((range.1, range.0)));
    assert!(e.contains("empty or inverted"), "{e}");
    let e = err(&options((5.0, 5.0)));
    assert!(e.contains("empty or inverted"), "{e}");
    let e = err(&options((-1.0, 5.0)));
    assert!(e.contains("min must be > 0"), "{e}");
    // No depth range and no sparse points.
    let e = err(&RunOptions {
        depth_range: None,
        ..options(range)
    });
    assert!(
        e.contains("sees no sparse points") && e.contains("--depth-range"),
        "{e}"
    );
    // Fewer than two images; unknown image.
    let e = err(&RunOptions {
        images: Some(vec!["im0.png".into()]),
        ..options(range)
    });
    assert!(e.contains("at least two"), "{e}");
    let e = err(&RunOptions {
        images: Some(vec!["im0.png".into(), "nope.png".into()]),
        ..options(range)
    });
    assert!(e.contains("'nope.png' is not in the model"), "{e}");
    // Image size different from its camera.
    let im1 = root.join("images/im1.png");
    let good = std::fs::read(&im1).unwrap();
    image::RgbImage::new(100, 80).save(&im1).unwrap();
    let e = err(&options(range));
    assert!(
        e.contains("im1.png") && e.contains("100x80") && e.contains("160x120"),
        "{e}"
    );
    // Unreadable image.
    std::fs::write(&im1, b"not a png").unwrap();
    let e = err(&options(range));
    assert!(
        e.contains("im1.png") && e.contains("cannot read image"),
        "{e}"
    );
    // Missing image.
    std::fs::remove_file(&im1).unwrap();
    let e = err(&options(range));
    assert!(
        e.contains("im1.png") && e.contains("cannot read image"),
        "{e}"
    );
    std::fs::write(&im1, good).unwrap();
    assert!(outputs(root).is_empty(), "{:?}", outputs(root));

    // A distorted model.
    let dir2 = tempfile::tempdir().unwrap();
    let range = make_workspace(dir2.path(), CameraModel::SimpleRadial);
    let e = run_workspace(dir2.path(), &options(range), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cameras.txt") && e.contains("SIMPLE_RADIAL") && e.contains("undistort"),
        "{e}"
    );
    assert!(outputs(dir2.path()).is_empty());
}

#[test]
fn patch_match_cfg_chooses_the_sources() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let range = make_workspace(root, CameraModel::Pinhole);
    std::fs::create_dir_all(root.join("stereo")).unwrap();
    // im2 has no source line: it is only a source.
    std::fs::write(
        root.join("stereo/patch-match.cfg"),
        "im0.png\nim1.png, im2.png\nim1.png\n__all__\n",
    )
    .unwrap();
    let s = run_workspace(root, &options(range), &mut |_| {}).unwrap();
    assert_eq!(s.reconstructed, ["im0.png", "im1.png"]);
    std::fs::write(
        root.join("stereo/patch-match.cfg"),
        "im0.png\nim1.png, ghost.png\n",
    )
    .unwrap();
    let e = run_workspace(root, &options(range), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("patch-match.cfg") && e.contains("'ghost.png'"),
        "{e}"
    );
}
