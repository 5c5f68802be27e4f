//! `vpctl mvs run` as a user runs it: the COLMAP workspace layout, triplets, bad input.

use std::path::Path;

mod common;

use common::{stderr, stdout, vpctl};

/// A COLMAP dense workspace of three rendered 128x96 views of a small
/// site, without 3D points; returns a depth range covering the views.
fn mvs_workspace(dir: &Path) -> (f64, f64) {
    use vp_scene::colmap::{self, CameraModel, ColmapCamera, ColmapImage, Reconstruction};
    let site = vp_scene::procedural::generate_site(&vp_scene::procedural::SiteParams {
        seed: 2,
        target_faces: 20_000,
        ..Default::default()
    })
    .unwrap();
    let caster = vp_scene::raycast::RayCaster::new(&site.mesh);
    let k = vp_scene::Intrinsics::from_hfov(128, 96, 60.0).unwrap();
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let mut rec = Reconstruction::default();
    rec.cameras.insert(
        1,
        ColmapCamera {
            id: 1,
            model: CameraModel::Pinhole,
            width: 128,
            height: 96,
            params: vec![k.fx, k.fy, k.cx, k.cy],
        },
    );
    let target = nalgebra::Point3::new(0.0, 0.0, 2.0);
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for i in 0..3u32 {
        let a = f64::from(i) * 2.1;
        let centre = nalgebra::Point3::new(-12.0 + 2.5 * a.cos(), -12.0 + 2.5 * a.sin(), 18.0);
        let cam = vp_scene::Camera::look_at(k, centre, target).unwrap();
        let r =
            vp_sim::render(&site.mesh, &caster, &cam, &vp_sim::RenderParams::default()).unwrap();
        for &d in r.depth.data.iter().filter(|&&d| d > 0.0) {
            lo = lo.min(f64::from(d));
            hi = hi.max(f64::from(d));
        }
        let name = format!("im{i}.png");
        r.rgb.save(dir.join("images").join(&name)).unwrap();
        rec.images.insert(
            i + 1,
            ColmapImage {
                id: i + 1,
                camera_id: 1,
                name,
                cam_from_world: cam.cam_from_world(),
                points2d: Vec::new(),
            },
        );
    }
    colmap::write_text(&dir.join("sparse"), &rec).unwrap();
    (0.8 * lo, 1.2 * hi)
}

#[test]
fn mvs_run_writes_colmap_layout_and_refuses_bad_input() {
    let o = vpctl(&["mvs", "defaults"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let defaults = stdout(&o);
    assert!(defaults.contains("# Geometric filter"), "{defaults}");
    let parsed = vp_mvs::MvsParams::from_toml(&defaults, Path::new("defaults")).unwrap();
    assert_eq!(parsed, vp_mvs::MvsParams::default());

    let dir = tempfile::tempdir().unwrap();
    let ws = dir.path().join("ws");
    let (lo, hi) = mvs_workspace(&ws);
    let config = dir.path().join("mvs.toml");
    std::fs::write(&config, "iterations = 3\n").unwrap();
    let range = format!("{lo},{hi}");
    let ws_str = ws.to_str().unwrap();
    let cfg_str = config.to_str().unwrap();
    let args = [
        "mvs",
        "run",
        "--workspace",
        ws_str,
        "--depth-range",
        &range,
        "--config",
        cfg_str,
        "--images",
        "im0.png,im1.png,im2.png",
        "--seed",
        "4",
    ];
    let o = vpctl(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("fused: "), "{}", stdout(&o));
    assert!(stderr(&o).contains("patch match: 3/3"), "{}", stderr(&o));
    for i in 0..3 {
        for kind in ["photometric", "geometric"] {
            let d = ws.join(format!("stereo/depth_maps/im{i}.png.{kind}.bin"));
            assert!(vp_scene::colmap::read_depth_map(&d).unwrap().stats().valid > 0);
            assert!(ws
                .join(format!("stereo/normal_maps/im{i}.png.{kind}.bin"))
                .is_file());
        }
    }
    let fused = std::fs::read(ws.join("fused.ply")).unwrap();
    // Existing output is not overwritten without --force.
    let o = vpctl(&args);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let mut forced = args.to_vec();
    forced.push("--force");
    let o = vpctl(&forced);
    assert!(o.status.success(), "{}", stderr(&o));
    // Same seed, same bytes.
    assert_eq!(std::fs::read(ws.join("fused.ply")).unwrap(), fused);

    // Bad input: exit 2 and a message naming the problem.
    let bad_range = format!("{hi},{lo}");
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws_str,
        "--depth-range",
        &bad_range,
        "--force",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("empty or inverted"), "{}", stderr(&o));
    let o = vpctl(&["mvs", "run", "--workspace", ws_str, "--force"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--depth-range"), "{}", stderr(&o));
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws_str,
        "--depth-range",
        &range,
        "--images",
        "im0.png",
        "--force",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("at least two"), "{}", stderr(&o));
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        dir.path().join("none").to_str().unwrap(),
        "--depth-range",
        &range,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn mvs_run_triplets_writes_the_layout_labelgen_reads() {
    use vp_labelgen::triplets::{write_triplet_list, Triplet};
    let dir = tempfile::tempdir().unwrap();
    let ws = dir.path().join("ws");
    let (lo, hi) = mvs_workspace(&ws);
    let list = dir.path().join("triplets.json");
    let images = ["im0.png", "im1.png", "im2.png"].map(String::from);
    write_triplet_list(
        &list,
        &[Triplet {
            bin: 1,
            angle_deg: 10.0,
            images,
        }],
    )
    .unwrap();
    let config = dir.path().join("mvs.toml");
    std::fs::write(&config, "iterations = 2\n").unwrap();
    let depth = dir.path().join("depth");
    let range = format!("{lo},{hi}");
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws.to_str().unwrap(),
        "--triplets",
        list.to_str().unwrap(),
        "--levels",
        "1,2",
        "--out",
        depth.to_str().unwrap(),
        "--depth-range",
        &range,
        "--config",
        config.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for (level, w, h) in [(1, 128, 96), (2, 64, 48)] {
        for i in 0..3 {
            let p = depth.join(format!("t0000/level{level}/im{i}.png.geometric.bin"));
            let d = vp_scene::colmap::read_depth_map(&p).unwrap();
            assert_eq!((d.width, d.height), (w, h));
            assert!(d.stats().valid > 0, "{}", p.display());
        }
    }
    // A triplet naming an unknown image: exit 2, nothing written.
    let images = ["im0.png", "im1.png", "ghost.png"].map(String::from);
    write_triplet_list(
        &list,
        &[Triplet {
            bin: 1,
            angle_deg: 10.0,
            images,
        }],
    )
    .unwrap();
    let out2 = dir.path().join("depth2");
    let o = vpctl(&[
        "mvs",
        "run",
        "--workspace",
        ws.to_str().unwrap(),
        "--triplets",
        list.to_str().unwrap(),
        "--out",
        out2.to_str().unwrap(),
        "--depth-range",
        &range,
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("t0000") && stderr(&o).contains("ghost.png"),
        "{}",
        stderr(&o)
    );
    assert!(!out2.exists());
}

/// Regression (issue 39): `mvs run --triplets --out <folder> --force` wrote
/// into any folder, the current one or the workspace's parent included.
#[test]
fn mvs_run_triplets_never_deletes_what_it_did_not_write() {
    use vp_labelgen::triplets::{write_triplet_list, Triplet};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (lo, hi) = mvs_workspace(&d.join("in/ws"));
    let images = ["im0.png", "im1.png", "im2.png"].map(String::from);
    write_triplet_list(
        &d.join("in/triplets.json"),
        &[Triplet {
            bin: 1,
            angle_deg: 10.0,
            images,
        }],
    )
    .unwrap();
    std::fs::write(d.join("in/mvs.toml"), "iterations = 1\n").unwrap();
    let range = format!("{lo},{hi}");
    common::assert_output_guards(
        d,
        &[
            "mvs",
            "run",
            "--workspace",
            "in/ws",
            "--triplets",
            "in/triplets.json",
            "--depth-range",
            &range,
            "--config",
            "in/mvs.toml",
        ],
        "in",
    );
}

/// `--algorithm sgm` runs the semi-global matcher through the same
/// workspace path (maps, fused.ply); a bad matcher name, a bad `[sgm]` key
/// and a depth range that needs too many disparities exit 2 with nothing
/// written.
#[test]
fn mvs_run_algorithm_sgm_writes_the_same_layout() {
    let o = vpctl(&["mvs", "defaults"]);
    assert!(stdout(&o).contains("\n[sgm]\n"), "{}", stdout(&o));
    assert!(stdout(&o).contains("algorithm = \"patchmatch\""));
    let dir = tempfile::tempdir().unwrap();
    let ws = dir.path().join("ws");
    let (lo, hi) = mvs_workspace(&ws);
    let range = format!("{lo},{hi}");
    let ws_str = ws.to_str().unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["mvs", "run", "--workspace", ws_str, "--depth-range", &range];
        args.extend_from_slice(extra);
        vpctl(&args)
    };
    let o = run(&["--algorithm", "sgmx"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("patchmatch, sgm"), "{}", stderr(&o));
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[sgm]\nbogus = 1\n").unwrap();
    let o = run(&["--algorithm", "sgm", "--config", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("bogus"), "{}", stderr(&o));
    let narrow = dir.path().join("narrow.toml");
    std::fs::write(&narrow, "[sgm]\nmax_disparities = 4\n").unwrap();
    let o = run(&["--algorithm", "sgm", "--config", narrow.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("sgm.max_disparities"), "{}", stderr(&o));
    assert!(!ws.join("fused.ply").exists() && !ws.join("stereo").exists());

    let o = run(&["--algorithm", "sgm"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("semi-global matching: 3/3"),
        "{}",
        stderr(&o)
    );
    for i in 0..3 {
        for kind in ["photometric", "geometric"] {
            let d = ws.join(format!("stereo/depth_maps/im{i}.png.{kind}.bin"));
            let valid = vp_scene::colmap::read_depth_map(&d).unwrap().stats().valid;
            assert!(valid > 0, "{}: {}", d.display(), stdout(&o));
        }
    }
    let fused = std::fs::read(ws.join("fused.ply")).unwrap();
    // Same input, same bytes.
    let o = run(&["--algorithm", "sgm", "--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(ws.join("fused.ply")).unwrap(), fused);
}
